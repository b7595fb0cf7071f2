"""The env's per-step safety figures: ``info["clearance"]`` and ``info["zmp_margin"]``.

Checked against independent references: the clearance against the distance from the body
circle to the obstacle computed here by hand; the ZMP margin against the ZMP offset worked out
here from the LIPM by numerical integration (scipy), never from footstep_gym/lipm.py, and the
stable rectangle of robot.yaml read directly.

What the ZMP offset is (docs/model.md §3.2): the pattern generator holds the ZMP at the support
foot's centre + p through single support, then slides it to the new foot's centre q through double
support; it picks the one free p that brings the step's end state closest, in
``a_w |dc|^2 + b_w |dv / omega|^2``, to the command's steady gait (the start state that repeats when
the command is repeated forever: with the feet alternating, the fixed point of the two-step map).
The margin is p's distance from the stable rectangle's nearest edge (|x| <= 0.5 scale length,
|y| <= 0.5 scale width), negative outside.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
import yaml
from scipy.integrate import solve_ivp

from footstep_gym.config import config_dir

NOMINAL = np.array([0.0, 0.08, 0.0, 0.6, 0.2], dtype=np.float32)
SIDES = {"left": 1, "right": -1}


# ------------------------------------------------------------------ independent LIPM reference
def _robot_yaml() -> dict:
    with open(config_dir() / "robot.yaml", encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def _lipm_step_end(start, p, command, side, omega):
    """End state ``[cx, cy, vx, vy]`` of one step by scipy's integration of ``c'' = omega^2 (c - zmp(t))``.

    ``start``: the CoM state relative to the support foot, in its frame; ``p``: the single-support ZMP
    there; ``side``: +1 left support, -1 right. The ZMP stays at ``p`` for T_SS, then slides linearly to the
    new foot's centre ``q = (S, -side L)`` over T_DS. The end state is returned relative to the new foot,
    in its frame (turned by theta): the next step's start state.
    """
    S, L, theta, t_ss, t_ds = command
    p, q = np.asarray(p, dtype=float), np.array([S, -side * L])

    def rhs(t, y):
        zmp = p if t <= t_ss else p + (q - p) * (t - t_ss) / t_ds
        return [y[2], y[3], omega ** 2 * (y[0] - zmp[0]), omega ** 2 * (y[1] - zmp[1])]

    y = np.asarray(start, dtype=float)
    for span in ((0.0, t_ss), (t_ss, t_ss + t_ds)):  # one solve per phase: the ZMP is smooth within each
        y = solve_ivp(rhs, span, y, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    c, s = math.cos(theta), math.sin(theta)
    turn = np.array([[c, s], [-s, c]])
    return np.concatenate([turn @ (y[:2] - q), turn @ y[2:]])


def _affine(f, n):
    """``(A, b)`` with ``f(x) = A x + b`` for an affine ``f`` of ``n`` variables (the LIPM is linear)."""
    b = f(np.zeros(n))
    return np.column_stack([f(e) - b for e in np.eye(n)]), b


def _generator_zmp(start, command, side, raw):
    """The generator's p, the end state's affine dependence ``(G, e0)`` on p, from the ODE alone."""
    omega = math.sqrt(raw["gravity"] / raw["com_height"])
    # Steady gait: the start state of the next step (other side supports) that the two steps
    # "next, then this one again" bring back; their map is affine, its fixed point a linear solve.
    A, b = _affine(lambda s: _lipm_step_end(_lipm_step_end(s, (0, 0), command, -side, omega),
                                            (0, 0), command, side, omega), 4)
    target = np.linalg.solve(np.eye(4) - A, b)
    G, e0 = _affine(lambda p: _lipm_step_end(start, p, command, side, omega), 2)
    wa, wb = raw["generator_weight_position"], raw["generator_weight_velocity"]
    w = np.sqrt([wa, wa, wb / omega ** 2, wb / omega ** 2])
    p, *_ = np.linalg.lstsq(w[:, None] * G, w * (target - e0), rcond=None)
    return p, G, e0


def _local_state(info):
    """The CoM ``[cx, cy, vx, vy]`` of an info relative to its support foot (``foot_pose``), in that foot's frame."""
    x, y, yaw = info["foot_pose"]
    c, s = math.cos(yaw), math.sin(yaw)
    turn = np.array([[c, s], [-s, c]])
    return np.concatenate([turn @ (np.array(info["com"]) - (x, y)), turn @ np.array(info["com_vel"])])


def _distance_to_rectangle_edge(p, hx, hy):
    """Euclidean distance from ``p`` to the boundary of the rectangle ``|x| <= hx, |y| <= hy`` (its four edges)."""
    corners = np.array([(hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy)])
    best = math.inf
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        u = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
        best = min(best, float(np.linalg.norm(p - (a + u * (b - a)))))
    return best


def test_zmp_margin_is_the_distance_to_the_stable_regions_edge():
    """Steps from the reset state (stepping in place: p = 0 on paper), a turning step from left support
    after it, then a cut of the period to 0.1 s that is a fall: the reported offset is the generator's p
    re-derived from the ODE, it is the ZMP the CoM really moved under, and the margin is its distance from
    the edge of robot.yaml's stable rectangle."""
    raw = _robot_yaml()
    hx = 0.5 * raw["zmp_region_scale"] * raw["foot_length"]  # 26 mm
    hy = 0.5 * raw["zmp_region_scale"] * raw["foot_width"]  # 16.5 mm
    env = gym.make("FootstepCrossing-v0", crossing_x=5.0)
    _, info = env.reset(seed=0)
    for n, command in enumerate((NOMINAL, [0.06, 0.08, 0.1, 0.4, 0.15], [0.06, 0.08, 0.0, 0.1, 0.1])):
        before = info
        side = SIDES[before["support_foot"]]
        start = _local_state(before)
        *_, terminated, _, info = env.step(np.asarray(command, dtype=np.float32))
        assert info["clipped"] is False
        np.testing.assert_allclose(info["command"], command, rtol=0, atol=1e-7)  # the float32 command applied
        p, G, e0 = _generator_zmp(start, info["command"], side, raw)
        assert info["zmp_offset"] == pytest.approx(tuple(p), abs=1e-9)
        assert info["zmp_margin"] == pytest.approx(min(hx - abs(p[0]), hy - abs(p[1])), abs=1e-9)
        if n == 0:
            # By hand: the episode starts in the steady gait of stepping in place at the nominal period
            # (docs/model.md §3.2), so the first nominal step needs p = 0 and the margin is the half width.
            assert np.hypot(*p) < 1e-9
            assert info["zmp_margin"] == pytest.approx(hy, abs=1e-9)
        inside = abs(p[0]) <= hx and abs(p[1]) <= hy
        assert info["feasible"] == inside  # all three commands are within the kinematic limits
        if inside:
            # The margin is the Euclidean distance to the rectangle's nearest edge...
            assert info["zmp_margin"] == pytest.approx(_distance_to_rectangle_edge(p, hx, hy), abs=1e-9)
            # ... of the ZMP the CoM really moved under: recovered from the start and end states the env
            # reports (the end state is affine in p), it is the same p, with nothing left over.
            end = _local_state(info)
            p_moved, *_ = np.linalg.lstsq(G, end - e0, rcond=None)
            assert p_moved == pytest.approx(p, abs=1e-9)
            assert np.abs(G @ p_moved + e0 - end).max() < 1e-9
        else:
            # Outside, the margin is minus the larger overshoot along the foot's axes: never farther out
            # than the rectangle really is.
            assert 0.0 < -info["zmp_margin"] <= _distance_to_rectangle_edge(p, hx, hy) + 1e-12
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
