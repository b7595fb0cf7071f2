""":class:`ObstaclePredictor` against the snapshot's own prediction, a direct geometric computation and
pymunk's ground truth (the door and the crossing car move at constant (angular) velocity), and against
the simulator's future, which it must not see; shorter horizons for shapes whose motion changed.
"""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest

from footstep_gym.planners.prediction import ObstaclePredictor, sensed_accelerations, steady_motion_horizons
from planner_helpers import robot  # noqa: F401

# ====================================================================== prediction
def segment_distance(p, a, b):
    """Distance from points ``p (N, 2)`` to segments ``a``-``b`` ``(N, 2)`` (plain vector algebra)."""
    ab = b - a
    denom = (ab * ab).sum(axis=1)
    u = np.where(denom > 0, ((p - a) * ab).sum(axis=1) / np.where(denom > 0, denom, 1.0), 0.0)
    u = np.clip(u, 0.0, 1.0)
    return np.linalg.norm(p - (a + u[:, None] * ab), axis=1)


def direct_clearance(obstacles, points, times):
    """Nearest surface of each point at its own time, constant (angular) velocity, from the views."""
    best = np.full(len(points), np.inf)
    for o in obstacles:
        ang = o.angle + o.angular_velocity * times
        c, s = np.cos(ang), np.sin(ang)
        origin = np.asarray(o.position) + np.outer(times, o.velocity)

        def world(local):
            return origin + np.stack([c * local[0] - s * local[1], s * local[0] + c * local[1]], axis=1)

        a = world(o.a)
        b = world(o.b) if o.kind == "segment" else a
        best = np.minimum(best, segment_distance(points, a, b) - o.radius)
    return best


def snapshot_after(env_id, steps, seed=0, **kwargs):
    env = gym.make(env_id, **kwargs)
    env.reset(seed=seed)
    u = env.unwrapped
    for _ in range(steps):
        _, _, terminated, _, _ = env.step(u.robot.nominal_command)
        assert not terminated
    return env, u.sensing()


def sample_points(snapshot, n, rng, spread=1.0, t_max=4.0):
    centre = np.asarray(snapshot.com)
    pts = centre + rng.uniform(-spread, spread, (n, 2))
    times = rng.uniform(0.0, t_max, n)
    return pts, times


CASES = [
    ("FootstepDoor-v0", 0, dict(door_speed=17.0), (0.0, 0.0), 1.5),  # rod rotating about the door centre
    ("FootstepCrossing-v0", 1, dict(crossing_x=0.5), None, 1.5),  # capsule translating at constant velocity
    ("FootstepCrowd-v0", 1, {}, None, 0.6),  # circles, velocities set by the last step
]


@pytest.mark.parametrize("env_id,steps,kwargs,centre,spread", CASES)
def test_prediction_agrees_with_geometry_and_snapshot(env_id, steps, kwargs, centre, spread):
    env, snap = snapshot_after(env_id, steps, **kwargs)
    moving = [o for o in snap.obstacles if not o.static]
    assert moving and any(np.hypot(*o.velocity) > 0 or o.angular_velocity != 0 for o in moving)
    rng = np.random.default_rng(0)
    pts, times = sample_points(snap, 300, rng, spread=spread)
    if centre is not None:  # near the rod as well
        extra = np.asarray(centre) + rng.uniform(-0.6, 0.6, (300, 2))
        pts, times = np.vstack([pts, extra]), np.concatenate([times, rng.uniform(0.0, 4.0, 300)])
    pred = ObstaclePredictor(snap)
    got = pred.clearance(pts, times)
    np.testing.assert_allclose(got, direct_clearance(snap.obstacles, pts, times), atol=1e-9)
    # the snapshot's own prediction, one instant at a time
    for t in (0.0, 0.37, 1.0, 2.5):
        same_t = np.full(len(pts), t)
        np.testing.assert_allclose(pred.clearance(pts, same_t), snap.shapes_at(t).clearance(pts), atol=1e-9)
    # some samples are near or inside an obstacle, so the check is not vacuous
    assert got.min() < 0.05
    env.close()


def test_prediction_known_numbers_circle_and_rotating_rod():
    """Hand numbers: a circle moving at 0.5 m/s and a rod turning at 90 deg/s."""
    env, snap = snapshot_after("FootstepCrowd-v0", 0)
    from footstep_gym.sensing import ObstacleView

    circle = ObstacleView("c", "circle", False, (1.0, 0.0), 0.0, (0.5, 0.0), 0.0, 0.1, (0.0, 0.0), (0.0, 0.0))
    rod = ObstacleView("r", "segment", False, (0.0, 5.0), 0.0, (0.0, 0.0), math.pi / 2, 0.01,
                       (-0.5, 0.0), (0.5, 0.0))
    snap = dataclasses.replace(snap, obstacles=(circle, rod))
    pred = ObstaclePredictor(snap)
    env.close()
    # circle: at t = 2 its centre is at (2, 0)
    assert pred.distances([[3.0, 0.0]], [2.0])[0, 0] == pytest.approx(0.9)
    assert pred.distances([[2.0, 0.0]], [2.0])[0, 0] == pytest.approx(-0.1)
    assert pred.distances([[2.0, 0.3]], [0.0])[0, 0] == pytest.approx(math.hypot(1.0, 0.3) - 0.1)
    # rod: horizontal at t = 0, vertical at t = 1 s (a quarter turn counter-clockwise)
    assert pred.distances([[0.0, 5.4]], [0.0])[0, 1] == pytest.approx(0.39)
    assert pred.distances([[0.0, 5.4]], [1.0])[0, 1] == pytest.approx(-0.01)
    assert pred.distances([[0.4, 5.0]], [1.0])[0, 1] == pytest.approx(0.39)
    assert pred.distances([[0.4, 5.0]], [2.0])[0, 1] == pytest.approx(-0.01)
    # the rod's tip after 45 degrees
    tip = np.array([0.0, 5.0]) + 0.5 * np.array([math.cos(math.pi / 4), math.sin(math.pi / 4)])
    assert pred.distances([tip], [0.5])[0, 1] == pytest.approx(-0.01)


@pytest.mark.parametrize("env_id,steps,kwargs", [("FootstepDoor-v0", 0, dict(door_speed=14.0)),
                                                 ("FootstepCrossing-v0", 1, dict(crossing_x=0.5))])
def test_prediction_matches_pymunk_for_constant_motion(env_id, steps, kwargs):
    """Door and crossing car move at constant (angular) velocity: the prediction is pymunk's future."""
    env, snap = snapshot_after(env_id, steps, **kwargs)
    pred = ObstaclePredictor(snap)
    rng = np.random.default_rng(3)
    world = env.unwrapped.world
    t_prev = 0.0
    for t in (0.3, 0.8, 1.6, 3.0):
        world.advance(t - t_prev)
        t_prev = t
        pts = np.asarray(snap.com) + rng.uniform(-1.5, 1.5, (60, 2))
        if env_id == "FootstepDoor-v0":
            pts = np.vstack([pts, rng.uniform(-0.6, 0.6, (60, 2))])
        truth = np.array([world.clearance(tuple(p), 100.0)[0] for p in pts])  # pymunk's nearest-shape query
        np.testing.assert_allclose(pred.clearance(pts, np.full(len(pts), t)), truth, atol=1e-6)
    env.close()


def test_prediction_horizon_drops_moving_obstacles():
    env, snap = snapshot_after("FootstepDoor-v0", 0)
    pts = np.array([[0.0, -0.3], [0.3, 0.0], [1.0, -0.5]])
    full = ObstaclePredictor(snap)
    short = ObstaclePredictor(snap, horizon=1.0)
    static_only = [o for o in snap.obstacles if o.static]
    for t in (0.0, 0.5, 1.0):
        np.testing.assert_allclose(short.clearance(pts, np.full(3, t)), full.clearance(pts, np.full(3, t)))
    for t in (1.001, 1.05, 1.5):
        t = np.full(3, t)
        np.testing.assert_allclose(short.clearance(pts, t), direct_clearance(static_only, pts, t), atol=1e-9)
    # the door's centre lies on the rod: beyond the horizon it is no longer checked
    assert full.clearance(np.zeros((1, 2)), [1.01])[0] < 0
    assert short.clearance(np.zeros((1, 2)), [1.01])[0] > 0
    env.close()


@pytest.mark.parametrize("env_id,kwargs", [("FootstepCrowd-v0", {}), ("FootstepDoor-v0", {}),
                                           ("FootstepCrossing-v0", dict(crossing_x=0.5))])
def test_prediction_never_reads_the_simulator_future(env_id, kwargs):
    env, snap = snapshot_after(env_id, 1, **kwargs)
    u = env.unwrapped
    pred = ObstaclePredictor(snap)
    rng = np.random.default_rng(1)
    pts, times = sample_points(snap, 200, rng, spread=1.0, t_max=3.0)
    before = pred.clearance(pts, times).copy()
    sensed = [(o.position, o.angle, o.velocity, o.angular_velocity) for o in snap.obstacles]
    # the simulator moves on (and, for the crowd, its members change velocity)
    for _ in range(3):
        _, _, terminated, _, _ = env.step(u.robot.nominal_command)
        if terminated:
            break
    # ... and is even tampered with: teleport and re-aim every kinematic body
    for o in u.world.obstacles:
        if not o.static:
            o.body.position = (o.body.position.x + 5.0, o.body.position.y - 5.0)
            o.body.velocity = (1.0, 1.0)
            o.body.angular_velocity = 1.0
    np.testing.assert_array_equal(pred.clearance(pts, times), before)  # the same code on the same inputs: exact
    assert [(o.position, o.angle, o.velocity, o.angular_velocity) for o in snap.obstacles] == sensed
    np.testing.assert_allclose(before, direct_clearance(snap.obstacles, pts, times), atol=1e-9)
    # a predictor from a fresh snapshot does see the change, so the comparison above is not vacuous
    fresh = ObstaclePredictor(u.sensing())
    assert not np.allclose(fresh.clearance(pts, times), before)
    env.close()


def test_crowd_prediction_is_constant_velocity_not_the_schedule():
    """The crowd changes velocity every step; the prediction extrapolates the sensed one regardless."""
    env, snap = snapshot_after("FootstepCrowd-v0", 2, seed=4)
    u = env.unwrapped
    period = float(sum(u.robot.nominal_command[3:]))
    pred = ObstaclePredictor(snap)
    pts = np.asarray(snap.com) + np.random.default_rng(0).uniform(-0.6, 0.6, (200, 2))
    later = np.full(len(pts), 3 * period)
    predicted = pred.clearance(pts, later)
    # the simulator's own schedule of the members, 3 periods on
    centres = u.scenario.positions(snap.time + 3 * period)
    radius = u.scenario.cfg.member_radius
    truth = (np.linalg.norm(pts[:, None, :] - centres[None], axis=-1) - radius).min(axis=1)
    np.testing.assert_allclose(predicted, direct_clearance(snap.obstacles, pts, later), atol=1e-9)
    assert not np.allclose(predicted, truth, atol=1e-6)  # the crowd did not keep its sensed velocity
    env.close()



SHORT_H, SPEED_TOL, TURN_TOL = 2.4, 0.01, 0.01


def two_snapshots(env_id, seed=0, **kwargs):
    """Snapshots after the first and the second nominal step (what a planner sensed one step apart)."""
    env = gym.make(env_id, **kwargs)
    env.reset(seed=seed)
    u = env.unwrapped
    snaps = []
    for _ in range(2):
        _, _, terminated, _, _ = env.step(u.robot.nominal_command)
        assert not terminated
        snaps.append(u.sensing())
    env.close()
    return snaps


def test_steady_motion_horizons_crowd_flags_members_whose_velocity_changed():
    previous, snap = two_snapshots("FootstepCrowd-v0")
    before = {v.name: v for v in previous.obstacles}
    expected = {}
    for v in snap.obstacles:
        dv = math.hypot(v.velocity[0] - before[v.name].velocity[0], v.velocity[1] - before[v.name].velocity[1])
        assert abs(dv - SPEED_TOL) > 1e-4  # no member on the fence: the answer does not hang on rounding
        if dv > SPEED_TOL:
            expected[v.name] = SHORT_H
    # the crowd changes its members' velocities every step, but not all of them by much
    assert 0 < len(expected) < len(snap.obstacles)
    assert steady_motion_horizons(previous, snap, SHORT_H, SPEED_TOL, TURN_TOL) == expected
    # a tolerance above every change flags none; one below every change flags all
    changes = [math.hypot(v.velocity[0] - before[v.name].velocity[0], v.velocity[1] - before[v.name].velocity[1])
               for v in snap.obstacles]
    assert steady_motion_horizons(previous, snap, SHORT_H, max(changes) + 1e-6, TURN_TOL) == {}
    assert min(changes) > 1e-6
    assert steady_motion_horizons(previous, snap, 1.0, min(changes) - 1e-7, TURN_TOL) == {
        v.name: 1.0 for v in snap.obstacles}
    assert steady_motion_horizons(None, snap, SHORT_H, SPEED_TOL, TURN_TOL) == {}


@pytest.mark.parametrize("env_id,kwargs", [("FootstepDoor-v0", dict(door_speed=17.0)),
                                           ("FootstepCrossing-v0", dict(crossing_x=0.5))])
def test_steady_motion_horizons_empty_for_constant_motion(env_id, kwargs):
    previous, snap = two_snapshots(env_id, **kwargs)
    moving = [v for v in snap.obstacles if not v.static]
    assert moving and all(np.hypot(*v.velocity) > 0 or v.angular_velocity != 0 for v in moving)
    before = {v.name: v for v in previous.obstacles}
    for v in moving:  # read from the snapshots: the motion did not change
        assert v.velocity == pytest.approx(before[v.name].velocity, abs=1e-12)
        assert v.angular_velocity == pytest.approx(before[v.name].angular_velocity, abs=1e-12)
    assert steady_motion_horizons(previous, snap, SHORT_H, SPEED_TOL, TURN_TOL) == {}
    assert steady_motion_horizons(None, snap, SHORT_H, SPEED_TOL, TURN_TOL) == {}


def test_steady_motion_horizons_turn_and_speed_changes_of_one_shape():
    """Edit the previous snapshot's door rod / crossing car: exactly that shape is flagged."""
    previous, snap = two_snapshots("FootstepDoor-v0", door_speed=17.0)
    turned = tuple(dataclasses.replace(v, angular_velocity=v.angular_velocity + 0.05) if v.name == "door" else v
                   for v in previous.obstacles)
    prev = dataclasses.replace(previous, obstacles=turned)
    assert steady_motion_horizons(prev, snap, SHORT_H, SPEED_TOL, TURN_TOL) == {"door": SHORT_H}
    assert steady_motion_horizons(prev, snap, SHORT_H, SPEED_TOL, 0.06) == {}
    previous, snap = two_snapshots("FootstepCrossing-v0", crossing_x=0.5)
    slowed = tuple(dataclasses.replace(v, velocity=(v.velocity[0], v.velocity[1] - 0.02)) for v in previous.obstacles)
    prev = dataclasses.replace(previous, obstacles=slowed)
    assert steady_motion_horizons(prev, snap, 1.5, SPEED_TOL, TURN_TOL) == {"car": 1.5}
    assert steady_motion_horizons(prev, snap, 1.5, 0.03, TURN_TOL) == {}


# ====================================================================== prediction: per-shape horizons
def test_per_shape_horizon_ignores_that_shape_after_it_only():
    """``horizons={"car": 1.0}``: the car is checked up to 1 s, then ignored; the rest is unchanged."""
    env, snap = snapshot_after("FootstepCrossing-v0", 1, crossing_x=0.5)
    env.close()
    (car,) = snap.obstacles
    full = ObstaclePredictor(snap)
    short = ObstaclePredictor(snap, horizons={"car": 1.0})
    t = np.array([0.0, 0.5, 0.99, 1.0, 1.01, 1.5, 3.0])
    centre = np.asarray(car.position) + t[:, None] * np.asarray(car.velocity)  # inside the car at its time
    before = t <= 1.0
    d_full, d_short = full.distances(centre, t)[:, 0], short.distances(centre, t)[:, 0]
    assert np.all(d_full < 0)
    np.testing.assert_allclose(d_short[before], d_full[before], rtol=0, atol=1e-12)
    assert np.all(np.isinf(d_short[~before]))
    np.testing.assert_array_equal(short.free(centre, t, 0.0), ~before)
    assert not full.free(centre, t, 0.0).any()


def test_per_shape_horizon_on_the_door_leaves_walls_checked():
    env, snap = snapshot_after("FootstepDoor-v0", 0)
    env.close()
    pred = ObstaclePredictor(snap, horizon=5.0, horizons={"door": 1.0, "wall_bottom": 0.5})
    hub = np.zeros((4, 2))  # the rod's pivot: on the rod at every time
    t = np.array([0.5, 1.0, 1.5, 4.0])
    np.testing.assert_array_equal(pred.free(hub, t, 0.0), [False, False, True, True])
    # a wall does not move: a per-shape horizon does not drop it
    on_wall = np.tile([1.0, -0.66], (4, 1))
    assert not pred.free(on_wall, np.array([0.1, 0.6, 3.0, 10.0]), 0.0).any()


# ====================================================================== sensed accelerations (additions.acceleration)
def test_an_accelerating_shape_is_predicted_at_p_v_t_plus_half_a_t_squared_up_to_the_cap():
    """``p + v t + a tau (t - tau / 2)``, ``tau = min(t, cap)``: the constant-acceleration parabola up to the cap, then
    the velocity reached; shapes without an acceleration (and a cap of 0) stay at constant velocity, exactly."""
    env, snap = snapshot_after("FootstepCrowd-v0", 3, seed=2)
    name = next(v.name for v in snap.obstacles if not v.static)
    view = next(v for v in snap.obstacles if v.name == name)
    a = np.array([0.04, -0.02])
    plain = ObstaclePredictor(snap, horizon=30.0)
    accel = ObstaclePredictor(snap, horizon=30.0, accelerations={name: tuple(a)}, acceleration_horizon=1.0)
    index = [v.name for v in snap.obstacles].index(name)
    for t in (0.0, 0.4, 1.0, 2.0):
        tau = min(t, 1.0)
        centre = np.asarray(view.position) + np.asarray(view.velocity) * t + a * tau * (t - 0.5 * tau)
        d = accel.distances(centre[None], [t])[0]
        assert d[index] == pytest.approx(-view.radius, abs=1e-12)  # the predicted centre is that shape's centre
        others = np.delete(np.arange(len(d)), index)
        np.testing.assert_array_equal(d[others], plain.distances(centre[None], [t])[0][others])
    off = ObstaclePredictor(snap, horizon=30.0, accelerations={name: tuple(a)}, acceleration_horizon=0.0)
    pts = np.asarray(snap.com) + np.random.default_rng(0).uniform(-1, 1, (50, 2))
    times = np.linspace(0, 3, 50)
    np.testing.assert_array_equal(off.clearance(pts, times), plain.clearance(pts, times))
    np.testing.assert_array_equal(off.shapes.rows, plain.shapes.rows)
    env.close()


def test_sensed_accelerations_are_finite_differences_of_what_was_sensed():
    """``(v_now - v_then) / (t_now - t_then)`` over the history's oldest snapshot; shapes whose velocity did not
    change are left out (the car, the door: their prediction is exactly constant-velocity); pooled: the mean."""
    env, first = snapshot_after("FootstepCrowd-v0", 2, seed=3)
    u = env.unwrapped
    history = [first]
    for _ in range(2):
        env.step(u.robot.nominal_command)
        history.append(u.sensing())
    now = history.pop()
    own = sensed_accelerations(history, now)
    dt = now.time - history[0].time
    assert own and dt > 0
    for v in now.obstacles:
        old = next(o for o in history[0].obstacles if o.name == v.name)
        want = ((v.velocity[0] - old.velocity[0]) / dt, (v.velocity[1] - old.velocity[1]) / dt)
        if want == (0.0, 0.0):
            assert v.name not in own
        else:
            assert own[v.name] == pytest.approx(want, abs=1e-15)
    pooled = sensed_accelerations(history, now, pooled=True)
    mean = np.mean(list(own.values()), axis=0)
    assert set(pooled) == set(own) and all(np.allclose(a, mean) for a in pooled.values())
    assert sensed_accelerations([], now) == {}
    env.close()
    for env_id in ("FootstepDoor-v0", "FootstepCrossing-v0"):  # steady motion: no acceleration at all
        env, snap = snapshot_after(env_id, 1)
        env.step(env.unwrapped.robot.nominal_command)
        assert sensed_accelerations([snap], env.unwrapped.sensing()) == {}
        env.close()
