"""Physics read off the env (footstep_gym/env.py over lipm.py and footstep.py).

The figures of docs/model.md §3.3 seen through ``step``: stepping in place needs no ZMP offset, an abrupt
cut of the period is feasible or a fall as the table says, the turn limits depend on which foot swings,
and each placed foot follows the footstep convention of docs/model.md §2, worked out by hand.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from env_helpers import FREE, LEFT, NOMINAL, RIGHT, read_yaml, strides
from footstep_gym import footstep


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


# ------------------------------------------------------------------ why a step is a fall: info["fall"]
def first_step(action, env_id="FootstepCrossing-v0", **kwargs):
    env = gym.make(env_id, **{**FREE, **kwargs})
    _, info = env.reset(seed=0)
    assert info["support_foot"] == "right"  # the left foot swings: theta > 0 turns it away (outer)
    return env.step(np.array(action))[-1]


@pytest.mark.parametrize("action, reason", [
    ([0.0, 0.10, -0.3, 0.6, 0.2], "turn_limit"),  # towards the support foot, beyond turn_inner = 0.2
    ([0.0, 0.07, 0.3, 0.6, 0.2], "overlap"),      # a legal outward turn, but the turned sole's corner meets the other
    ([0.10, 0.12, 0.0, 0.1, 0.02], "zmp"),        # from standing, the longest stride at the shortest period
    ([0.0, 0.08, 0.0, 0.6, 0.2], None),           # stepping in place
])
def test_info_says_why_a_step_is_a_fall(action, reason):
    info = first_step(action)
    assert info["fall"] == reason
    assert info["feasible"] == (reason is None) and (info["termination"] == "fall") == (reason is not None)
    if reason == "zmp":
        assert info["zmp_margin"] < 0
    elif reason is not None:  # a kinematic fall says nothing of the ZMP: here it lies inside the region
        assert info["zmp_margin"] > 0 and info["clearance"] is None and info["time"] == 0.0


def test_fall_after_an_abrupt_period_cut_is_a_zmp_fall():
    env = gym.make("FootstepCrossing-v0", **FREE)
    env.reset(seed=0)
    for action in strides(0.02, 0.035, 0.05, 0.05, 0.05):
        env.step(action)
    *_, info = env.step(np.array([0.05, 0.08, 0.0, 0.1, 0.2]))
    assert info["fall"] == "zmp" and info["zmp_margin"] < 0


def test_fall_reasons_match_the_limits_read_off_robot_yaml():
    """200 random first steps: ``info["fall"]`` is the first limit the command breaks, each worked out here from
    robot.yaml (the turn interval of the swinging side, the soles' separating-axis test, the ZMP region)."""
    robot = read_yaml("robot.yaml")
    hx, hy = (robot["foot_length"] + robot["foot_clearance"]) / 2, (robot["foot_width"] + robot["foot_clearance"]) / 2
    zx, zy = robot["zmp_region_scale"] * robot["foot_length"] / 2, robot["zmp_region_scale"] * robot["foot_width"] / 2
    env = gym.make("FootstepCrossing-v0", **FREE)
    low, high = env.action_space.low.astype(float), env.action_space.high.astype(float)
    rng = np.random.default_rng(11)
    seen = set()
    for _ in range(200):
        env.reset(seed=0)
        action = rng.uniform(low, high)
        *_, info = env.step(action)
        S, L, theta = action[:3]
        support = [(u, v) for u in (-hx, hx) for v in (-hy, hy)]  # the right sole's corners, its own frame
        swing = [(S + u * math.cos(theta) - v * math.sin(theta), L + u * math.sin(theta) + v * math.cos(theta))
                 for u, v in support]  # the left sole's, in the right one's frame
        axes = [(1.0, 0.0), (0.0, 1.0), (math.cos(theta), math.sin(theta)), (-math.sin(theta), math.cos(theta))]
        # Two convex rectangles overlap iff no axis of either separates their projections.
        overlap = True
        for ax, ay in axes:
            a = [x * ax + y * ay for x, y in support]
            b = [x * ax + y * ay for x, y in swing]
            if max(a) < min(b) or max(b) < min(a):
                overlap = False
        px, py = info["zmp_offset"]
        expected = ("turn_limit" if not -robot["turn_inner"] <= theta <= robot["turn_outer"]
                    else "overlap" if overlap else "zmp" if abs(px) > zx or abs(py) > zy else None)
        assert info["fall"] == expected, (action, info["fall"], expected)
        seen.add(expected)
    assert seen == {None, "turn_limit", "overlap", "zmp"}


@pytest.mark.parametrize("command", [(0.2, 0.08, 0.0, 0.6, 0.2), (0.0, 0.08, 0.0, 0.6, 0.0),
                                     (math.nan, 0.08, 0.0, 0.6, 0.2)])
def test_a_command_outside_the_box_breaks_the_limits_first(command):
    """``footstep.kinematic_violation`` names the box first; the env clips to the box, so never reports it."""
    from footstep_gym.robot import load_robot

    assert footstep.kinematic_violation(load_robot(), *command, RIGHT) == "limits"
    if not math.isnan(command[0]):
        info = first_step(command)
        assert info["clipped"] and info["fall"] is None
