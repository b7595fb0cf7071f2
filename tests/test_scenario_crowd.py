"""``FootstepCrowd-v0`` (footstep_gym/scenarios/crowd.py): the crowd's draws per seed.

The reference is scenarios/crowd.yaml read directly.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from env_helpers import moving, read_yaml


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
