"""``FootstepCrossing-v0`` (footstep_gym/scenarios/crossing.py): the obstacle's draws per seed.

The reference is scenarios/crossing.yaml read directly.
"""

from __future__ import annotations

import gymnasium as gym
import pytest

from env_helpers import moving, read_yaml


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
