"""Actions as the env reads them (footstep_gym/env.py): parsing, clipping to the box, float32 edges.

A command outside the action box is clipped and applied clipped; a float32 action at a limit is
that limit (what SB3 and ``RescaleAction`` send), not a hair beyond; non-finite and wrong-shape
actions raise naming the problem. The box's bounds are robot.yaml read directly.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym
from env_helpers import ENV_IDS, FREE, NOMINAL, read_yaml


# ------------------------------------------------------------------ clipping
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


# ------------------------------------------------------------------ float32 at the edges of the box
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


# ------------------------------------------------------------------ footstep_gym.action: batched and one at a time
def random_actions(rng: np.random.Generator, low: np.ndarray, high: np.ndarray, n: int, dtype) -> np.ndarray:
    """Uniform in a box 20 % wider than [low, high], a quarter of the fields set to a limit cast to ``dtype``."""
    span = high - low
    actions = rng.uniform(low - 0.2 * span, high + 0.2 * span, (n, len(low)))
    at_limit = rng.random(actions.shape) < 0.25
    limits = np.where(rng.random(actions.shape) < 0.5, low, high)
    return np.where(at_limit, limits.astype(dtype), actions).astype(dtype)


@pytest.mark.parametrize("fixed_period", [False, True])
@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.float16])
def test_batched_actions_are_read_as_the_env_reads_each(fixed_period, dtype):
    """``action.to_commands`` on a batch equals the env's reading of each action (``info["command"]``,
    ``info["clipped"]``), float32/float16 limits pinned, the fixed period's tail appended."""
    from footstep_gym import action as act

    env = gym.make("FootstepCrossing-v0", fixed_period=fixed_period, **FREE).unwrapped
    limits = act.action_limits(env.robot, fixed_period)
    n = len(limits.fields)
    robot = read_yaml("robot.yaml")
    low, high = robot_limits(robot)
    batch = random_actions(np.random.default_rng(3), low[:n], high[:n], 200, dtype)
    commands, clipped = act.to_commands(batch, limits)
    assert commands.shape == (200, 5) and commands.dtype == np.float64 and clipped.shape == (200,)
    assert 20 < clipped.sum() < 180
    if fixed_period:
        assert np.all(commands[:, 3:] == [robot["nominal_t_ss"], robot["nominal_t_ds"]])
    for a, command, was_clipped in zip(batch, commands, clipped):
        env.reset(seed=0)
        *_, info = env.step(a)
        assert info["command"] == tuple(command.tolist()) and info["clipped"] == bool(was_clipped)
    # A field at a limit rounded to the dtype is the limit exactly; in float64 nothing is pinned.
    edges = np.array([high[:n], low[:n]], dtype=dtype)
    assert np.all(act.to_commands(edges, limits)[0][:, :n] == np.array([high[:n], low[:n]]))
    assert (dtype == np.float64) == np.all(edges.astype(np.float64) == [high[:n], low[:n]])  # rounded: pinned back


def test_inner_turn_limit_is_pinned_in_a_batch_too():
    from footstep_gym import action as act
    from footstep_gym.robot import load_robot

    robot = read_yaml("robot.yaml")
    limits = act.action_limits(load_robot())
    a = np.array([[0.0, 0.1, -robot["turn_inner"], 0.5, 0.2], [0.0, 0.1, robot["turn_inner"], 0.5, 0.2]],
                 dtype=np.float32)
    commands, clipped = act.to_commands(a, limits)
    assert commands[:, 2].tolist() == [-robot["turn_inner"], robot["turn_inner"]] and not clipped.any()


@pytest.mark.parametrize("bad, match", [(np.zeros((3, 4)), "last axis of 5"), (np.float32(1.0), "last axis"),
                                        (np.array([[0.0, 0.08, np.nan, 0.6, 0.2]]), "non-finite")])
def test_batched_bad_actions_raise_naming_the_problem(bad, match):
    from footstep_gym import action as act
    from footstep_gym.robot import load_robot

    with pytest.raises(footstep_gym.ActionError, match=match):
        act.to_commands(bad, act.action_limits(load_robot()))


def test_action_space_is_the_robot_box_in_float32():
    from footstep_gym import action as act
    from footstep_gym.robot import load_robot

    low, high = robot_limits(read_yaml("robot.yaml"))
    for fixed, n in ((False, 5), (True, 3)):
        box = act.action_space(act.action_limits(load_robot(), fixed))
        assert box.dtype == np.float32 and box.shape == (n,)
        assert np.array_equal(box.low, low[:n].astype(np.float32))
        assert np.array_equal(box.high, high[:n].astype(np.float32))
