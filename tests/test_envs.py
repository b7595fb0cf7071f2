"""The three registered envs (footstep_gym/env.py, scenarios/, sensing.py) over the registry.

Gymnasium's and SB3's checkers, vectorisation, pickling, seeded replay, the info
contract, physics read off the env (the figures of docs/model.md §3), goal and truncation,
bad actions, and the read-only sensing snapshot. References are the YAML files read
directly, hand geometry and the numbers quoted in docs/model.md, never the code under test.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
import yaml
from gymnasium.utils.env_checker import check_env, data_equivalence

import footstep_gym
from footstep_gym import config, footstep
from footstep_gym.config import config_dir
from footstep_gym.errors import ConfigError
from footstep_gym.scenarios import SCENARIOS

ENV_IDS = ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"]
NOMINAL = np.array([0.0, 0.08, 0.0, 0.6, 0.2])
LEFT, RIGHT = 1, -1
#: Crossing env with the car 5 m ahead, arriving after 40 s: nothing near the robot.
FREE = dict(crossing_x=5.0, timing_jitter=0.0)


def read_yaml(name: str) -> dict:
    with open(config_dir() / name, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def strides(*values, t_ss=0.6, t_ds=0.2, side=0.08):
    return [np.array([s, side, 0.0, t_ss, t_ds]) for s in values]


def assert_identical(a, b, path="") -> None:
    """Bit-identical nested data (NaN equal to NaN), types included."""
    assert type(a) is type(b), (path, type(a), type(b))
    if isinstance(a, dict):
        assert list(a) == list(b), path
        for k in a:
            assert_identical(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_identical(x, y, f"{path}[{i}]")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, path
        assert a.tobytes() == b.tobytes(), path
    elif isinstance(a, float):
        assert (math.isnan(a) and math.isnan(b)) or a == b, (path, a, b)
    else:
        assert a == b, (path, a, b)


# ------------------------------------------------------------------ registry and checkers
def test_registry_holds_the_three_ids():
    assert sorted(footstep_gym.ENV_IDS.values()) == sorted(ENV_IDS)
    for env_id in ENV_IDS:
        assert env_id in gym.registry


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_check_env(env_id):
    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the SI action box and unbounded observation are by design
        check_env(env.unwrapped)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_check_env(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    env = gym.make(env_id)
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        # SB3 warns that the action box is not [-1, 1] (documented: SI units, RescaleAction
        # in the baselines); anything that is an error must raise.
        sb3_checker.check_env(env.unwrapped, warn=True)
    env.close()


def test_make_with_module_prefix_in_fresh_process(tmp_path):
    code = (
        "import sys, gymnasium as gym\n"
        "assert 'footstep_gym' not in sys.modules\n"
        "env = gym.make('footstep_gym:FootstepDoor-v0')\n"
        "obs, info = env.reset(seed=0)\n"
        "obs, r, term, trunc, info = env.step(env.action_space.sample())\n"
        "print(obs.shape, type(env.unwrapped).__name__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["(42,)", "FootstepEnv"]


@pytest.mark.parametrize("mode", ["sync", "async"])
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_make_vec(env_id, mode):
    envs = gym.make_vec(env_id, num_envs=4, vectorization_mode=mode)
    try:
        obs, info = envs.reset(seed=123)
        assert obs.shape == (4, 42) and obs.dtype == np.float32
        assert obs in envs.observation_space
        assert len({o.tobytes() for o in obs}) == 4  # seeds 123..126 draw four different episodes
        envs.action_space.seed(5)
        for _ in range(4):
            obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
            assert obs.shape == (4, 42) and reward.shape == (4,)
            assert terminated.dtype == bool and truncated.dtype == bool
            assert np.all(np.isfinite(obs)) and np.all(np.isfinite(reward))
    finally:
        envs.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("clone", [lambda e: pickle.loads(pickle.dumps(e)), copy.deepcopy], ids=["pickle", "deepcopy"])
def test_pickle_and_deepcopy_after_reset(env_id, clone):
    env = gym.make(env_id)
    env.reset(seed=11)
    env.step(NOMINAL)
    twin = clone(env)
    # Gymnasium's own shape: the clone continues exactly as the original.
    assert data_equivalence(env.reset(), twin.reset())
    for action in [NOMINAL, *strides(0.03, 0.05)]:
        a, b = env.step(action), twin.step(action)
        assert data_equivalence(a, b)
    assert twin.unwrapped.world is not env.unwrapped.world
    env.close()
    twin.close()


# ------------------------------------------------------------------ seeding by replay
def rollout(env, seed, actions):
    trace = [env.reset(seed=seed)]
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        trace.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            trace.append(env.reset())  # no seed: the episode generator carries on
    return trace


def random_actions(space, n, seed):
    space = copy.deepcopy(space)
    space.seed(seed)
    return [space.sample() for _ in range(n)]


def near_nominal_actions(n, seed):
    rng = np.random.default_rng(seed)
    return [np.array([rng.uniform(0.0, 0.05), rng.uniform(0.075, 0.09), rng.uniform(-0.05, 0.05),
                      rng.uniform(0.5, 0.6), rng.uniform(0.18, 0.22)]) for _ in range(n)]


@pytest.mark.parametrize("kind", ["random", "near_nominal"])
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_same_actions_replays_bit_identically(env_id, kind):
    env_a, env_b = gym.make(env_id), gym.make(env_id)
    actions = (random_actions(env_a.action_space, 40, seed=3) if kind == "random"
               else near_nominal_actions(40, seed=4))
    trace_a = rollout(env_a, 2024, actions)
    trace_b = rollout(env_b, 2024, actions)
    assert_identical(trace_a, trace_b)
    # The same env, reset again with the same seed, replays too.
    assert_identical(rollout(env_a, 2024, actions), trace_a)
    # And a different seed gives a different trace.
    trace_c = rollout(env_a, 2025, actions)
    assert any(not np.array_equal(x[0], y[0]) for x, y in zip(trace_a, trace_c))


def layout(env):
    """Every obstacle's pose and velocity after reset, and the robot's CoM."""
    snap = env.unwrapped.sensing()
    return [(o.name, o.position, o.angle, o.velocity, o.angular_velocity) for o in snap.obstacles], snap.com


def moving(env):
    return [o for o in env.unwrapped.sensing().obstacles if not o.static]


def test_door_angle_jitter_draws_differ_and_stay_in_range():
    door = read_yaml("scenarios/door.yaml")
    env = gym.make("FootstepDoor-v0")
    angles = []
    for seed in range(12):
        env.reset(seed=seed)
        (rod,) = moving(env)
        angles.append(math.degrees(rod.angle))
        assert rod.angular_velocity == pytest.approx(-math.radians(door["door_speed"]))  # clockwise
    lo = door["door_start_angle"] - door["door_angle_jitter"]
    hi = door["door_start_angle"] + door["door_angle_jitter"]
    assert all(lo <= a <= hi for a in angles)
    assert len(set(angles)) == len(angles)
    assert max(angles) - min(angles) > door["door_angle_jitter"]  # spread over the range


def test_crossing_timing_draws_differ_and_stay_in_range():
    cfg = read_yaml("scenarios/crossing.yaml")
    env = gym.make("FootstepCrossing-v0")
    meets = []
    for seed in range(12):
        env.reset(seed=seed)
        (car,) = moving(env)
        assert car.velocity == pytest.approx((0.0, cfg["obstacle_speed"]))
        assert car.position[0] == pytest.approx(cfg["start"][0] + cfg["crossing_x"])
        meets.append((cfg["start"][1] - car.position[1]) / cfg["obstacle_speed"])  # when it reaches the path
    nominal = cfg["crossing_x"] / cfg["arrival_speed"]
    assert all(abs(m - nominal) <= cfg["timing_jitter"] + 1e-9 for m in meets)
    assert len(set(meets)) == len(meets)


def test_crowd_draws_differ_and_stay_on_the_ring():
    cfg = read_yaml("scenarios/crowd.yaml")
    env = gym.make("FootstepCrowd-v0")
    layouts = []
    for seed in range(6):
        env.reset(seed=seed)
        members = moving(env)
        assert len(members) == cfg["crowd_size"]
        centres = np.array([m.position for m in members])
        radii = np.linalg.norm(centres - np.array(cfg["start"]), axis=1)
        assert np.all(radii >= cfg["ring_radius"] - cfg["breathing_amplitude"] - 1e-9)
        assert np.all(radii <= cfg["ring_radius"] + cfg["breathing_amplitude"] + 1e-9)
        layouts.append(centres)
    for i in range(len(layouts)):
        for j in range(i):
            assert not np.allclose(layouts[i], layouts[j])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_seeded_reset_repeats_and_unseeded_reset_moves_on(env_id):
    env = gym.make(env_id)
    env.reset(seed=7)
    first = layout(env)
    env.reset()
    second = layout(env)
    env.reset(seed=7)
    assert layout(env) == first
    assert second != first
    env.reset(seed=8)
    assert layout(env) != first


def test_start_jitter_moves_the_robot_within_bounds():
    cfg = read_yaml("scenarios/door.yaml")
    env = gym.make("FootstepDoor-v0")
    centres = []
    for seed in range(10):
        env.reset(seed=seed)
        centres.append(env.unwrapped.sensing().centre)
    centres = np.array(centres)
    assert np.all(np.abs(centres - np.array(cfg["start"])) <= cfg["start_jitter"] + 1e-12)
    assert len({tuple(c) for c in centres}) == len(centres)


def test_randomized_door_speed_is_drawn_within_range_per_seed():
    env = gym.make("FootstepDoor-v0", randomize={"door_speed": [8, 17]})
    speeds = []
    for seed in range(20):
        env.reset(seed=seed)
        (rod,) = moving(env)
        body = next(o.body for o in env.unwrapped.world.obstacles if o.name == rod.name)
        assert body.angular_velocity == rod.angular_velocity
        speeds.append(-math.degrees(rod.angular_velocity))
        assert env.unwrapped.episode_config.door_speed == pytest.approx(speeds[-1])
    assert all(8.0 <= s <= 17.0 for s in speeds)
    assert len(set(speeds)) == len(speeds)
    assert min(speeds) < 10.0 and max(speeds) > 15.0
    # The drawn speed is what the door really does: it turns that fast over a step.
    env.reset(seed=0)
    before = moving(env)[0].angle
    env.step(NOMINAL)
    after = moving(env)[0].angle
    assert math.degrees(before - after) / 0.8 == pytest.approx(speeds[0], rel=1e-9)


# ------------------------------------------------------------------ the info contract
INFO_TYPES = {
    "is_success": bool, "feasible": bool, "collision": bool, "clipped": bool,
    "time": float, "period": float, "rewards": dict,
}


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_info_keys_on_every_step(env_id):
    env = gym.make(env_id)
    actions = near_nominal_actions(25, seed=1) + random_actions(env.action_space, 25, seed=2)
    _, info = env.reset(seed=5)
    assert len(info["com"]) == 2 and len(info["com_vel"]) == 2
    last_time = 0.0
    terminations = set()
    for action in actions:
        _, reward, terminated, truncated, info = env.step(action)
        for key, typ in INFO_TYPES.items():
            assert type(info[key]) is typ, (key, info[key])
        assert info["termination"] in {"goal", "collision", "fall", None}
        assert terminated == (info["termination"] is not None)
        assert info["is_success"] == (info["termination"] == "goal")
        assert info["collision"] == (info["termination"] == "collision")
        assert info["feasible"] == (info["termination"] != "fall")
        assert info["support_foot"] in {"left", "right"}
        assert len(info["foot_pose"]) == 3 and all(math.isfinite(v) for v in info["foot_pose"])
        for key in ("zmp", "com", "com_vel"):
            assert len(info[key]) == 2 and all(math.isfinite(v) for v in info[key]), key
        assert sum(info["rewards"].values()) == pytest.approx(reward, abs=1e-12)
        cmd = info["command"]
        assert info["period"] == pytest.approx(cmd[3] + cmd[4])
        assert info["time"] >= last_time
        assert info["time"] <= last_time + info["period"] + 1e-12
        last_time = info["time"]
        terminations.add(info["termination"])
        if terminated or truncated:
            _, info = env.reset()
            assert len(info["com"]) == 2 and len(info["com_vel"]) == 2
            last_time = 0.0
    assert None in terminations and "fall" in terminations  # both kinds of step were seen


# ------------------------------------------------------------------ physics through the env
def test_stepping_in_place_needs_no_zmp_offset():
    env = gym.make("FootstepDoor-v0")
    _, info = env.reset(seed=0)
    sides = [info["support_foot"]]
    for _ in range(30):
        _, _, terminated, truncated, info = env.step(NOMINAL)
        assert not terminated and not truncated and info["feasible"]
        assert np.hypot(*info["zmp_offset"]) < 1e-9
        sides.append(info["support_foot"])
    assert sides[:3] == ["right", "left", "right"]  # feet alternate, the right one supports first
    assert all(a != b for a, b in zip(sides, sides[1:]))


@pytest.mark.parametrize("t_ss, survives", [(0.2, True), (0.1, False)])
def test_abrupt_period_cut_after_steady_steps(t_ss, survives):
    """Cutting T_SS 0.6 -> 0.2 s in one step at 5 cm strides is feasible, -> 0.1 s a fall (docs/model.md §3)."""
    env = gym.make("FootstepCrossing-v0", **FREE)
    env.reset(seed=0)
    for action in strides(0.02, 0.035, 0.05, 0.05, 0.05):  # reach a steady 5 cm gait
        _, _, terminated, _, info = env.step(action)
        assert not terminated
    time_before = info["time"]
    _, reward, terminated, truncated, info = env.step(np.array([0.05, 0.08, 0.0, t_ss, 0.2]))
    if survives:
        assert not terminated and info["feasible"] and info["termination"] is None
    else:
        assert terminated and not truncated
        assert info["termination"] == "fall" and not info["feasible"] and not info["is_success"]
        assert info["rewards"]["fall"] < 0 and reward < 0
        assert info["time"] == time_before  # a fall ends the episode at the start of the step


@pytest.mark.parametrize("first_theta, second_theta, feasible", [
    (0.3, None, True),     # right support, left swings: +0.3 turns away (outer, limit 0.4)
    (-0.3, None, False),   # ... -0.3 turns towards the support foot (inner, limit 0.2)
    (-0.15, None, True),   # ... inside the inner limit
    (0.3, -0.3, True),     # then left support, right swings: -0.3 is outward for it
    (0.3, 0.3, False),     # ... +0.3 is inward for the right foot
])
def test_turn_limits_depend_on_the_swinging_foot(first_theta, second_theta, feasible):
    env = gym.make("FootstepCrossing-v0", **FREE)
    env.reset(seed=0)
    thetas = [first_theta] if second_theta is None else [first_theta, second_theta]
    for theta in thetas:
        _, _, terminated, _, info = env.step(np.array([0.0, 0.10, theta, 0.6, 0.2]))
        if theta is not thetas[-1]:
            assert info["feasible"]  # the first of two steps is a legal outward turn
    assert info["feasible"] == feasible
    assert (info["termination"] == "fall") == (not feasible)
    assert terminated == (not feasible)


@pytest.mark.parametrize("action", [
    [0.2, 0.08, 0.0, 0.6, 0.2],     # S above its range
    [0.0, 0.08, 0.0, 0.9, 0.2],     # T_SS above
    [-0.3, 0.08, 0.0, 0.6, 0.05],   # S and T_DS below
])
def test_command_outside_the_box_is_clipped_and_applied_clipped(action):
    action = np.array(action)
    env = gym.make("FootstepCrossing-v0", **FREE)
    twin = gym.make("FootstepCrossing-v0", **FREE)
    env.reset(seed=0)
    twin.reset(seed=0)
    robot = read_yaml("robot.yaml")
    low, high = robot_limits(robot)
    expected = np.minimum(np.maximum(action, low), high)
    obs, reward, terminated, _, info = env.step(action)
    assert info["clipped"] is True
    assert info["command"] == tuple(expected)
    # It behaves exactly as the clipped command would.
    obs2, reward2, terminated2, _, info2 = twin.step(expected)
    assert info2["clipped"] is False
    assert np.array_equal(obs, obs2) and reward == reward2 and terminated == terminated2
    assert info["com"] == info2["com"] and info["foot_pose"] == info2["foot_pose"]


def robot_limits(robot: dict) -> tuple[np.ndarray, np.ndarray]:
    """The action box's bounds as robot.yaml writes them (float64)."""
    turn = max(robot["turn_inner"], robot["turn_outer"])
    low = np.array([robot["stride_front"][0], robot["stride_side"][0], -turn, robot["t_ss"][0], robot["t_ds"][0]])
    high = np.array([robot["stride_front"][1], robot["stride_side"][1], turn, robot["t_ss"][1], robot["t_ds"][1]])
    return low, high


CORNERS = [np.array(bits) for bits in np.ndindex(*(2,) * 5)]


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("corner", CORNERS, ids=lambda b: "".join(map(str, b)))
def test_float32_action_at_a_corner_of_the_box_is_the_limit_it_rounds_from(env_id, corner):
    """What SB3 sends (float32, clipped to the box) is the robot's exact limit, not a hair beyond."""
    low, high = robot_limits(read_yaml("robot.yaml"))
    exact = np.where(corner == 1, high, low)
    env = gym.make(env_id, **(FREE if "Crossing" in env_id else {}))
    as32 = np.where(corner == 1, env.action_space.high, env.action_space.low)
    assert as32.dtype == np.float32 and env.action_space.contains(as32)
    results = []
    for action in (as32, exact):
        env.reset(seed=5)
        results.append(env.step(action))
    (obs32, r32, term32, _, info32), (obs64, r64, term64, _, info64) = results
    assert info32["clipped"] is False
    assert info32["command"] == tuple(exact)
    assert np.array_equal(obs32, obs64) and r32 == r64 and term32 == term64
    assert info32["termination"] == info64["termination"]


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_float32_nominal_command_and_rescaled_extremes_are_not_falls(env_id):
    """The nominal period at T_SS's upper bound, sent as float32 and through RescaleAction's +1."""
    robot = read_yaml("robot.yaml")
    env = gym.make(env_id, **(FREE if "Crossing" in env_id else {}))
    env.reset(seed=1)
    _, _, terminated, _, info = env.step(NOMINAL.astype(np.float32))
    assert info["feasible"] and not terminated and info["clipped"] is False
    assert info["command"][3] == robot["t_ss"][1] == NOMINAL[3]
    scaled = gym.wrappers.RescaleAction(gym.make(env_id, **(FREE if "Crossing" in env_id else {})),
                                         np.float32(-1.0), np.float32(1.0))
    scaled.reset(seed=1)
    nominal = np.array([0.0, 0.08, 0.0, 0.6, 0.2])
    unit = 2.0 * (nominal - robot_limits(robot)[0]) / (robot_limits(robot)[1] - robot_limits(robot)[0]) - 1.0
    unit[3] = 1.0  # T_SS at its largest: +1 exactly
    _, _, terminated, _, info = scaled.step(unit.astype(np.float32))
    assert info["command"][3] == robot["t_ss"][1]
    assert info["feasible"] and not terminated


def test_float32_action_at_the_inner_turn_limit_is_that_limit():
    """theta = float32(turn_inner) towards the support foot is the limit, so feasible like the float64 one."""
    robot = read_yaml("robot.yaml")
    env = gym.make("FootstepCrossing-v0", **FREE)
    _, info = env.reset(seed=2)
    # Support foot is the right one: the left foot swings, turning towards the right foot is theta < 0.
    assert info["support_foot"] == "right"
    action = np.array([0.0, 0.10, -robot["turn_inner"], 0.5, 0.2], dtype=np.float32)
    assert float(action[2]) != -robot["turn_inner"]  # the rounding the env must undo
    _, _, _, _, info = env.step(action)
    assert info["command"][2] == -robot["turn_inner"]
    assert info["feasible"]


def test_foot_pose_follows_the_footstep_convention():
    """Each placed foot is the command applied to the previous support foot (docs/model.md §2)."""
    env = gym.make("FootstepCrossing-v0", **FREE)
    _, info = env.reset(seed=3)
    support, side = info["foot_pose"], RIGHT
    commands = [(0.02, 0.08, 0.1), (0.04, 0.09, -0.1), (0.05, 0.10, 0.15), (0.06, 0.09, -0.12),
                (0.05, 0.085, 0.0), (-0.02, 0.08, 0.05), (0.0, 0.08, -0.05)]
    for S, L, theta in commands:
        _, _, terminated, _, info = env.step(np.array([S, L, theta, 0.6, 0.2]))
        assert not terminated
        new = info["foot_pose"]
        # By hand: the new foot sits S ahead and L outward (to the swing side) in the support frame.
        x, y, yaw = support
        lateral = -side * L
        expected = (x + S * math.cos(yaw) - lateral * math.sin(yaw),
                    y + S * math.sin(yaw) + lateral * math.cos(yaw), yaw + theta)
        assert new == pytest.approx(expected, abs=1e-12)
        assert new == pytest.approx(footstep.place_foot(support, side, S, L, theta), abs=1e-12)
        assert footstep.command_between(support, side, new) == pytest.approx((S, L, theta), abs=1e-12)
        side = -side
        assert info["support_foot"] == {LEFT: "left", RIGHT: "right"}[side]
        support = new


# ------------------------------------------------------------------ episode end
def walk_to_goal(env, max_steps=60):
    infos = []
    for action in strides(0.02, 0.04, 0.06, 0.08) + strides(*([0.10] * max_steps)):
        _, reward, terminated, truncated, info = env.step(action)
        infos.append(info)
        if terminated or truncated:
            return infos, reward, terminated, truncated
    return infos, reward, terminated, truncated


def test_walking_straight_reaches_the_goal():
    cfg = read_yaml("scenarios/crossing.yaml")
    env = gym.make("FootstepCrossing-v0", **FREE)
    _, info0 = env.reset(seed=0)
    infos, reward, terminated, truncated = walk_to_goal(env)
    info = infos[-1]
    assert terminated and not truncated
    assert info["termination"] == "goal" and info["is_success"] is True
    assert info["rewards"]["goal"] > 0
    # The robot centre (midpoint of the last two feet) is within the tolerance of the goal...
    centre = np.mean([infos[-1]["foot_pose"][:2], infos[-2]["foot_pose"][:2]], axis=0)
    assert np.hypot(*(centre - cfg["goal"])) <= cfg["goal_tolerance"]
    # ... and was not one step earlier.
    before = np.mean([infos[-2]["foot_pose"][:2], infos[-3]["foot_pose"][:2]], axis=0)
    assert np.hypot(*(before - cfg["goal"])) > cfg["goal_tolerance"]
    # About 1.9 m at up to 10 cm per step (the paper: 20 steps).
    assert 18 <= len(infos) <= 24
    assert not any(i["is_success"] for i in infos[:-1])


def test_goal_close_to_the_start():
    cfg = read_yaml("scenarios/door.yaml")
    goal = [cfg["start"][0] + 0.12, cfg["start"][1]]
    env = gym.make("FootstepDoor-v0", goal=goal, start_jitter=0.0)
    env.reset(seed=0)
    infos, _, terminated, _ = walk_to_goal(env)
    assert terminated and infos[-1]["termination"] == "goal" and infos[-1]["is_success"]
    assert len(infos) <= 5


def test_truncation_at_max_steps():
    env = gym.make("FootstepCrossing-v0", max_steps=3, **FREE)
    env.reset(seed=0)
    flags = [env.step(NOMINAL)[2:4] for _ in range(3)]
    assert flags == [(False, False), (False, False), (False, True)]


def test_truncation_at_time_limit():
    env = gym.make("FootstepCrossing-v0", time_limit=2.0, **FREE)
    env.reset(seed=0)
    flags = [env.step(NOMINAL)[2:4] for _ in range(3)]  # 0.8, 1.6, 2.4 s
    assert flags == [(False, False), (False, False), (False, True)]


def test_rewards_progress_term_measures_distance_gained():
    env_cfg = read_yaml("env.yaml")
    cfg = read_yaml("scenarios/crossing.yaml")
    env = gym.make("FootstepCrossing-v0", start_jitter=0.0, **FREE)
    env.reset(seed=0)
    infos, _, _, _ = walk_to_goal(env)
    total = sum(i["rewards"]["progress"] for i in infos)
    centre = np.mean([infos[-1]["foot_pose"][:2], infos[-2]["foot_pose"][:2]], axis=0)
    gained = math.dist(cfg["start"], cfg["goal"]) - math.dist(centre, cfg["goal"])
    assert total == pytest.approx(env_cfg["reward_progress"] * gained, abs=1e-9)
    assert sum(i["rewards"]["step"] for i in infos) == pytest.approx(env_cfg["reward_step"] * len(infos))
    assert sum(i["rewards"]["time"] for i in infos) == pytest.approx(env_cfg["reward_time"] * infos[-1]["time"])


# ------------------------------------------------------------------ bad actions
@pytest.mark.parametrize("index, value, name", [
    (3, float("nan"), "t_ss"), (0, float("inf"), "S"), (2, -float("inf"), "theta"), (4, float("nan"), "t_ds"),
])
def test_non_finite_action_names_the_field(index, value, name):
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    action = NOMINAL.copy()
    action[index] = value
    with pytest.raises(ValueError) as exc:
        env.step(action)
    assert isinstance(exc.value, footstep_gym.ActionError)
    message = str(exc.value)
    assert f"{name}=" in message
    other = [f for f in ("S=", "L=", "theta=", "t_ss=", "t_ds=") if f != f"{name}="]
    assert not any(o in message for o in other)  # only the bad field is blamed


@pytest.mark.parametrize("action", [np.zeros(4), np.zeros(6), np.zeros((1, 5)), np.zeros((5, 1)), 0.3, "fast"])
def test_wrong_shape_action_raises(action):
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape|5 numbers"):
        env.unwrapped.step(action)


def test_plain_list_action_is_accepted():
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    _, _, terminated, _, info = env.unwrapped.step([0.0, 0.08, 0.0, 0.6, 0.2])
    assert not terminated and info["feasible"]


def test_step_before_reset_raises():
    env = gym.make("FootstepDoor-v0").unwrapped
    with pytest.raises(gym.error.ResetNeeded):
        env.step(NOMINAL)
    with pytest.raises(gym.error.ResetNeeded):
        env.sensing()


# ------------------------------------------------------------------ sensing snapshot
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_snapshot_is_read_only_and_matches_info(env_id):
    env = gym.make(env_id)
    _, info = env.reset(seed=0)
    _, _, _, _, info = env.step(NOMINAL)
    snap = env.unwrapped.sensing()
    assert snap.com == pytest.approx(info["com"], abs=1e-12)
    assert snap.com_vel == pytest.approx(info["com_vel"], abs=1e-12)
    assert snap.time == info["time"]
    assert snap.support_foot == pytest.approx(info["foot_pose"], abs=1e-12)
    assert snap.support_side == {"left": LEFT, "right": RIGHT}[info["support_foot"]]
    assert snap.previous_command == pytest.approx(info["command"])
    # CoM relative to the support foot, in its frame.
    x, y, yaw = snap.support_foot
    dx, dy = snap.com[0] - x, snap.com[1] - y
    assert snap.com_local == pytest.approx((math.cos(yaw) * dx + math.sin(yaw) * dy,
                                            -math.sin(yaw) * dx + math.cos(yaw) * dy), abs=1e-12)

    with pytest.raises(dataclasses.FrozenInstanceError):
        snap.time = 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        snap.obstacles[0].position = (0.0, 0.0)
    assert isinstance(snap.obstacles, tuple)
    shapes = snap.shapes_at(0.0)
    arrays = [getattr(shapes, f.name) for f in dataclasses.fields(shapes)]
    for arr in arrays:
        if arr.flags.writeable:  # a fresh array is fine, as long as writing to it changes nothing
            arr[...] = 123.0
    again = snap.shapes_at(0.0)
    for f in dataclasses.fields(again):
        assert not np.any(getattr(again, f.name) == 123.0), f.name
    # The snapshot does not follow the env on.
    frozen_view = (snap.time, snap.com, snap.obstacles)
    env.step(NOMINAL)
    assert (snap.time, snap.com, snap.obstacles) == frozen_view


def rod_ends(view):
    c, s = math.cos(view.angle), math.sin(view.angle)
    return [(view.position[0] + c * p[0] - s * p[1], view.position[1] + s * p[0] + c * p[1]) for p in (view.a, view.b)]


def test_snapshot_predicts_the_door_exactly():
    """The door turns at a constant rate: shapes_at(dt) is where the rod really is after dt."""
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    snap = env.unwrapped.sensing()
    for period, action in ((0.8, NOMINAL), (0.5, np.array([0.0, 0.08, 0.0, 0.3, 0.2]))):
        predicted = snap.shapes_at(period)
        _, _, terminated, _, _ = env.step(action)
        assert not terminated
        snap = env.unwrapped.sensing()
        (rod,) = [o for o in snap.obstacles if not o.static]
        seg = np.stack([predicted.segment_a, predicted.segment_b], axis=1)  # (K, 2, 2)
        actual = np.array(rod_ends(rod))
        match = [np.allclose(s, actual, atol=1e-9) for s in seg]
        assert sum(match) == 1
        # The walls do not move.
        walls = [np.array(rod_ends(o)) for o in snap.obstacles if o.static]
        assert all(any(np.allclose(s, w, atol=1e-12) for s in seg) for w in walls)


def test_snapshot_predicts_the_crossing_car_exactly():
    env = gym.make("FootstepCrossing-v0")
    env.reset(seed=0)
    predicted = env.unwrapped.sensing().shapes_at(0.8)
    env.step(NOMINAL)
    (car,) = [o for o in env.unwrapped.sensing().obstacles if not o.static]
    actual = np.array(rod_ends(car))
    assert np.allclose(np.stack([predicted.segment_a[0], predicted.segment_b[0]]), actual, atol=1e-9)


def test_snapshot_holds_no_future_of_the_crowd():
    """A member's sensed velocity is what it did over the past step, not what it will do next."""
    env = gym.make("FootstepCrowd-v0", crowd_speed=0.2)
    env.reset(seed=0)
    snap0 = env.unwrapped.sensing()
    assert all(o.velocity == (0.0, 0.0) for o in snap0.obstacles)  # standing still at the start
    period = 0.8
    env.step(NOMINAL)
    snap1 = env.unwrapped.sensing()
    p0 = np.array([o.position for o in snap0.obstacles])
    p1 = np.array([o.position for o in snap1.obstacles])
    v1 = np.array([o.velocity for o in snap1.obstacles])
    assert np.allclose(v1, (p1 - p0) / period, atol=1e-9)  # the past step's motion
    env.step(NOMINAL)
    p2 = np.array([o.position for o in env.unwrapped.sensing().obstacles])
    # The crowd accelerates and breathes: the constant-velocity prediction is not the truth.
    assert not np.allclose(p1 + v1 * period, p2, atol=1e-4)
    names = {f.name for f in dataclasses.fields(snap1)}
    assert not any("scenario" in n or "world" in n or "future" in n for n in names)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reset_after_another_episode_replays_a_fresh_env(env_id):
    """The walls kept across resets change nothing: a used env replays a fresh one bit for bit."""
    def rollout(env, seed):
        obs, _ = env.reset(seed=seed)
        out = [obs]
        env.action_space.seed(seed)
        for _ in range(6):
            obs, reward, terminated, truncated, info = env.step(env.unwrapped.robot.nominal_command)
            out.append(np.append(obs, [reward, info["time"]]))
            if terminated or truncated:
                break
        return out

    fresh = gym.make(env_id)
    used = gym.make(env_id)
    rollout(used, 11)
    for a, b in zip(rollout(fresh, 3), rollout(used, 3), strict=True):
        np.testing.assert_array_equal(a, b)
    assert sorted(o.name for o in fresh.unwrapped.world.obstacles) == sorted(o.name for o in used.unwrapped.world.obstacles)


def test_walls_kept_across_randomized_speeds_replay_fresh_envs():
    """With ``randomize`` on a key the walls do not read, each episode of a used env is a fresh env's."""
    kwargs = {"randomize": {"door_speed": [5.0, 20.0], "door_angle_jitter": [0.0, 20.0]}}
    used = gym.make("FootstepDoor-v0", **kwargs)
    used.reset(seed=5)
    world = used.unwrapped.world
    for seed in (3, 4):
        fresh = gym.make("FootstepDoor-v0", **kwargs)
        for env in (fresh, used):
            env.reset(seed=seed)
        assert used.unwrapped.world is world  # walls kept
        assert fresh.unwrapped.episode_config == used.unwrapped.episode_config
        for _ in range(8):
            a, b = fresh.step(NOMINAL), used.step(NOMINAL)
            np.testing.assert_array_equal(a[0], b[0])
            assert a[1:4] == b[1:4] and a[4]["time"] == b[4]["time"] and a[4]["clearance"] == b[4]["clearance"]
            if a[2] or a[3]:
                break


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_compiled_sweep_off_gives_the_same_episodes(env_id):
    """``compiled_sweep=False`` (pymunk at every check, no numba) changes the cost of a step, not its outcome."""
    rng = np.random.default_rng(5)
    actions = [NOMINAL + rng.normal(0.0, 0.01, 5) * [1, 0.3, 1, 1, 0.5] for _ in range(60)]
    runs = []
    for compiled in (True, False):
        env = gym.make(env_id, compiled_sweep=compiled)
        assert env.unwrapped.config.compiled_sweep is compiled
        out = [env.reset(seed=2)[0]]
        for a in actions:
            obs, reward, terminated, truncated, info = env.step(a)
            out.append((obs.tolist(), reward, terminated, truncated, info["time"], info["clearance"], info["obstacle"]))
            if terminated or truncated:
                out.append(env.reset()[0])
        runs.append(out)
    assert str(runs[0]) == str(runs[1])
    code = ("import sys, gymnasium as gym, footstep_gym; e = gym.make(%r, compiled_sweep=False); e.reset(seed=0); "
            "[e.step(e.unwrapped.robot.nominal_command) for _ in range(3)]; print('numba' in sys.modules)" % env_id)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"  # such an env process never loads numba


@pytest.mark.parametrize("scene", sorted(SCENARIOS))
def test_static_keys_name_every_key_the_walls_read(scene):
    """Changing any key outside ``Scenario.static_keys`` leaves ``build_static``'s walls as they were."""
    from footstep_gym.world import World

    cls = SCENARIOS[scene]
    base = cls.load_config()

    def walls(cfg):
        world = World(0.1, 0.001, 0.02, 0.25, 2000)
        cls(cfg, np.random.default_rng(0)).build_static(world)
        return [(o.name, o.local_a, o.local_b, o.radius) for o in world.obstacles]

    if cls.static_keys is None:
        pytest.skip(f"{scene}: every key counts")
    changed = 0
    for f in dataclasses.fields(base):
        if f.name in cls.static_keys:
            continue
        value = getattr(base, f.name)
        if isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, float) for v in value):
            options = [tuple(v * 1.05 + 0.01 for v in value)]
        elif isinstance(value, float):
            options = [value * 0.9 + 0.01]
        else:
            options = []
        for new in options:
            try:
                cfg = config.replace(base, **{f.name: new})
            except ConfigError:
                continue
            assert walls(cfg) == walls(base), f.name
            changed += 1
    assert changed >= 5
    for key in cls.static_keys:  # and each static key does change them
        value = getattr(base, key)
        new = (tuple(v * 1.02 + 0.01 for v in value) if isinstance(value, tuple) else
               value + 1 if isinstance(value, int) else value * 1.02)
        assert walls(config.replace(base, **{key: new})) != walls(base), key


def test_randomized_geometry_rebuilds_the_walls():
    env = gym.make("FootstepDoor-v0", randomize={"door_radius": [0.45, 0.5]})
    env.reset(seed=0)
    ends = {o.name: tuple(o.shape.a) for o in env.unwrapped.world.obstacles if o.name == "wall_top_right"}
    env.reset(seed=1)
    again = {o.name: tuple(o.shape.a) for o in env.unwrapped.world.obstacles if o.name == "wall_top_right"}
    assert ends != again  # the upper wall's end follows the drawn door radius
    assert len([o for o in env.unwrapped.world.obstacles if o.name == "wall_top_right"]) == 1


# ------------------------------------------------------------------ stepping after the end
def end_episode(env, how):
    """Step ``env`` (reset at seed 0) until its episode ends the way ``how`` names; the last step's flags."""
    if how == "fall":  # -0.3 rad turns the left foot towards the right one: beyond turn_inner (0.2)
        actions = [np.array([0.0, 0.10, -0.3, 0.6, 0.2])]
    elif how == "collision":  # stepping in place while the car's side passes 8 cm from the CoM
        actions = [NOMINAL] * 10
    elif how == "goal":
        actions = strides(0.02, 0.04, 0.06, 0.08) + strides(*([0.10] * 30))
    else:
        actions = [NOMINAL] * 10
    env.reset(seed=0)
    for n, action in enumerate(actions, start=1):
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            return n, terminated, truncated, info
    raise AssertionError(f"the episode did not end by {how}")


END_SETTINGS = {
    "fall": ({}, "fall"),
    "collision": (dict(crossing_x=0.2, timing_jitter=0.0), "collision"),
    "goal": ({}, "goal"),
    "max_steps": (dict(max_steps=3), "truncated: max_steps=3 reached"),
    "time_limit": (dict(time_limit=2.0), "truncated: time_limit=2.0 s reached"),
}


@pytest.mark.parametrize("how", list(END_SETTINGS))
def test_step_after_the_episode_ended_raises_reset_needed(how):
    kwargs, words = END_SETTINGS[how]
    env = gym.make("FootstepCrossing-v0", **{**FREE, **kwargs})
    n, terminated, truncated, info = end_episode(env, how)
    assert (terminated, truncated) == ((False, True) if how in ("max_steps", "time_limit") else (True, False))
    if terminated:
        assert info["termination"] == how
    state = (env.unwrapped.time, env.unwrapped.steps, env.unwrapped.com)
    for action in (NOMINAL, np.array([0.0, 0.10, -0.3, 0.6, 0.2])):
        with pytest.raises(gym.error.ResetNeeded) as exc:
            env.step(action)
        message = str(exc.value)
        assert f"episode ended ({words}) at step {n}" in message and "reset()" in message
        assert message.startswith("FootstepCrossing-v0:")
    assert (env.unwrapped.time, env.unwrapped.steps, env.unwrapped.com) == state  # nothing moved on
    env.reset(seed=1)  # a reset starts a new episode that steps as usual
    _, _, _, _, info = env.step(NOMINAL)
    assert info["steps"] == 1 and info["time"] > 0.0


def test_step_after_the_end_raises_on_the_unwrapped_env_and_its_sensing_still_works():
    env = gym.make("FootstepDoor-v0").unwrapped
    n, *_ = end_episode(env, "fall")
    with pytest.raises(gym.error.ResetNeeded, match=r"FootstepDoor-v0: episode ended \(fall\) at step 1"):
        env.step(NOMINAL)
    assert env.sensing().time == 0.0  # what a planner reads after the end is still there
    direct = footstep_gym.env.FootstepEnv(scenario="crowd")
    with pytest.raises(gym.error.ResetNeeded, match=r"FootstepEnv\(scenario='crowd'\): call reset\(\) before step"):
        direct.step(NOMINAL)


def test_mix_env_after_the_end_raises_naming_the_mix_and_the_scene():
    env = gym.make("FootstepMix-v0", scenes=["crossing", "door"], crossing=dict(max_steps=2, **FREE),
                   door=dict(max_steps=2))
    with pytest.raises(gym.error.ResetNeeded, match="reset"):
        env.step(NOMINAL)
    with pytest.raises(gym.error.ResetNeeded, match=r"FootstepMixEnv \(scene 'crossing'\): call reset\(\) before step"):
        env.unwrapped.step(NOMINAL)
    for seed in range(4):
        _, info = env.reset(seed=seed)
        scene = info["scene"]
        env.step(NOMINAL)
        _, _, terminated, truncated, _ = env.step(NOMINAL)
        assert truncated and not terminated
        with pytest.raises(gym.error.ResetNeeded) as exc:
            env.step(NOMINAL)
        assert str(exc.value).startswith(f"FootstepMix-v0 (scene '{scene}'): episode ended (truncated: max_steps=2 reached) at step 2")
    bad = NOMINAL.copy()
    bad[3] = np.nan
    env.reset(seed=0)
    with pytest.raises(footstep_gym.ActionError, match=r"FootstepMix-v0 \(scene '\w+'\): .*t_ss=nan"):
        env.step(bad)


@pytest.mark.parametrize("mode", ["sync", "async"])
@pytest.mark.parametrize("env_id", ["FootstepCrossing-v0", "FootstepMix-v0"])
def test_vector_envs_reset_ended_episodes_by_themselves(env_id, mode):
    """Gymnasium's NEXT_STEP autoreset: the step after an end resets that sub-env, so nothing raises."""
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode=mode,
                        vector_kwargs={"autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP})
    try:
        envs.reset(seed=0)
        envs.action_space.seed(0)
        ended = 0
        for _ in range(30):  # random commands fall within a few steps
            _, reward, terminated, truncated, _ = envs.step(envs.action_space.sample())
            ended += int(np.sum(terminated | truncated))
            assert np.all(np.isfinite(reward))
        assert ended >= 4
    finally:
        envs.close()


@pytest.mark.parametrize("vec", ["dummy", "subproc"])
def test_sb3_vec_envs_reset_ended_episodes_by_themselves(vec):
    sb3_vec = pytest.importorskip("stable_baselines3.common.vec_env")
    fns = [lambda: gym.make("FootstepDoor-v0") for _ in range(2)]
    envs = sb3_vec.DummyVecEnv(fns) if vec == "dummy" else sb3_vec.SubprocVecEnv(fns, start_method="fork")
    try:
        envs.seed(0)
        envs.reset()
        rng = np.random.default_rng(0)
        space = envs.action_space
        dones = 0
        for _ in range(30):
            actions = rng.uniform(space.low, space.high, (2, 5)).astype(np.float32)
            _, reward, done, _ = envs.step(actions)
            dones += int(done.sum())
            assert np.all(np.isfinite(reward))
        assert dones >= 4
    finally:
        envs.close()


# ------------------------------------------------------------------ errors from a vector env's workers
@pytest.mark.parametrize("env_id, name", [("FootstepDoor-v0", "FootstepDoor-v0"),
                                          ("FootstepMix-v0", r"FootstepMix-v0 \(scene '\w+'\)")])
def test_async_worker_error_names_the_env_and_the_error(env_id, name):
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="async")
    try:
        envs.reset(seed=0)
        actions = np.tile(NOMINAL.astype(np.float32), (2, 1))
        actions[1, 3] = np.nan
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with pytest.raises(footstep_gym.ActionError,
                               match=rf"^{name}: action has non-finite field\(s\): t_ss=nan$"):
                envs.step(actions)
    finally:
        envs.close(terminate=True)
    # Gymnasium reports (as warnings) which worker failed, with the worker's traceback.
    logged = "\n".join(str(w.message) for w in caught)
    assert "Worker-1" in logged and "footstep_gym.errors.ActionError" in logged
