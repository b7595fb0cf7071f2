"""The footstep convention (footstep_gym/footstep.py).

References are independent of the code: hand-worked poses and an exact convex-polygon
clipping for the foot overlap. (The robot config, robot.py read against the YAML file, is
tested in test_config.py; the ``robot`` fixture is conftest.py's.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from footstep_gym import footstep
from footstep_gym.footstep import (
    LEFT, RIGHT, command_between, feet_overlap, foot_from_node, kinematically_feasible,
    place_foot, robot_centre, turn_bounds, wrap_angle,
)
from footstep_gym.robot import load_robot


def angle_diff(a, b):
    """a - b modulo 2 pi, in (-pi, pi]."""
    return np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b))))


# ------------------------------------------------------------------ 1. round trips
def test_place_then_command_round_trip_scalar():
    rng = np.random.default_rng(20)
    for _ in range(200):
        pose = (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-4, 4))
        side = int(rng.choice([LEFT, RIGHT]))
        S, L, theta = rng.uniform(-0.2, 0.2), rng.uniform(0.0, 0.2), rng.uniform(-3.0, 3.0)
        new = place_foot(pose, side, S, L, theta)
        S2, L2, th2 = command_between(pose, side, new)
        assert S2 == pytest.approx(S, abs=1e-12)
        assert L2 == pytest.approx(L, abs=1e-12)
        assert th2 == pytest.approx(theta, abs=1e-12)


def test_command_then_place_round_trip_scalar():
    rng = np.random.default_rng(21)
    for _ in range(200):
        a = (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-10, 10))
        b = (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-10, 10))
        side = int(rng.choice([LEFT, RIGHT]))
        S, L, theta = command_between(a, side, b)
        x, y, yaw = place_foot(a, side, S, L, theta)
        assert x == pytest.approx(b[0], abs=1e-12)
        assert y == pytest.approx(b[1], abs=1e-12)
        assert abs(angle_diff(yaw, b[2])) < 1e-12
        assert -math.pi <= yaw < math.pi and -math.pi <= theta < math.pi


def test_round_trips_vectorised():
    rng = np.random.default_rng(22)
    N = 500
    pose = (rng.uniform(-5, 5, N), rng.uniform(-5, 5, N), rng.uniform(-4, 4, N))
    sides = rng.choice([LEFT, RIGHT], N)
    S, L, theta = rng.uniform(-0.2, 0.2, N), rng.uniform(0, 0.2, N), rng.uniform(-3, 3, N)
    new = place_foot(pose, sides, S, L, theta)
    back = command_between(pose, sides, new)
    for got, want in zip(back, (S, L, theta)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # element i of the batch equals the scalar call
    for i in range(0, N, 97):
        xi = place_foot((pose[0][i], pose[1][i], pose[2][i]), int(sides[i]), S[i], L[i], theta[i])
        np.testing.assert_allclose([n[i] for n in new], xi, atol=1e-15)
    other = (rng.uniform(-5, 5, N), rng.uniform(-5, 5, N), rng.uniform(-10, 10, N))
    cmd = command_between(pose, sides, other)
    x, y, yaw = place_foot(pose, sides, *cmd)
    np.testing.assert_allclose(x, other[0], atol=1e-12)
    np.testing.assert_allclose(y, other[1], atol=1e-12)
    assert np.all(np.abs(angle_diff(yaw, other[2])) < 1e-12)


def test_stride_is_measured_in_the_support_frame():
    """|(S, L)| is the distance between the feet; S and L do not depend on the world frame."""
    rng = np.random.default_rng(23)
    for _ in range(50):
        pose = (rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-3, 3))
        side = int(rng.choice([LEFT, RIGHT]))
        S, L, th = rng.uniform(-0.1, 0.1), rng.uniform(0.05, 0.15), rng.uniform(-0.5, 0.5)
        x, y, _ = place_foot(pose, side, S, L, th)
        assert math.hypot(x - pose[0], y - pose[1]) == pytest.approx(math.hypot(S, L), abs=1e-12)
        # rigidly move the world: the same command comes out
        phi, tx, ty = rng.uniform(-3, 3), rng.uniform(-2, 2), rng.uniform(-2, 2)
        c, s = math.cos(phi), math.sin(phi)

        def move(p):
            return (c * p[0] - s * p[1] + tx, s * p[0] + c * p[1] + ty, p[2] + phi)

        cmd = command_between(move(pose), side, move((x, y, pose[2] + th)))
        np.testing.assert_allclose(cmd, (S, L, th), atol=1e-12)


def test_wrap_angle():
    assert wrap_angle(math.pi) == pytest.approx(-math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(-math.pi)
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(0.3 + 4 * math.pi) == pytest.approx(0.3)
    a = np.linspace(-20, 20, 1001)
    w = wrap_angle(a)
    assert np.all((w >= -math.pi) & (w < math.pi))
    np.testing.assert_allclose(np.exp(1j * w), np.exp(1j * a), atol=1e-12)


# ------------------------------------------------------------------ 2. convention by hand
def test_convention_by_hand():
    # support right foot at the origin: the left foot lands forward and to the left
    np.testing.assert_allclose(place_foot((0.0, 0.0, 0.0), RIGHT, 0.05, 0.08, 0.1), (0.05, 0.08, 0.1), atol=1e-15)
    # support left foot: the right foot lands forward and to the right (L > 0 is outward)
    np.testing.assert_allclose(place_foot((0.0, 0.0, 0.0), LEFT, 0.05, 0.08, 0.1), (0.05, -0.08, 0.1), atol=1e-15)
    # support yaw pi/2: forward is +y, the left of the heading is -x
    np.testing.assert_allclose(place_foot((1.0, 2.0, math.pi / 2), RIGHT, 0.05, 0.0, 0.0),
                               (1.0, 2.05, math.pi / 2), atol=1e-15)
    np.testing.assert_allclose(place_foot((1.0, 2.0, math.pi / 2), RIGHT, 0.05, 0.08, -0.2),
                               (1.0 - 0.08, 2.05, math.pi / 2 - 0.2), atol=1e-15)
    np.testing.assert_allclose(place_foot((1.0, 2.0, math.pi / 2), LEFT, 0.05, 0.08, 0.0),
                               (1.0 + 0.08, 2.05, math.pi / 2), atol=1e-15)
    # and the inverse by hand
    np.testing.assert_allclose(command_between((0.0, 0.0, 0.0), LEFT, (0.03, -0.09, -0.2)),
                               (0.03, 0.09, -0.2), atol=1e-15)
    assert LEFT == 1 and RIGHT == -1


# ------------------------------------------------------------------ 3. turn bounds
def test_turn_bounds(robot):
    # support right -> left swing: inner is clockwise (negative), outer counter-clockwise
    assert turn_bounds(RIGHT, robot) == pytest.approx((-robot.turn_inner, robot.turn_outer))
    assert turn_bounds(LEFT, robot) == pytest.approx((-robot.turn_outer, robot.turn_inner))
    assert turn_bounds(RIGHT, robot) == pytest.approx((-0.2, 0.4))  # paper Fig. 4 values in the config
    lo, hi = turn_bounds(np.array([LEFT, RIGHT, RIGHT]), robot)
    np.testing.assert_allclose(lo, [-robot.turn_outer, -robot.turn_inner, -robot.turn_inner])
    np.testing.assert_allclose(hi, [robot.turn_inner, robot.turn_outer, robot.turn_outer])
    for side in (LEFT, RIGHT):  # one side as int, numpy integer or 0-d array: the same bounds as floats
        want = turn_bounds(np.array(side), robot)
        for given in (side, np.int64(side), np.int32(side)):
            got = turn_bounds(given, robot)
            assert got == want and all(isinstance(b, float) for b in got)


# ------------------------------------------------------------------ 4. overlap and feasibility
def _rect(cx, cy, yaw, hx, hy):
    c, s = math.cos(yaw), math.sin(yaw)
    return [(cx + c * u - s * v, cy + s * u + c * v) for u, v in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))]


def _clip(subject, clip):
    """Sutherland-Hodgman: the part of convex polygon ``subject`` inside convex CCW ``clip``."""
    out = subject
    for i in range(len(clip)):
        (ax, ay), (bx, by) = clip[i], clip[(i + 1) % len(clip)]

        def inside(p):
            return (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax) >= 0

        def cross(p, q):
            d1 = (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax)
            d2 = (bx - ax) * (q[1] - ay) - (by - ay) * (q[0] - ax)
            t = d1 / (d1 - d2)
            return (p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]))

        inp, out = out, []
        for j in range(len(inp)):
            p, q = inp[j], inp[(j + 1) % len(inp)]
            if inside(q):
                if not inside(p):
                    out.append(cross(p, q))
                out.append(q)
            elif inside(p):
                out.append(cross(p, q))
        if not out:
            return []
    return out


def _area(poly):
    return 0.5 * abs(sum(poly[i][0] * poly[(i + 1) % len(poly)][1] - poly[(i + 1) % len(poly)][0] * poly[i][1]
                         for i in range(len(poly))))


def reference_overlap(S, L, theta, support_side, robot, grow=0.0):
    """Do the two feet, each grown by half the clearance (+ ``grow``), intersect? Built in the world."""
    hx = 0.5 * robot.foot_length + 0.5 * robot.foot_clearance + grow
    hy = 0.5 * robot.foot_width + 0.5 * robot.foot_clearance + grow
    support = (0.3, -0.7, 0.9)  # an arbitrary support pose in the world
    new = place_foot(support, support_side, S, L, theta)
    inter = _clip(_rect(*new, hx, hy), _rect(*support, hx, hy))
    return bool(inter) and _area(inter) > 0.0


def test_feet_overlap_against_polygon_clipping(robot):
    rng = np.random.default_rng(24)
    N = 3000
    S = rng.uniform(-0.15, 0.15, N)
    L = rng.uniform(0.0, 0.15, N)
    theta = rng.uniform(-1.6, 1.6, N)
    sides = rng.choice([LEFT, RIGHT], N)
    got = feet_overlap(S, L, theta, sides, robot)
    compared = hits = 0
    for i in range(N):
        lo = reference_overlap(S[i], L[i], theta[i], sides[i], robot, grow=-1e-7)
        hi = reference_overlap(S[i], L[i], theta[i], sides[i], robot, grow=+1e-7)
        if lo != hi:
            continue  # within 0.1 um of touching: either answer is right
        compared += 1
        hits += lo
        assert bool(got[i]) == lo, (S[i], L[i], theta[i], sides[i])
        assert bool(feet_overlap(float(S[i]), float(L[i]), float(theta[i]), int(sides[i]), robot)) == lo
    assert compared > 0.99 * N and 0.1 * N < hits < 0.9 * N


def test_feet_overlap_clearance_by_hand(robot):
    # side by side, yaw 0: they touch-with-clearance when L < foot width + clearance
    w, cl = robot.foot_width, robot.foot_clearance
    assert feet_overlap(0.0, w + cl - 1e-6, 0.0, RIGHT, robot)
    assert not feet_overlap(0.0, w + cl + 1e-6, 0.0, RIGHT, robot)
    assert not feet_overlap(0.0, w + cl + 1e-6, 0.0, LEFT, robot)
    # one foot length ahead, no side stride: same rule along x
    ln = robot.foot_length
    assert feet_overlap(ln + cl - 1e-6, 0.0, 0.0, LEFT, robot)
    assert not feet_overlap(ln + cl + 1e-6, 0.0, 0.0, LEFT, robot)


def test_kinematically_feasible(robot):
    nominal = robot.nominal_command
    for side in (LEFT, RIGHT):
        assert kinematically_feasible(nominal, side, robot)
        assert kinematically_feasible(np.array([robot.command_low[0], robot.command_high[1], 0.0,
                                                robot.command_low[3], robot.command_high[4]]), side, robot)
    # each field just outside its box
    low, high = robot.command_low, robot.command_high
    for k in range(5):
        if k == 2:
            continue  # theta: side-dependent, below
        for bad in (low[k] - 1e-3, high[k] + 1e-3):
            cmd = nominal.copy()
            cmd[k] = bad
            assert not kinematically_feasible(cmd, LEFT, robot).any(), (k, bad)
            assert not kinematically_feasible(cmd, RIGHT, robot).any(), (k, bad)
    # turns: away from the support foot up to turn_outer, towards it only to turn_inner
    out, inn = robot.turn_outer, robot.turn_inner
    between = 0.5 * (inn + out)
    left_swing_out = np.array([0.0, 0.1, +between, 0.6, 0.2])
    right_swing_out = np.array([0.0, 0.1, -between, 0.6, 0.2])
    assert kinematically_feasible(left_swing_out, RIGHT, robot)
    assert not kinematically_feasible(left_swing_out, LEFT, robot)  # same turn is inner for the right foot
    assert kinematically_feasible(right_swing_out, LEFT, robot)
    assert not kinematically_feasible(right_swing_out, RIGHT, robot)
    for side in (LEFT, RIGHT):
        assert not kinematically_feasible(np.array([0.0, 0.1, -side * (out + 1e-3), 0.6, 0.2]), side, robot)
    # inside the box and the turn limits but the feet overlap (turned toe/heel hits the support foot)
    overlapping = np.array([0.0, robot.command_low[1], out, 0.6, 0.2])
    assert feet_overlap(*overlapping[:3], RIGHT, robot)
    assert not kinematically_feasible(overlapping, RIGHT, robot)
    # batch with per-row sides, and NaN rejected
    batch = np.array([left_swing_out, left_swing_out, nominal, [np.nan, 0.08, 0.0, 0.6, 0.2]])
    got = kinematically_feasible(batch, np.array([RIGHT, LEFT, LEFT, RIGHT]), robot)
    assert got.tolist() == [True, False, True, False]


def test_kinematically_feasible_matches_independent_rules(robot):
    rng = np.random.default_rng(25)
    N = 2000
    low, high = robot.command_low, robot.command_high
    span = high - low
    cmds = rng.uniform(low - 0.05 * span, high + 0.05 * span, size=(N, 5))
    sides = rng.choice([LEFT, RIGHT], N)
    got = kinematically_feasible(cmds, sides, robot)
    n_ok = 0
    for i in range(N):
        S, L, th, tss, tds = cmds[i]
        swing = -sides[i]
        outward_turn = swing * th  # > 0: away from the support foot
        in_box = (low[0] <= S <= high[0] and low[1] <= L <= high[1]
                  and low[3] <= tss <= high[3] and low[4] <= tds <= high[4])
        in_turn = -robot.turn_inner <= outward_turn <= robot.turn_outer
        overlap = reference_overlap(S, L, th, sides[i], robot)
        want = in_box and in_turn and not overlap
        n_ok += want
        assert bool(got[i]) == want, (cmds[i], sides[i])
    assert 0.1 * N < n_ok < 0.9 * N


# ------------------------------------------------------------------ 5. nodes -> feet
def test_foot_from_node_sides():
    rng = np.random.default_rng(26)
    for _ in range(100):
        node = rng.uniform(-3, 3, 2)
        heading = rng.uniform(-7, 7)
        hw = rng.uniform(0.03, 0.06)
        h = np.array([math.cos(heading), math.sin(heading)])
        feet = {}
        for side in (LEFT, RIGHT):
            x, y, yaw = foot_from_node(node, heading, side, hw)
            d = np.array([x, y]) - node
            cross = h[0] * d[1] - h[1] * d[0]  # > 0: to the left of the heading
            assert np.sign(cross) == side
            assert np.hypot(*d) == pytest.approx(hw, abs=1e-12)
            assert abs(np.dot(h, d)) < 1e-12
            assert abs(angle_diff(yaw, heading)) < 1e-12
            feet[side] = (x, y, yaw)
        np.testing.assert_allclose(robot_centre(feet[LEFT], feet[RIGHT]), node, atol=1e-12)
        # the command from the right foot to the left foot of the same node: S=0, L=2 hw, theta=0
        np.testing.assert_allclose(command_between(feet[RIGHT], RIGHT, feet[LEFT]), (0.0, 2 * hw, 0.0), atol=1e-12)
    # by hand: heading +x, the left foot is at +y
    np.testing.assert_allclose(foot_from_node((0.0, 0.0), 0.0, LEFT, 0.04), (0.0, 0.04, 0.0), atol=1e-15)


# ------------------------------------------------------------------ 6. limits read from the config
def test_footstep_module_reads_no_literals():
    """Changing the robot config changes the limits (nothing hard-coded in footstep.py)."""
    r = load_robot({"turn_inner": 0.1, "turn_outer": 0.3, "foot_width": 0.05})
    assert turn_bounds(RIGHT, r) == pytest.approx((-0.1, 0.3))
    assert not footstep.feet_overlap(0.0, 0.055, 0.0, RIGHT, r)
    assert footstep.feet_overlap(0.0, 0.055, 0.0, RIGHT, load_robot())


def test_place_foot_scalar_is_place_foot_within_ulps():
    """The env's plain-float twin gives numpy's answer to a few ulps on any CPU (libm's cos/sin against numpy's,
    which call libm for float64 today but may take per-CPU SIMD kernels; the rest is the same IEEE arithmetic)."""
    rng = np.random.default_rng(11)
    for _ in range(5000):
        pose = (float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)), float(rng.uniform(-4, 4)))
        side = int(rng.choice([-1, 1]))
        S, L, theta = (float(v) for v in rng.uniform([-0.05, 0.06, -0.5], [0.12, 0.13, 0.5]))
        want = tuple(float(v) for v in footstep.place_foot(pose, side, S, L, theta))
        got = footstep.place_foot_scalar(pose, side, S, L, theta)
        np.testing.assert_allclose(got, want, rtol=4 * np.finfo(float).eps, atol=1e-14)  # |x| <= 5.2 m: ~4 ulp


def test_local_to_world_is_the_inverse_of_the_foot_frame():
    """A point given in a foot's frame, taken to the world and back by hand (rotation by -yaw), is itself."""
    rng = np.random.default_rng(0)
    poses = rng.uniform([-2, -2, -np.pi], [2, 2, np.pi], size=(50, 3))
    local = rng.uniform(-0.2, 0.2, size=(50, 2))
    world = footstep.local_to_world(poses.T, local)
    d = world - poses[:, :2]
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    assert np.allclose(np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1), local, atol=1e-12)
    one = footstep.local_to_world((1.0, 2.0, np.pi / 2), np.array([0.1, 0.0]))
    assert np.allclose(one, [1.0, 2.1])


# ------------------------------------------------------------------ 7. the swing's floor on T_SS
def test_swing_time_floor_is_the_min_jerk_closed_form():
    """A minimum-jerk swing over D = 2|S| in T: peak speed 15/8 D/T at the middle, peak acceleration 10/sqrt(3) D/T^2
    at u = (3 - sqrt 3)/6 (sampled here, not taken from the code); the floor is the T at which the tighter of the two
    limits is met with equality. With no limits (robot.yaml's .inf) there is no floor and no "swing" verdict."""
    r = load_robot({"swing_speed": 0.9, "swing_acceleration": 12.0})
    u = np.linspace(0.0, 1.0, 200_001)
    speed = np.max(30 * u ** 2 - 60 * u ** 3 + 30 * u ** 4)  # d/du (10u^3 - 15u^4 + 6u^5)
    accel = np.max(60 * u - 180 * u ** 2 + 120 * u ** 3)
    assert speed == pytest.approx(footstep.MIN_JERK_PEAK_SPEED, rel=1e-9)
    assert accel == pytest.approx(footstep.MIN_JERK_PEAK_ACCELERATION, rel=1e-9)
    for S in (0.0, 0.02, -0.04, 0.06, 0.1):
        D = 2 * abs(S)
        t = footstep.swing_time_floor(r, S, math)
        if not S:
            assert t == 0.0
        if S:  # at the floor one limit holds with equality and the other is not exceeded
            assert speed * D / t <= 0.9 * (1 + 1e-12) and accel * D / t ** 2 <= 12.0 * (1 + 1e-12)
            assert math.isclose(speed * D / t, 0.9, rel_tol=1e-9) or math.isclose(accel * D / t ** 2, 12.0, rel_tol=1e-9)
    batch = np.array([0.0, 0.02, -0.04, 0.06, 0.1])
    np.testing.assert_array_equal(footstep.swing_time_floor(r, batch),
                                  [footstep.swing_time_floor(r, float(S), math) for S in batch])
    # the verdicts: just below the floor falls as "swing" (after the box, before the turn limits), just above not
    t = footstep.swing_time_floor(r, 0.08, math)
    for side in (LEFT, RIGHT):
        assert footstep.kinematic_violation(r, 0.08, 0.1, 0.0, t - 1e-3, 0.2, side) == "swing"
        assert footstep.kinematic_violation(r, 0.08, 0.1, 0.0, t + 1e-3, 0.2, side) is None
        assert not kinematically_feasible(np.array([0.08, 0.1, 0.0, t - 1e-3, 0.2]), side, r)
        assert kinematically_feasible(np.array([0.08, 0.1, 0.0, t + 1e-3, 0.2]), side, r)
    assert footstep.kinematic_violation(r, 0.08, 0.1, 1.0, t - 1e-3, 0.2, LEFT) == "limits"
    base = load_robot()
    assert not base.swing_limited and footstep.swing_time_floor(base, 0.1, math) == 0.0
    assert footstep.kinematic_violation(base, 0.1, 0.1, 0.0, base.t_ss[0], 0.2, LEFT) is None
