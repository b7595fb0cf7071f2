"""Shared pytest setup: pygame must be able to open a (dummy) display on a headless machine; the fixtures
several test files share (``robot``, ``x64``). Shared plain helpers live in env_helpers.py, planner_helpers.py and
jax_helpers.py."""

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


@pytest.fixture(scope="module")
def x64():
    """JAX's 64-bit mode for the module's tests (the JAX backend's float64 replays)."""
    import jax

    with jax.enable_x64(True):
        yield
