"""Shared pytest setup: pygame must be able to open a (dummy) display on a headless machine; the fixtures
several test files share (``robot``). Shared plain helpers live in env_helpers.py and planner_helpers.py."""

import os

# Before anything imports pygame: "human" rendering then works without a screen.
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import pytest  # noqa: E402  (after the environment above, like everything that may pull in pygame)


@pytest.fixture(scope="module")
def robot():
    """The default robot (configs/robot.yaml); a test module may define its own ``robot`` instead."""
    from footstep_gym.robot import load_robot

    return load_robot()
