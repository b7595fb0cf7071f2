"""The oracle: period-aware told the truth, an upper bound that reads it only through bind_truth.

* it is registered with a description saying it is an upper bound, and it is the only registered policy that
  declares ``reads_truth``; the evaluation runner binds it (and nothing else) to the env;
* unbound it refuses to act; bound it ignores the snapshot it is passed (sensing noise included) and reads
  the true one off the env;
* its truth is the env's own: the poses it predicts at the ends of the steps of a walk of period T are where
  the env puts the obstacles (scripted crowd, door, steady traffic exactly; ORCA to float32 when the robot is
  invisible to the pedestrians);
* where what period-aware senses misleads its prediction (sensing noise, the door and the scripted crowd), the
  oracle reaches the goal at least as often as period-aware, and on nearly every episode, over the first seeds
  of the validation split (:data:`RATE_SEEDS`, whatever their outcome; :data:`ORACLE_RATE`). On the noise-free
  crowd it is not an upper bound episode by episode (as greedy as period-aware, it loses a few; see the
  module doc of :mod:`footstep_gym.planners.oracle`), so no test claims that.
"""

from __future__ import annotations

import ast
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import make_policy
from footstep_gym.evaluation.runner import Cell, Task, bind_truth, run_episode
from footstep_gym.kernels import select_kernels
from footstep_gym.planners import POLICIES
from footstep_gym.planners.oracle import OraclePlanner, TruthBody, TruthModel, TruthPredictor, true_snapshot
from footstep_gym.policy import Policy
from footstep_gym.registry import resolve
from footstep_gym.rl import AGENTS, ZooAgent

REPO = Path(__file__).resolve().parents[1]
#: The episodes of the success-rate tests: the first seeds of the validation split (configs/eval.yaml's
#: ``validation``), whatever their outcome.
RATE_SEEDS = range(10000, 10008)
#: [share of RATE_SEEDS] The oracle reaches the goal on at least this share where sensing noise misleads
#: period-aware's prediction (the hard tier's noisy cells).
ORACLE_RATE = 0.85
#: The sensing noise of the hard tier's noisy cells (configs/benchmark.yaml's ``x-noise``: Gaussian stds [m, m/s,
#: rad, rad/s] of the moving obstacles' sensed state).
NOISE = dict(sensing_noise_position=0.02, sensing_noise_velocity=0.05, sensing_noise_angle=0.01,
             sensing_noise_angular_velocity=0.01)


# ---------------------------------------------------------------- registry: labelled, and the only one
def test_the_oracle_is_registered_as_an_upper_bound_and_alone_in_reading_the_truth():
    spec = POLICIES["oracle"]
    assert spec.planner is OraclePlanner and spec.description.startswith("UPPER BOUND, not a baseline")
    assert resolve("oracle").description == spec.description and resolve("oracle").reads_truth
    assert spec.readings["kernels"] == {"compiled": False}  # numpy: the compiled kernels assume constant velocity
    readers = [name for name, s in POLICIES.items() if getattr(s.planner, "reads_truth", False)]
    assert readers == ["oracle", "oracle-lookahead"]  # the two privileged solvers (protocol 3)
    assert not any(resolve(name).reads_truth for name in AGENTS)
    assert not hasattr(Policy, "reads_truth") and not hasattr(ZooAgent, "reads_truth")
    assert not resolve("period-aware-no-fallback").reads_truth and not resolve("agent:mine").reads_truth


def test_the_oracle_refuses_to_act_unbound_and_the_compiled_kernels():
    env = gym.make("FootstepCrowd-v0")
    oracle = make_policy("oracle", env.unwrapped.robot, seed=0)
    obs, _ = env.reset(seed=0)
    oracle.reset(seed=0)
    with pytest.raises(RuntimeError, match="bind_truth"):
        oracle.act(obs, env.unwrapped.sensing())
    assert not oracle.bound
    with pytest.raises(ValueError, match="kernels.compiled must be false"):
        make_policy("oracle", kernels={"compiled": True})
    # its body check has no shape table: the compiled kernels refuse it, the numpy ones check it with the truth
    snap = true_snapshot(env.unwrapped)
    body = TruthBody(TruthPredictor(snap, TruthModel(env.unwrapped, snap.obstacles, 30.0), 30.0), env.unwrapped.robot,
                     0.02)
    with pytest.raises(TypeError, match="no shape table for the compiled kernels"):
        select_kernels(True).check_body(body)
    select_kernels(False).check_body(body)
    point = np.asarray(snap.com)[None]
    assert select_kernels(False).body_free(body, point, np.zeros(1), np.zeros((1, 2)), 0.8).shape == (1,)
    env.close()


def _attribute_calls(name: str) -> list[str]:
    """Every ``<something>.<name>(...)`` call in the package and the baselines' scripts, as ``file:function``."""
    found = []
    for path in [*(REPO / "footstep_gym").rglob("*.py"), *(REPO / "baselines").glob("*.py")]:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for func in (n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))):
            for node in ast.walk(func):
                if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                        and node.func.attr == name):
                    found.append(f"{path.relative_to(REPO)}:{func.name}")
    return found


def test_the_env_hands_the_truth_to_a_policy_in_one_place_only():
    """``policy.bind_truth(env)`` is called by the runner's ``bind_truth`` alone, and only for ``reads_truth``."""
    assert _attribute_calls("bind_truth") == ["footstep_gym/evaluation/runner.py:bind_truth"]

    class Spy:
        """Steps in place; records what the runner binds to it."""

        reads_truth = False

        def __init__(self, robot):
            self.command = robot.nominal_command.copy()
            self.bound = []
            self.last_info = {}

        def bind_truth(self, env):
            self.bound.append(env)

        def reset(self, seed=None):
            pass

        def act(self, observation, snapshot):
            return self.command.copy()

    class TruthSpy(Spy):
        reads_truth = True

    made = []

    def factory(kind):
        def make(cell, robot, seed):
            made.append(kind(robot))
            return made[-1]
        return make

    env = gym.make("FootstepCrossing-v0")
    robot = env.unwrapped.robot
    assert not bind_truth(Spy(robot), env) and bind_truth(TruthSpy(robot), env)
    env.close()
    cell = Cell("FootstepCrossing-v0", "crossing", "spy")
    run_episode(Task(0, cell, 20000), factory=factory(Spy), warm=False)
    run_episode(Task(0, cell, 20000), factory=factory(TruthSpy), warm=False)
    plain, reader = made
    assert plain.bound == [] and len(reader.bound) == 1
    assert reader.bound[0].__class__.__name__ == "FootstepEnv"  # the unwrapped env


def test_the_oracle_reads_the_true_state_not_the_sensed_snapshot():
    """With sensing noise on, ``sensing()`` differs from the truth; the oracle plans the same whatever it is passed."""
    env = gym.make("FootstepCrowd-v0", sensing_noise_position=0.05, sensing_noise_velocity=0.05)
    base = env.unwrapped
    obs, _ = env.reset(seed=10000)
    first, second = (make_policy("oracle", base.robot, seed=10000) for _ in range(2))
    for oracle in (first, second):
        oracle.reset(seed=10000)
        bind_truth(oracle, env)
    for _ in range(4):
        env.step(first.act(obs, base.sensing()))  # let the crowd move; the noise is drawn per step
        second.act(obs, base.sensing())
    sensed, truth = base.sensing(), true_snapshot(base)
    assert truth.obstacles == base.world.views() and sensed.obstacles != truth.obstacles
    assert (truth.com, truth.support_foot, truth.time) == (sensed.com, sensed.support_foot, sensed.time)
    noisy = first.act(obs, sensed)
    blind = second.act(obs, None)  # the snapshot passed is ignored: even none will do
    np.testing.assert_array_equal(noisy, blind)
    env.close()


# ---------------------------------------------------------------- the truth is the env's
def _step_and_compare(env_id: str, kwargs: dict, seed: int, steps: int, atol: float) -> float:
    """Step in place at the nominal period ``steps`` times; the truth built at reset, asked for each step's end
    (just before the env re-places its shapes), must match the world's bodies there. Returns the worst error."""
    env = gym.make(env_id, **kwargs)
    base = env.unwrapped
    env.reset(seed=seed)
    command = base.robot.nominal_command.copy()
    period = float(command[3] + command[4])
    views = base.world.views()
    truth = TruthModel(base, views, horizon=30.0)
    moving = [i for i, v in enumerate(views) if not v.static]
    worst = 0.0
    for k in range(steps):
        _, _, terminated, truncated, _ = env.step(command)
        assert not (terminated or truncated)
        now = base.world.views()
        end = np.array([(k + 1) * period * (1 - 1e-12)])  # the end of step k, before the next re-placement
        centre, angle = truth.poses(end, period)
        for i in moving:
            assert now[i].name == views[i].name
            err = abs(centre[0, i] - complex(*now[i].position))
            worst = max(worst, err, abs(angle[0, i] - now[i].angle))
    env.close()
    assert worst <= atol, worst
    return worst


@pytest.mark.parametrize("env_id, kwargs, atol", [
    ("FootstepCrowd-v0", {}, 1e-9),  # the scripted crowd: its schedule's chords
    ("FootstepDoor-v0", {"door_speed": 17.0}, 1e-9),  # the rod turning steadily
    ("FootstepCrossing-v0", {"traffic_lanes": 2}, 1e-9),  # steady traffic, re-placed each footstep
    ("FootstepCrossing-v0", {}, 1e-9),  # the paper's one timed car: a member that only keeps its velocity
    ("FootstepCrowd-v0", {"crowd_model": "orca", "crowd_layout": "counter_flow", "robot_visible": False}, 1e-5),
])
def test_the_truth_is_where_the_env_puts_the_obstacles(env_id, kwargs, atol):
    if kwargs.get("crowd_model") == "orca":
        pytest.importorskip("pyrvo")
    _step_and_compare(env_id, kwargs, seed=10003, steps=3, atol=atol)


# ---------------------------------------------------------------- the oracle does at least as well
def _outcome(policy: str, env_id: str, scenario: str, seed: int, params=()) -> tuple[str, int]:
    result = run_episode(Task(0, Cell(env_id, scenario, policy, params), seed), warm=False)
    return result.outcome, result.steps


@pytest.mark.parametrize("env_id, scenario", [("FootstepDoor-v0", "door"), ("FootstepCrossing-v0", "crossing")])
def test_on_constant_motion_the_oracle_walks_as_period_aware(env_id, scenario):
    """The door turns steadily and the paper's car keeps its velocity, so period-aware's prediction is the truth:
    the same episode, step for step."""
    assert _outcome("oracle", env_id, scenario, 10000) == _outcome("period-aware", env_id, scenario, 10000)


def _successes(policy: str, env_id: str, seeds, **env_kwargs) -> list[bool]:
    """Whether each episode of ``policy`` (bound to the truth if it reads it) reached the goal, one per seed."""
    env = gym.make(env_id, **env_kwargs)
    planner = make_policy(policy, env.unwrapped.robot)
    bind_truth(planner, env)
    reached = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        planner.reset(seed=seed)
        while True:
            obs, _, terminated, truncated, info = env.step(planner.act(obs, env.unwrapped.sensing()))
            if terminated or truncated:
                reached.append(info["termination"] == "goal")
                break
    env.close()
    return reached


@pytest.mark.parametrize("env_id, kwargs", [("FootstepDoor-v0", dict(door_speed=17.0, **NOISE)),
                                            ("FootstepCrowd-v0", NOISE)])
def test_where_sensing_noise_misleads_period_aware_the_oracle_reaches_the_goal_at_least_as_often(env_id, kwargs):
    """Noise corrupts period-aware's constant-velocity prediction, not the oracle's truth: over :data:`RATE_SEEDS`
    the oracle succeeds on at least :data:`ORACLE_RATE` of the episodes and on at least as many as period-aware."""
    oracle = _successes("oracle", env_id, RATE_SEEDS, **kwargs)
    aware = _successes("period-aware", env_id, RATE_SEEDS, **kwargs)
    assert sum(oracle) >= ORACLE_RATE * len(oracle), oracle
    assert sum(oracle) >= sum(aware), (oracle, aware)
