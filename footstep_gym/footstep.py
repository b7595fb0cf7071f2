"""The footstep convention: command ``(S, L, theta)`` <-> foot poses (paper eq. 2-3, Fig. 5).

Poses are ``(x, y, yaw)`` in the world [m, m, rad]; a side is ``+1`` for the left foot
and ``-1`` for the right foot. The swing foot is always on the side opposite the
support foot, ``swing = -support``.

A command places the new (swing) foot relative to the support foot ``F``, in ``F``'s
frame (x forward, y to the left)::

        new foot (left swing)            y ^
           +---+  yaw = theta              |
           | o |                            +--> x
           +---+                      S: along F's x
             ^ L (outward, > 0)       L: along F's y, towards the swing side
           +---+                      theta: new yaw - F's yaw (counter-clockwise > 0)
           | o |  F (right support)
           +---+

so the new foot's centre is ``F + R(yaw_F) (S, swing * L)`` and its yaw ``yaw_F + theta``.
L > 0 always means "away from the support foot", whichever foot swings; theta is not
mirrored, so its limits depend on the side: turning the new foot away from the
support foot (``swing * theta > 0``) is the outer angle (up to ``turn_outer``),
turning it towards it the inner angle (down to ``-turn_inner``), paper Fig. 4.

:func:`command_between` is the exact inverse of :func:`place_foot` (eq. 2-3).
Functions accept scalars or numpy arrays (broadcast over a batch).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from footstep_gym.robot import Robot

LEFT = 1
RIGHT = -1
SIDE_NAMES = {LEFT: "left", RIGHT: "right"}


def wrap_angle(a: Any) -> Any:
    """Angle(s) wrapped to ``[-pi, pi)`` [rad]."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def place_foot(support_pose: Any, support_side: Any, S: Any, L: Any, theta: Any, xp: Any = np
               ) -> tuple[Any, Any, Any]:
    """World pose ``(x, y, yaw)`` of the foot that command ``(S, L, theta)`` places.

    ``support_pose`` is ``(x, y, yaw)`` (each scalar or array), ``support_side`` +1/-1; ``xp`` the array
    namespace (``numpy``, or ``jax.numpy`` for the batched backend).
    """
    x, y, yaw = support_pose
    swing = -support_side
    lat = swing * L
    c, s = xp.cos(yaw), xp.sin(yaw)
    return (x + c * S - s * lat, y + s * S + c * lat, wrap_angle(yaw + theta))


def place_foot_scalar(support_pose: tuple[float, float, float], support_side: int, S: float, L: float,
                      theta: float) -> tuple[float, float, float]:
    """:func:`place_foot` for one command in plain Python floats (the env's per-step path, where numpy's
    per-call cost on scalars dominated): the same operations, and ``math.cos``/``math.sin`` (libm), which
    agree with numpy's ``cos``/``sin`` to a few ulps on any CPU (bit for bit where numpy calls libm for float64,
    as numpy 2.x does; ``tests/test_footstep.py`` checks the ulps)."""
    x, y, yaw = support_pose
    lat = -support_side * L
    c, s = math.cos(yaw), math.sin(yaw)
    return (x + c * S - s * lat, y + s * S + c * lat, (yaw + theta + math.pi) % (2.0 * math.pi) - math.pi)


def local_to_world(pose: Any, local: np.ndarray) -> np.ndarray:
    """Points ``local`` ``(..., 2)`` [m] given in the frame of foot ``pose`` ``(x, y, yaw)`` (each scalar or
    array, broadcast against ``local``'s leading axes), in the world frame."""
    x, y, yaw = (np.asarray(v, dtype=float) for v in pose)
    c, s = np.cos(yaw), np.sin(yaw)
    lx, ly = local[..., 0], local[..., 1]
    return np.stack([x + c * lx - s * ly, y + s * lx + c * ly], axis=-1)


def command_between(support_pose: Any, support_side: Any, new_pose: Any) -> tuple[Any, Any, Any]:
    """``(S, L, theta)`` that moves the swing foot from ``support_pose`` to ``new_pose`` (eq. 2-3)."""
    x, y, yaw = support_pose
    nx, ny, nyaw = new_pose
    dx, dy = nx - x, ny - y
    c, s = np.cos(yaw), np.sin(yaw)
    S = c * dx + s * dy
    lat = -s * dx + c * dy
    return (S, -support_side * lat, wrap_angle(nyaw - yaw))


def turn_bounds(support_side: Any, robot: Robot, xp: Any = np) -> tuple[Any, Any]:
    """``(theta_min, theta_max)`` [rad] for the foot that swings opposite ``support_side`` (``xp``: the array
    namespace of a batch of sides)."""
    if isinstance(support_side, (int, np.integer)):  # one side (the planners' per-call case): no arrays
        return (-robot.turn_inner, robot.turn_outer) if support_side < 0 else (-robot.turn_outer, robot.turn_inner)
    swing = -xp.asarray(support_side)
    lo = xp.where(swing > 0, -robot.turn_inner, -robot.turn_outer)
    hi = xp.where(swing > 0, robot.turn_outer, robot.turn_inner)
    if lo.ndim == 0 and xp is np:
        return float(lo), float(hi)
    return lo, hi


def feet_overlap(S: Any, L: Any, theta: Any, support_side: Any, robot: Robot, xp: Any = np) -> Any:
    """True where the two foot rectangles (plus ``foot_clearance``) would overlap.

    Separating-axis test between the support foot (at the origin, yaw 0) and the new
    foot at ``(S, swing*L)`` with yaw ``theta``. Mirroring y maps a swing side of -1 to
    +1 with ``theta -> -theta``, so only ``swing * theta`` matters.
    """
    hx = 0.5 * (robot.foot_length + robot.foot_clearance)
    hy = 0.5 * (robot.foot_width + robot.foot_clearance)
    t = -support_side * theta
    c, s = xp.cos(t), xp.sin(t)
    ac, as_ = xp.abs(c), xp.abs(s)
    dx, dy = S, L
    # Axes of the support foot (x, y), then of the new foot (c, s), (-s, c).
    sep_x = xp.abs(dx) > hx + hx * ac + hy * as_
    sep_y = xp.abs(dy) > hy + hx * as_ + hy * ac
    sep_u = xp.abs(c * dx + s * dy) > hx * ac + hy * as_ + hx
    sep_v = xp.abs(-s * dx + c * dy) > hx * as_ + hy * ac + hy
    return ~(sep_x | sep_y | sep_u | sep_v)


#: Peak speed and peak acceleration of the minimum-jerk path s(u) = 10u^3 - 15u^4 + 6u^5 over a distance D in a
#: time T, in units of D / T and D / T^2: s'(1/2) = 15/8 and s''((3 - sqrt 3) / 6) = 10 / sqrt 3.
MIN_JERK_PEAK_SPEED = 15.0 / 8.0
MIN_JERK_PEAK_ACCELERATION = 10.0 / math.sqrt(3.0)


def swing_time_floor(robot: Robot, S: Any, xp: Any = np) -> Any:
    """The shortest T_SS [s] at front stride ``S`` [m] whose swing keeps to ``robot.swing_speed`` and
    ``robot.swing_acceleration``: the swing foot travels the steady gait's ``2|S|`` on a minimum-jerk path, so
    ``T_SS >= max(15/8 * 2|S| / swing_speed, sqrt(10/sqrt(3) * 2|S| / swing_acceleration))`` (0 with no limits;
    ``xp``: ``math``, ``numpy`` or ``jax.numpy``)."""
    travel = 2.0 * (abs(S) if xp is math else xp.abs(S))
    by_speed = MIN_JERK_PEAK_SPEED * travel / robot.swing_speed
    by_acceleration = xp.sqrt(MIN_JERK_PEAK_ACCELERATION * travel / robot.swing_acceleration)
    return max(by_speed, by_acceleration) if xp is math else xp.maximum(by_speed, by_acceleration)


#: The kinematic limits a command can fail, in the order :func:`kinematic_violation` checks them: outside the
#: command box, a T_SS too short for the swing to travel the stride (:func:`swing_time_floor`), outside the
#: swinging side's turn limits, the two soles (grown by ``foot_clearance``) overlapping.
KINEMATIC_VIOLATIONS = ("limits", "swing", "turn_limit", "overlap")


def kinematic_violation(robot: Robot, S: float, L: float, theta: float, t_ss: float, t_ds: float,
                        support_side: int) -> str | None:
    """The first of :data:`KINEMATIC_VIOLATIONS` one command fails (NaN: ``"limits"``), or None.

    :func:`kinematically_feasible`'s limits and tolerance for one command, in plain Python (the env's step
    and :func:`footstep_gym.lipm.check_step` call it one command at a time, where numpy's per-call cost counts).
    """
    eps = 1e-9
    turn = robot.turn_limit
    if not (S >= robot.stride_front[0] - eps and S <= robot.stride_front[1] + eps  # NaN fails here too
            and L >= robot.stride_side[0] - eps and L <= robot.stride_side[1] + eps
            and theta >= -turn - eps and theta <= turn + eps
            and t_ss >= robot.t_ss[0] - eps and t_ss <= robot.t_ss[1] + eps
            and t_ds >= robot.t_ds[0] - eps and t_ds <= robot.t_ds[1] + eps):
        return "limits"
    if robot.swing_limited and t_ss < swing_time_floor(robot, S, math) - eps:
        return "swing"
    lo, hi = turn_bounds(support_side, robot)
    if not (theta >= lo - eps and theta <= hi + eps):
        return "turn_limit"
    # feet_overlap, one command: separating-axis test of the two foot rectangles.
    hx = 0.5 * (robot.foot_length + robot.foot_clearance)
    hy = 0.5 * (robot.foot_width + robot.foot_clearance)
    t = -support_side * theta
    c, s = math.cos(t), math.sin(t)
    ac, as_ = abs(c), abs(s)
    if (abs(S) > hx + hx * ac + hy * as_
            or abs(L) > hy + hx * as_ + hy * ac
            or abs(c * S + s * L) > hx * ac + hy * as_ + hx
            or abs(-s * S + c * L) > hx * as_ + hy * ac + hy):
        return None
    return "overlap"


def kinematically_feasible(commands: Any, support_side: Any, robot: Robot, xp: Any = np) -> Any:
    """Batch verdict of the kinematic limits for commands ``(N, 5)`` ``[S, L, theta, T_SS, T_DS]``.

    Inside the action box, T_SS at least the swing's floor (:func:`swing_time_floor`), inside the side-dependent
    turn limits, and no foot overlap. With ``xp`` another
    array namespace (``jax.numpy``) the commands keep their float dtype and every limit is rounded to it, so a
    float32 command at a float32-rounded limit is inside.
    """
    if xp is np:
        cmd = np.asarray(commands, dtype=float)
        low, high = robot.command_low, robot.command_high
    else:
        cmd = xp.asarray(commands)
        low, high = (xp.asarray(b, dtype=cmd.dtype) for b in (robot.command_low, robot.command_high))
    eps = 1e-9
    ok = xp.all((cmd >= low - eps) & (cmd <= high + eps), axis=-1)
    if robot.swing_limited:
        ok &= cmd[..., 3] >= swing_time_floor(robot, cmd[..., 0], xp) - eps
    lo, hi = turn_bounds(support_side, robot, xp)
    theta = cmd[..., 2]
    if xp is not np:
        lo, hi = xp.asarray(lo, dtype=cmd.dtype), xp.asarray(hi, dtype=cmd.dtype)
    ok &= (theta >= lo - eps) & (theta <= hi + eps)
    ok &= ~feet_overlap(cmd[..., 0], cmd[..., 1], theta, support_side, robot, xp)
    return ok


def robot_centre(foot_a: Any, foot_b: Any) -> tuple[float, float]:
    """Midpoint ``(x, y)`` of two foot poses [m]: the robot centre the planner's nodes stand for.

    The definition written out (docs/model.md §2, "Nodes and feet"), the test oracle of :func:`foot_from_node`
    (``tests/test_footstep.py``); the env and the snapshot compute the same midpoint inline
    (:attr:`footstep_gym.sensing.Snapshot.centre`).
    """
    return (0.5 * (foot_a[0] + foot_b[0]), 0.5 * (foot_a[1] + foot_b[1]))


def foot_from_node(node_xy: Any, heading: Any, side: Any, half_width: float, xp: Any = np) -> tuple[Any, Any, Any]:
    """Pose of the ``side`` foot for robot centre ``node_xy`` facing ``heading`` (paper Fig. 5).

    The foot centre lies ``half_width`` [m] from the node, perpendicular to the heading.
    """
    x, y = node_xy
    return (x - side * half_width * xp.sin(heading), y + side * half_width * xp.cos(heading), wrap_angle(heading))
