"""The env's per-step safety figures: ``info["clearance"]`` and ``info["zmp_margin"]``.

Checked against independent geometry: the clearance against the distance from the body
circle to the obstacle computed here by hand, the ZMP margin against the stable region's
half sizes and the reported ZMP offset.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

NOMINAL = np.array([0.0, 0.08, 0.0, 0.6, 0.2], dtype=np.float32)


def test_zmp_margin_is_the_distance_to_the_stable_regions_edge():
    env = gym.make("FootstepCrossing-v0", crossing_x=5.0)
    env.reset(seed=0)
    hx, hy = env.unwrapped.robot.zmp_half_extent
    for command in (NOMINAL, [0.06, 0.08, 0.1, 0.4, 0.15], [0.06, 0.08, 0.0, 0.1, 0.1]):
        *_, terminated, _, info = env.step(np.asarray(command, dtype=np.float32))
        px, py = info["zmp_offset"]
        assert info["zmp_margin"] == pytest.approx(min(hx - abs(px), hy - abs(py)))
        assert (info["zmp_margin"] >= 0) == info["feasible"] or not info["feasible"]
        if terminated:
            break
    assert info["termination"] == "fall" and info["zmp_margin"] < 0 and info["clearance"] is None


def test_clearance_against_a_standing_robot_and_a_known_circle():
    """A still crowd member at a known distance: the clearance is that gap, to the sweep's resolution."""
    env = gym.make("FootstepCrowd-v0", crowd_speed=0.0, breathing_amplitude=0.0)
    obs, _ = env.reset(seed=1)
    base = env.unwrapped
    step_in_place = np.array([0.0, 0.08, 0.0, 0.6, 0.2], dtype=np.float32)
    *_, info = env.step(step_in_place)
    com = np.array(info["com"])
    gaps = [math.hypot(*(np.array(o.position) - com)) - o.radius - base.robot.body_radius
            for o in base.sensing().obstacles if o.kind == "circle"]
    # The body moved by the CoM sway during the step; the smallest gap seen is within that of the end state.
    assert info["clearance"] <= min(gaps) + 1e-9
    assert info["clearance"] >= min(gaps) - 0.05


def test_clearance_is_negative_on_a_collision_and_inf_when_nothing_is_near():
    env = gym.make("FootstepCrossing-v0", crossing_x=20.0)
    env.reset(seed=0)
    *_, info = env.step(NOMINAL)
    assert info["clearance"] == math.inf
    crowd = gym.make("FootstepCrowd-v0")
    crowd.reset(seed=0)
    for _ in range(40):  # the fixed nominal command is overtaken by the crowd
        *_, terminated, truncated, info = crowd.step(NOMINAL)
        if terminated or truncated:
            break
    assert info["termination"] == "collision" and info["clearance"] < 0
