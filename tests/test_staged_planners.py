"""The staged planners of :mod:`footstep_gym.planners.staged` end to end, and their registry.

The end-to-end claims are success rates over :data:`SEEDS` (a rule, the first seeds of the train split, not
seeds picked by outcome) held to a stated bound (:data:`RATE`): one seed decides nothing. On another CPU
numpy's SIMD kernels (and libm's code path) round some of the planners' floats an ulp otherwise; an outcome
could change only through a decision within a few ulps of a tie.
"""

from __future__ import annotations

import gymnasium as gym
import pytest

import footstep_gym  # noqa: F401  (registers the envs)

#: The episode seeds of the end-to-end tests: the first ten of the train split (configs/eval.yaml's ``train``),
#: whatever their outcome. Each seed draws a different start (the door's phase, the car's and the crowd's places).
SEEDS = range(10)
#: [share of SEEDS] A planner passes a scene when it reaches the goal on at least this share of the seeds, and
#: fails it when it reaches the goal on at most ``1 - RATE``.
RATE = 0.9


# ====================================================================== the policies end to end
def run_policy(name: str, env_id: str, seeds=SEEDS, **env_kwargs) -> list[dict]:
    """One episode of policy ``name`` on ``env_id`` per seed: each episode's final step's info, with the periods
    of its commands (``policy.last_info["period"]``, [s]) as ``"periods"``."""
    from footstep_gym import make_policy

    env = gym.make(env_id, **env_kwargs)
    policy = make_policy(name, env.unwrapped.robot)
    ends = []
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        policy.reset(seed=seed)
        periods = []
        while True:
            obs, _, terminated, truncated, info = env.step(policy.act(obs, env.unwrapped.sensing()))
            periods.append(policy.last_info["period"])
            if terminated or truncated:
                ends.append({**info, "periods": periods})
                break
    env.close()
    return ends


def success_rate(ends: list[dict]) -> float:
    """The share of episodes that reached the goal (``is_success`` and a ``"goal"`` termination agree)."""
    assert all(bool(e["is_success"]) == (e["termination"] == "goal") for e in ends)
    return sum(e["termination"] == "goal" for e in ends) / len(ends)


@pytest.mark.parametrize("env_id, kwargs", [
    ("FootstepDoor-v0", {"door_speed": 17.0}),
    ("FootstepCrossing-v0", {}),
    ("FootstepCrowd-v0", {}),
])
def test_period_aware_planner_reaches_the_goal_in_each_env(env_id, kwargs):
    ends = run_policy("period-aware", env_id, **kwargs)
    assert success_rate(ends) >= RATE, [e["termination"] for e in ends]


def test_fixed_period_planner_passes_a_slow_door_and_not_a_fast_one_that_period_aware_passes():
    """The paper's Fig. 8 over :data:`SEEDS`: at T_n the robot crosses the disc turning at 5 deg/s and not at
    14 deg/s, which the period-aware planner crosses by shortening the period."""
    slow, fast = (run_policy("fixed-period", "FootstepDoor-v0", door_speed=v) for v in (5.0, 14.0))
    assert success_rate(slow) >= RATE, [e["termination"] for e in slow]
    assert success_rate(fast) <= 1.0 - RATE, [e["termination"] for e in fast]
    assert {e["termination"] for e in fast} <= {"goal", "collision"}  # a failure here is the door's, not a fall
    assert all(e["periods"] == pytest.approx([0.8] * len(e["periods"])) for e in slow + fast)  # T_n throughout
    aware = run_policy("period-aware", "FootstepDoor-v0", door_speed=14.0)
    assert success_rate(aware) >= RATE, [e["termination"] for e in aware]
    assert all(min(e["periods"]) < 0.8 for e in aware if e["termination"] == "goal")


# ====================================================================== the registry and the ablation variants
def test_registry_has_the_paper_planners_beside_ours():
    from footstep_gym.planners import POLICIES

    assert {"period-aware", "fixed-period", "pso-only", "paper-period-aware", "paper-fixed-period", "lattice",
            "oracle"} <= set(POLICIES)  # the oracle: an upper bound that reads the true future, not a baseline


def test_variant_names_switch_one_addition_off():
    import dataclasses

    from footstep_gym import make_policy
    from footstep_gym.planners import ablation_variants
    from footstep_gym.planners.params import AdditionsParams

    switches = [f.name for f in dataclasses.fields(AdditionsParams)]
    names = ablation_variants()
    n = len(switches)
    assert names[0] == "period-aware" and names[n + 1] == "paper-period-aware" and len(names) == 2 * n + 2
    for switch, name in zip(switches, names[1:n + 1]):
        assert name == "period-aware-no-" + switch.replace("_", "-")
        policy = make_policy(name, seed=0)
        assert policy.name == name
        off = [s for s in switches if not getattr(policy.config.additions, s)]
        assert off == [switch]
    fixed = make_policy("fixed-period-no-fallback")
    assert not fixed.vary_period and not fixed.config.additions.fallback


def test_with_names_switch_one_addition_on_in_the_papers_planner():
    """``paper-period-aware-with-<switch>``: the paper's planner (its readings kept) with that one addition on."""
    import dataclasses

    from footstep_gym import make_policy
    from footstep_gym.planners import ablation_variants
    from footstep_gym.planners.params import AdditionsParams
    from footstep_gym.registry import resolve

    switches = [f.name for f in dataclasses.fields(AdditionsParams)]
    paper = make_policy("paper-period-aware").config
    names = ablation_variants()[len(switches) + 2:]
    assert len(names) == len(switches)
    for switch, name in zip(switches, names):
        assert name == "paper-period-aware-with-" + switch.replace("_", "-") and resolve(name).kind == "planner"
        assert resolve(name).description == f"paper-period-aware with the addition {switch} on"
        policy = make_policy(name, seed=0)
        assert policy.name == name and policy.vary_period
        on = [s for s in switches if getattr(policy.config.additions, s)]
        assert on == [switch]
        assert dataclasses.replace(policy.config, additions=paper.additions) == paper  # the paper's readings kept
    fixed = make_policy("paper-fixed-period-with-fallback")
    assert not fixed.vary_period and fixed.config.additions.fallback
    for bad in ("paper-period-aware-with-nothing", "pso-only-with-fallback", "paper-period-aware-with-"):
        with pytest.raises(ValueError, match="unknown policy"):
            resolve(bad)


@pytest.mark.parametrize("name", ["period-aware-no-such-thing", "pso-only-no-fallback", "nonsense",
                                  "paper-period-aware-no"])
def test_unknown_names_are_rejected_with_the_known_ones(name):
    from footstep_gym import make_policy

    with pytest.raises(ValueError, match="known: .*period-aware-no-waiting-walks"):
        make_policy(name)


@pytest.mark.parametrize("name", ["paper-period-aware", "paper-fixed-period"])
def test_paper_planners_walk_to_the_goal_when_nothing_is_in_the_way(name):
    """The crossing with its car crossing 5 m away (beyond the goal): on every one of the first seeds, both paper
    planners walk the 1.9 m straight to the goal at the nominal period, in full 10 cm strides (19-20 steps),
    without the PSO. Nothing is in the way, so no seed may fail."""
    from footstep_gym import make_policy

    env = gym.make("FootstepCrossing-v0", crossing_x=5.0)
    policy = make_policy(name, env.unwrapped.robot)
    for seed in SEEDS[:3]:
        obs, _ = env.reset(seed=seed)
        policy.reset(seed=seed)
        periods = []
        while True:
            obs, _, terminated, truncated, info = env.step(policy.act(obs, env.unwrapped.sensing()))
            periods.append(policy.last_info["period"])
            assert not policy.last_info["pso_ran"], seed
            if terminated or truncated:
                break
        assert info["termination"] == "goal" and 19 <= info["steps"] <= 20, (seed, info["termination"], info["steps"])
        assert periods == pytest.approx([0.8] * len(periods)), seed
    env.close()


def test_every_ablation_variant_plans_an_episode_start():
    """Each variant of the ablation plans a few steps of the crowd with the same interface and reports its stages."""
    from footstep_gym import make_policy
    from footstep_gym.planners import ablation_variants

    env = gym.make("FootstepCrowd-v0")
    for name in ablation_variants():
        policy = make_policy(name, env.unwrapped.robot, seed=1)
        obs, _ = env.reset(seed=1)
        policy.reset(seed=1)
        for _ in range(3):
            obs, _, terminated, _, _ = env.step(policy.act(obs, env.unwrapped.sensing()))
            info = policy.last_info
            assert info["policy"] == name and info["period"] > 0
            assert {"time_period_search_ms", "time_rrt_ms", "time_pso_ms", "period_search"} <= set(info)
            if terminated:
                break
    env.close()
