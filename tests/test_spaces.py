"""The observation box's bounds and the step limit in the spec (footstep_gym/env.py, mix.py).

Every observation the four envs produce must lie in their observation space (fuzzed over
seeds, random and near-nominal actions, ``randomize`` ranges and small sensing ranges);
Gymnasium's and SB3's checkers must raise no warning about the space beyond the infinite
bounds of the slots the layout leaves unbounded; ``env.spec.max_episode_steps`` must be the
step the env truncates at. References are the YAML files read directly.
"""

from __future__ import annotations

import math
import pickle
import warnings
import zlib

import gymnasium as gym
import numpy as np
import pytest
import yaml
from gymnasium.utils.env_checker import check_env

import footstep_gym
from footstep_gym.config import config_dir

SCENE_IDS = {"door": "FootstepDoor-v0", "crossing": "FootstepCrossing-v0", "crowd": "FootstepCrowd-v0"}
ALL_IDS = [*SCENE_IDS.values(), "FootstepMix-v0"]
NOMINAL = np.array([0.0, 0.08, 0.0, 0.6, 0.2])
#: Crossing env with the car 5 m ahead, arriving after 40 s: nothing near the robot.
FREE = dict(crossing_x=5.0, timing_jitter=0.0)
#: Observation slots the layout gives no bound (docstring of FootstepEnv, "Observation Space").
GOAL, SIDE, COM, PREVIOUS = slice(0, 2), 2, slice(3, 7), slice(7, 12)


def read_yaml(name: str) -> dict:
    with open(config_dir() / name, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def obstacle_slots(k: int, part: slice | int) -> list[int]:
    """Indices of field(s) ``part`` (0-1 position, 2-3 velocity, 4 flag) of each of the ``k`` obstacle slots."""
    offsets = range(5)[part] if isinstance(part, slice) else [part]
    return [12 + 5 * j + o for j in range(k) for o in offsets]


# ------------------------------------------------------------------ the bounds
@pytest.mark.parametrize("env_id", ALL_IDS)
def test_bounds_per_slot_follow_the_layout(env_id):
    cfg = read_yaml("env.yaml")
    k = cfg["n_obstacles_observed"]
    space = gym.make(env_id).observation_space
    assert space.shape == (12 + 5 * k,) and space.dtype == np.float32
    low, high = space.low, space.high
    reach = np.float32(cfg["sensing_range"] / cfg["observation_position_scale"])
    unbounded = [*range(12)[GOAL], *range(12)[COM], *obstacle_slots(k, slice(2, 4))]
    assert np.all(low[unbounded] == -np.inf) and np.all(high[unbounded] == np.inf)
    assert np.all(np.isfinite(np.delete(low, unbounded))) and np.all(np.isfinite(np.delete(high, unbounded)))
    assert (low[SIDE], high[SIDE]) == (-1.0, 1.0)
    assert np.all(low[PREVIOUS] == -1.0) and np.all(high[PREVIOUS] == 1.0)
    positions = obstacle_slots(k, slice(0, 2))
    assert np.all(low[positions] == -reach) and np.all(high[positions] == reach)
    flags = obstacle_slots(k, 4)
    assert np.all(low[flags] == 0.0) and np.all(high[flags] == 1.0)


def test_bounds_follow_the_sensing_range_and_scale():
    space = gym.make("FootstepDoor-v0", sensing_range=0.3, observation_position_scale=0.7).observation_space
    positions = obstacle_slots(space.shape[0] // 5 - 2, slice(0, 2))
    assert np.all(space.high[positions] == np.float32(0.3 / 0.7))
    assert np.all(space.low[positions] == -np.float32(0.3 / 0.7))


def test_a_nominal_command_outside_the_box_widens_its_slot():
    """With ``stride_front`` leaving out S = 0, the nominal command of the reset maps below -1."""
    env = gym.make("FootstepCrossing-v0", robot={"stride_front": [0.01, 0.10]}, **FREE)
    space = env.observation_space
    obs, _ = env.reset(seed=0)
    assert obs in space
    assert space.low[7] < -1.0 and obs[7] == space.low[7]
    assert np.all(space.low[8:12] == -1.0) and np.all(space.high[7:12] == 1.0)
    obs, *_ = env.step(np.array([0.01, 0.08, 0.0, 0.6, 0.2], dtype=np.float32))
    assert obs in space and obs[7] == -1.0  # applied commands are clipped to the box


def test_mix_box_holds_each_scenes_box():
    env = gym.make("FootstepMix-v0", door={"sensing_range": 0.5}, crowd={"observation_position_scale": 0.7})
    scenes = env.unwrapped.envs
    for scene in scenes.values():
        assert np.all(env.observation_space.low <= scene.observation_space.low)
        assert np.all(env.observation_space.high >= scene.observation_space.high)
    highs = np.stack([s.observation_space.high for s in scenes.values()])
    assert np.array_equal(env.observation_space.high, highs.max(axis=0))
    plain = gym.make("FootstepMix-v0")
    assert plain.observation_space == gym.make("FootstepDoor-v0").observation_space


# ------------------------------------------------------------------ every observation lies in the box
RANDOMIZE = {
    "door": {"door_speed": [8.0, 120.0], "door_angle_jitter": [0.0, 40.0]},
    "crossing": {"obstacle_speed": [0.1, 1.0], "crossing_x": [0.3, 1.2], "timing_jitter": [0.0, 3.0]},
    "crowd": {"crowd_speed": [0.1, 0.4], "ring_radius": [0.3, 0.5]},
}
#: Small sensing ranges (shapes come and go at the boundary) and a scale whose quotient float32 rounds.
SMALL_RANGE = {"sensing_range": 0.3, "observation_position_scale": 0.7}


def settings(env_id: str, case: str) -> dict:
    scene = next((s for s, i in SCENE_IDS.items() if i == env_id), None)
    if case == "default":
        return {}
    if scene is None:  # the mix: each scene its own randomize ranges; sensing ranges that differ across scenes
        kw = {s: {"randomize": r} for s, r in RANDOMIZE.items()}
        if case == "small_range":
            kw["door"].update(SMALL_RANGE)
            kw["crowd"].update(sensing_range=0.45)
        return kw
    return {"randomize": RANDOMIZE[scene], **(SMALL_RANGE if case == "small_range" else {})}


def action(kind: str, space: gym.spaces.Box, rng: np.random.Generator) -> np.ndarray:
    """A float32 action in the box: uniform, at its corners (the float32-rounded bounds) or a near-nominal
    stride (long episodes: obstacles come near, collisions)."""
    low, high = space.low.astype(np.float64), space.high.astype(np.float64)
    if kind == "uniform":
        return rng.uniform(low, high).astype(np.float32)
    if kind == "corners":
        return np.where(rng.random(5) < 0.5, space.low, space.high)
    near = np.array([0.07, 0.09, 0.0, 0.55, 0.2]) + rng.normal(0.0, [0.02, 0.005, 0.03, 0.03, 0.02])
    return np.clip(near, low, high).astype(np.float32)


@pytest.mark.parametrize("case", ["default", "randomize", "small_range"])
@pytest.mark.parametrize("env_id", ALL_IDS)
def test_every_observation_lies_in_the_box(env_id, case):
    env = gym.make(env_id, **settings(env_id, case))
    space = env.observation_space
    rng = np.random.default_rng(zlib.crc32(f"{env_id} {case}".encode()))
    k = (space.shape[0] - 12) // 5
    positions = np.array(obstacle_slots(k, slice(0, 2))).reshape(k, 2)
    seen = {"obs": 0, "resets": 0, "shapes": 0, "collision": 0, "fall": 0, "goal": 0}
    farthest = 0.0  # the largest |relative position| of a listed shape, over its bound
    obs, _ = env.reset(seed=int(rng.integers(2**31)))
    kinds = ("uniform", "corners", "near", "near")
    kind = kinds[0]
    for _ in range(1200):
        assert obs in space, (obs, space)
        seen["obs"] += 1
        listed = obs[positions[:, 0] + 4] == 1.0
        seen["shapes"] += int(listed.sum())
        if listed.any():
            farthest = max(farthest, float(np.max(np.hypot(*obs[positions[listed]].astype(np.float64).T)
                                                  / space.high[positions[listed, 0]])))
        obs, reward, terminated, truncated, info = env.step(action(kind, env.action_space, rng))
        assert math.isfinite(reward)
        if terminated or truncated:
            assert obs in space, (obs, space)
            seen[info["termination"] or "truncated"] = seen.get(info["termination"] or "truncated", 0) + 1
            # Unseeded resets continue the stream; a seeded one now and then starts a new one.
            obs, _ = env.reset(seed=int(rng.integers(2**31)) if rng.random() < 0.3 else None)
            kind = kinds[int(rng.integers(len(kinds)))]
            seen["resets"] += 1
    assert seen["resets"] >= 20 and seen["shapes"] > 0 and seen["collision"] > 0 and seen["fall"] > 0, seen
    assert farthest <= 1.0 + 1e-6
    if case == "small_range":  # shapes were listed close to the boundary of the box
        assert farthest > 0.9, farthest


@pytest.mark.parametrize("scale", [2.0, 0.7, 0.3])
@pytest.mark.parametrize("env_id", list(SCENE_IDS.values()))
def test_a_shape_exactly_at_sensing_range_lies_in_the_box(env_id, scale):
    """A shape whose gap to the CoM is sensing_range exactly is listed, at R of the box."""
    probe = gym.make(env_id).unwrapped
    probe.reset(seed=3)
    gaps = [g for g, *_ in probe.world.nearest((probe.com.real, probe.com.imag), 6, math.inf) if g > 0]
    assert gaps
    for gap in gaps:
        env = gym.make(env_id, sensing_range=gap, observation_position_scale=scale)
        obs, _ = env.reset(seed=3)
        assert obs in env.observation_space
        k = (obs.size - 12) // 5
        listed = [j for j in range(k) if obs[12 + 5 * j + 4] == 1.0]
        rel = obs[12 + 5 * listed[-1]: 14 + 5 * listed[-1]].astype(np.float64)
        assert np.hypot(*rel) == pytest.approx(gap / scale, rel=1e-6)  # the last listed is the one at the range


# ------------------------------------------------------------------ the checkers
GYM_INFINITE = {"A Box observation space minimum value is -infinity. This is probably too low.",
                "A Box observation space maximum value is infinity. This is probably too high."}
ACTION_BOX = ("we recommend using a symmetric and normalized space", "We recommend you to use a symmetric and "
              "normalized Box action space")  # the action box is in SI units by design (docstring)


def _plain(message: str) -> str:
    """A gymnasium logger warning without its colour codes and ``WARN:`` prefix."""
    for code in ("\x1b[33m", "\x1b[0m"):
        message = message.replace(code, "")
    return message.removeprefix("WARN: ")


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_checkers_warn_about_no_observation_bound_but_the_unbounded_slots(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    env = gym.make(env_id)
    caught = {}
    for name, check in (("gymnasium", lambda e: check_env(e, skip_render_check=True)),
                        ("sb3", lambda e: sb3_checker.check_env(e, warn=True))):
        with warnings.catch_warnings(record=True) as rec:
            warnings.simplefilter("always")
            check(env.unwrapped)
        caught[name] = {_plain(str(w.message)) for w in rec}
    for name, messages in caught.items():
        rest = {m for m in messages if not any(a in m for a in ACTION_BOX)}
        # gymnasium flags any infinite bound; the goal, CoM and obstacle-velocity slots have none (docstring)
        assert rest == (GYM_INFINITE if name == "gymnasium" else set()), (name, rest)
    env.close()


# ------------------------------------------------------------------ the step limit in the spec
def _wrappers(env: gym.Env) -> list[type]:
    out = []
    while isinstance(env, gym.Wrapper):
        out.append(type(env))
        env = env.env
    return out


@pytest.mark.parametrize("scene, env_id", SCENE_IDS.items())
def test_spec_reports_the_scenarios_max_steps_and_make_adds_no_time_limit(scene, env_id):
    max_steps = read_yaml(f"scenarios/{scene}.yaml")["max_steps"]
    env = gym.make(env_id)
    assert env.spec.max_episode_steps == max_steps
    assert env.unwrapped.spec.max_episode_steps == max_steps
    assert gym.wrappers.TimeLimit not in _wrappers(env)  # the env truncates by itself: one limit
    assert gym.spec(env_id).max_episode_steps is None  # a registered one would add a TimeLimit
    assert pickle.loads(pickle.dumps(env)).spec.max_episode_steps == max_steps


def test_mix_spec_reports_the_largest_scene_max_steps():
    env = gym.make("FootstepMix-v0")
    assert env.spec.max_episode_steps == max(read_yaml(f"scenarios/{s}.yaml")["max_steps"] for s in SCENE_IDS)
    env = gym.make("FootstepMix-v0", scenes=["door", "crowd"], door={"max_steps": 30}, crowd={"max_steps": 40})
    assert env.spec.max_episode_steps == 40 and gym.wrappers.TimeLimit not in _wrappers(env)
    assert env.spec.id == "FootstepMix-v0"


def test_a_directly_built_env_has_no_spec():
    assert footstep_gym.env.FootstepEnv(scenario="door").spec is None
    assert footstep_gym.mix.FootstepMixEnv().spec is None


def _steps_to_truncation(env: gym.Env, limit: int = 50) -> int:
    env.reset(seed=0)
    for n in range(1, limit + 1):
        _, _, terminated, truncated, _ = env.step(NOMINAL)
        assert not terminated
        if truncated:
            return n
    raise AssertionError("not truncated")


def test_the_episode_truncates_at_the_spec_max_episode_steps():
    env = gym.make("FootstepCrossing-v0", max_steps=9, **FREE)
    assert env.spec.max_episode_steps == 9
    assert _steps_to_truncation(env) == 9
    assert env.unwrapped.ended == "truncated: max_steps=9 reached"
    # Re-made from its spec (which now states the limit): a TimeLimit at the same step.
    again = gym.make(env.spec)
    assert again.spec.max_episode_steps == 9 and _steps_to_truncation(again) == 9


def test_make_max_episode_steps_adds_a_time_limit_that_can_only_shorten():
    env = gym.make("FootstepCrossing-v0", max_episode_steps=4, **FREE)
    assert gym.wrappers.TimeLimit in _wrappers(env)
    assert env.spec.max_episode_steps == 4 and _steps_to_truncation(env) == 4
    longer = gym.make("FootstepCrossing-v0", max_episode_steps=20, max_steps=6, **FREE)
    assert _steps_to_truncation(longer) == 6  # the env's own max_steps still holds (docstring, "Episode End")


# ------------------------------------------------------------------ footstep_gym.observation: the batched builder
@pytest.mark.parametrize("env_id", list(SCENE_IDS.values()))
def test_batched_observations_equal_the_envs_to_a_few_ulps(env_id):
    """``observation.observations`` on the env's states, stacked over an episode, is what ``step`` returned
    (within a few float32 ulps: it computes with numpy's cos and sin, the env with libm's)."""
    from footstep_gym import observation as ob

    sensing_range = {"FootstepDoor-v0": 0.8, "FootstepCrossing-v0": 1.2, "FootstepCrowd-v0": 0.3}[env_id]  # [m]: some
    # slots hold shapes, some are padding
    env = gym.make(env_id, sensing_range=sensing_range).unwrapped
    env_cfg, robot = read_yaml("env.yaml"), read_yaml("robot.yaml")
    k = env_cfg["n_obstacles_observed"]
    scales = ob.ObservationScales(env_cfg["observation_position_scale"], env_cfg["observation_velocity_scale"],
                                  env_cfg["observation_com_scale"])
    turn = max(robot["turn_inner"], robot["turn_outer"])
    low = np.array([robot["stride_front"][0], robot["stride_side"][0], -turn, robot["t_ss"][0], robot["t_ds"][0]])
    high = np.array([robot["stride_front"][1], robot["stride_side"][1], turn, robot["t_ss"][1], robot["t_ds"][1]])
    rng = np.random.default_rng(0)
    got, rows = [], []
    obs, _ = env.reset(seed=1)
    for i in range(60):
        com = (env.com.real, env.com.imag)
        near = env.world.nearest(com, k, sensing_range)
        points = np.zeros((k, 2))
        velocities = np.zeros((k, 2))
        for j, (_, point, velocity, _) in enumerate(near):
            points[j], velocities[j] = point, velocity
        rows.append(dict(support=env.feet[env.support_side], side=env.support_side, com=com,
                         com_vel=(env.com_vel.real, env.com_vel.imag), goal=env.episode_config.goal,
                         previous_unit=ob.command_to_unit(env.previous_command, low, high - low),
                         points=points, velocities=velocities, present=np.arange(k) < len(near)))
        got.append(obs)
        action = NOMINAL + rng.uniform(-1, 1, 5) * [0.03, 0.01, 0.1, 0.05, 0.02] * (i % 3 != 0)
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            obs, _ = env.reset()
    batch = {key: np.array([row[key] for row in rows]) for key in rows[0]}
    built = ob.observations(scales=scales, **batch)
    assert built.dtype == np.float32 and built.shape == (60, ob.observation_size(k)) == (60, len(got[0]))
    present = np.array([row["present"] for row in rows])
    assert present.any() and not present.all()
    eps = float(np.finfo(np.float32).eps)
    np.testing.assert_allclose(built, np.array(got), rtol=4 * eps, atol=4 * eps)
