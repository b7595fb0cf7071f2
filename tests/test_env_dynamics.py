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

from env_helpers import FREE, LEFT, NOMINAL, RIGHT, strides
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
