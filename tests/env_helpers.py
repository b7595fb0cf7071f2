"""Shared hand-made inputs of the env tests (test_env_api.py, test_actions.py, test_scenario_*.py, ...).

Written out here, or read from the YAML files directly, never from the code under test.
"""

from __future__ import annotations

import numpy as np
import yaml

from footstep_gym.config import config_dir

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


def moving(env):
    return [o for o in env.unwrapped.sensing().obstacles if not o.static]
