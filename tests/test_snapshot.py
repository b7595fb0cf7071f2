"""The read-only sensing snapshot (footstep_gym/sensing.py, ``env.unwrapped.sensing()``).

It matches the step's info, cannot be written to and does not follow the env on; its predictions of the
door and the crossing car are exact (both move at constant rates), and it holds nothing of the crowd's
future. References are the obstacles' own later poses and hand geometry.
"""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest

from env_helpers import ENV_IDS, LEFT, NOMINAL, RIGHT


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
