"""Compiled inner loops of the planners (numba): the same arithmetic as the numpy code they replace.

The planners ask tens of thousands of small questions per footstep ("is this body point,
at this time, clear of every predicted shape?"); in numpy each question costs a dozen
array temporaries and Python-level calls. These kernels loop over points and shapes
once, stopping at the first shape that blocks a point:

* :func:`points_free` — :meth:`.prediction.ObstaclePredictor.free`: points against thick
  segments moving at constant velocity and angular velocity (docs/model.md §5);
* :func:`walks_survival` — :func:`.walks.walks_survival` with a :class:`.prediction.BodyModel`:
  the body points of whole walks (each at its own period) generated and checked in one loop,
  each walk stopping at its first blocked point;
* :func:`pursue_lanes` — the pure pursuit of :class:`.rollouts.GoalRollouts`.

Compiled on first use and cached on disk (``cache=True``): the first call of a fresh
install costs the compilation (a few seconds for all three), later processes load them
in milliseconds.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, fastmath=False, inline="always")
def _gap2(x: float, y: float, t: float, q: int, pos_x: np.ndarray, pos_y: np.ndarray, vel_x: np.ndarray,
          vel_y: np.ndarray, angle: np.ndarray, omega: np.ndarray, a_x: np.ndarray, a_y: np.ndarray,
          ab_x: np.ndarray, ab_y: np.ndarray, ab2: np.ndarray) -> float:
    """Squared distance [m^2] from ``(x, y)`` to shape ``q``'s centre line at time ``t`` [s]: the body-frame
    segment ``a``..``a + ab`` rotated by ``angle + omega t`` and carried by ``pos + vel t``."""
    ang = angle[q] + omega[q] * t
    c, sn = math.cos(ang), math.sin(ang)
    ox = pos_x[q] + vel_x[q] * t + (c * a_x[q] - sn * a_y[q])
    oy = pos_y[q] + vel_y[q] * t + (sn * a_x[q] + c * a_y[q])
    apx, apy = x - ox, y - oy
    bx = c * ab_x[q] - sn * ab_y[q]
    by = sn * ab_x[q] + c * ab_y[q]
    u = 0.0
    if ab2[q] > 0:
        u = min(max((apx * bx + apy * by) / ab2[q], 0.0), 1.0)
    dx, dy = apx - u * bx, apy - u * by
    return dx * dx + dy * dy


@numba.njit(cache=True, fastmath=False)
def points_free(px: np.ndarray, py: np.ndarray, t: np.ndarray, pos_x: np.ndarray, pos_y: np.ndarray,
                vel_x: np.ndarray, vel_y: np.ndarray, angle: np.ndarray, omega: np.ndarray, a_x: np.ndarray,
                a_y: np.ndarray, ab_x: np.ndarray, ab_y: np.ndarray, ab2: np.ndarray, need2: np.ndarray,
                horizon: np.ndarray, out: np.ndarray) -> None:
    """Whether each point ``(px[i], py[i])`` [m] at time ``t[i]`` [s] clears every shape, into ``out`` (bool).

    Shape ``s`` (body-frame segment ``a``..``a + ab``, rotated by ``angle + omega t`` and carried by
    ``pos + vel t``) blocks a point closer than ``sqrt(need2[s])`` to its centre line, for times
    up to ``horizon[s]``.
    """
    n = px.size
    n_shapes = pos_x.size
    for i in range(n):
        x, y, ti = px[i], py[i], t[i]
        ok = True
        for s in range(n_shapes):
            if ti > horizon[s]:
                continue
            if _gap2(x, y, ti, s, pos_x, pos_y, vel_x, vel_y, angle, omega, a_x, a_y, ab_x, ab_y, ab2) < need2[s]:
                ok = False
                break
        out[i] = ok


@numba.njit(cache=True, fastmath=False)
def pursue_lanes(node_x: float, node_y: float, axis_x: float, axis_y: float, goal_x: float, goal_y: float,
                 length: float, lookahead: float, goal_radius: float, heading0: float, side0: int,
                 offsets: np.ndarray, strides: np.ndarray, waits: np.ndarray, left_lo: float, left_hi: float,
                 right_lo: float, right_hi: float, has_window: bool, window_lo: float, window_hi: float,
                 depth: int) -> tuple[np.ndarray, np.ndarray]:
    """Pure pursuit of each rollout's lane for ``depth`` steps: nodes ``(R, depth + 1, 2)`` [m], headings [rad].

    Rollout ``r`` aims at the point ``lookahead`` [m] ahead on the line from the start node
    along ``axis`` offset sideways by ``offsets[r]`` (the offset tapering to zero over the
    last ``lookahead`` before the goal), turns at most the support side's limits, steps in
    place for ``waits[r]`` steps, then strides ``strides[r]`` (the first step clipped into the
    window if ``has_window``), never past the goal, and stands still (no stride, no turn) once its
    body, the midpoint of its last two nodes, is within ``goal_radius``: the episode is over there.
    Side ``+1`` is left; the limits ``(lo, hi)`` are those of the foot swinging from that support.
    """
    n_roll = offsets.size
    nodes = np.empty((n_roll, depth + 1, 2))
    headings = np.empty((n_roll, depth + 1))
    for r in range(n_roll):
        lane_x = offsets[r] * -axis_y
        lane_y = offsets[r] * axis_x
        x, y, h = node_x, node_y, heading0
        nodes[r, 0, 0], nodes[r, 0, 1], headings[r, 0] = x, y, h
        side = side0
        arrived = False
        for d in range(1, depth + 1):
            if arrived:
                nodes[r, d, 0], nodes[r, d, 1], headings[r, d] = x, y, h
                continue
            ahead = (x - node_x) * axis_x + (y - node_y) * axis_y + lookahead
            taper = min(max((length - ahead) / lookahead, 0.0), 1.0)
            along = min(ahead, length)
            aim_x = node_x + along * axis_x + taper * lane_x
            aim_y = node_y + along * axis_y + taper * lane_y
            rx, ry = aim_x - x, aim_y - y
            c, sn = math.cos(h), math.sin(h)
            turn = math.atan2(ry * c - rx * sn, rx * c + ry * sn)
            lo, hi = (left_lo, left_hi) if side > 0 else (right_lo, right_hi)
            h = h + min(max(turn, lo), hi)
            stride = 0.0 if d <= waits[r] else strides[r]
            if d == 1 and has_window:
                stride = min(max(stride, window_lo), window_hi)
            dist = math.hypot(goal_x - x, goal_y - y)
            stride = min(stride, dist)
            x_new = x + stride * math.cos(h)
            y_new = y + stride * math.sin(h)
            arrived = math.hypot(0.5 * (x + x_new) - goal_x, 0.5 * (y + y_new) - goal_y) <= goal_radius
            x, y = x_new, y_new
            nodes[r, d, 0], nodes[r, d, 1], headings[r, d] = x, y, h
            side = -side
    return nodes, headings


@numba.njit(cache=True, fastmath=False)
def walks_survival(prev_x: float, prev_y: float, body_x: float, body_y: float, nodes: np.ndarray,
                   headings: np.ndarray, n_nodes: np.ndarray, side0: int, period: np.ndarray, samples: np.ndarray,
                   goal_x: float, goal_y: float, goal_radius: float, shift: np.ndarray, needed: np.ndarray,
                   pos_x: np.ndarray, pos_y: np.ndarray, vel_x: np.ndarray, vel_y: np.ndarray, angle: np.ndarray,
                   omega: np.ndarray, a_x: np.ndarray, a_y: np.ndarray, ab_x: np.ndarray, ab_y: np.ndarray,
                   ab2: np.ndarray, radius: np.ndarray, horizon: np.ndarray, blocked_at: np.ndarray) -> None:
    """:func:`.walks.walks_survival` for a :class:`.prediction.BodyModel`, one walk after the other: into
    ``blocked_at[r]`` [s] the time of walk ``r``'s first blocked point (``inf`` if it stays free).

    Walk ``r`` has its own period ``T = period[r]`` [s] and its first ``n_nodes[r]`` nodes (so that
    one call checks walks at several periods). The body of step ``d`` moves from ``bodies[d]`` to
    ``bodies[d + 1]`` during ``[d T, (d + 1) T]``, sampled at the fractions ``samples``, shifted by
    ``shift[r]`` [m] towards the step's support foot, and needs ``needed[r]`` [m] of clearance; once
    a walk's body has reached the goal region it is not checked further (the env ends the episode
    when the robot centre, the midpoint of the feet, is within the goal tolerance).
    """
    n_roll = nodes.shape[0]
    n_shapes = pos_x.size
    for r in range(n_roll):
        blocked_at[r] = np.inf
        ax, ay = body_x, body_y
        side = side0
        walk_period, walk_shift, walk_needed = period[r], shift[r], needed[r]
        for d in range(n_nodes[r] - 1):
            px_prev = prev_x if d == 0 else nodes[r, d - 1, 0]
            py_prev = prev_y if d == 0 else nodes[r, d - 1, 1]
            if d > 0:
                ax = 0.5 * (px_prev + nodes[r, d, 0])
                ay = 0.5 * (py_prev + nodes[r, d, 1])
                if math.hypot(ax - goal_x, ay - goal_y) <= goal_radius:
                    break  # the body reached the goal at the end of step d - 1: the episode is over
            bx = 0.5 * (nodes[r, d, 0] + nodes[r, d + 1, 0])
            by = 0.5 * (nodes[r, d, 1] + nodes[r, d + 1, 1])
            h = headings[r, d]
            nrm_x = -side * math.sin(h)
            nrm_y = side * math.cos(h)
            t0 = d * walk_period
            t1 = (d + 1) * walk_period
            for k in range(samples.size):
                s = samples[k]
                x = ax + s * (bx - ax) + walk_shift * nrm_x
                y = ay + s * (by - ay) + walk_shift * nrm_y
                ti = t0 + s * (t1 - t0)
                for q in range(n_shapes):
                    if ti > horizon[q]:
                        continue
                    lim = radius[q] + walk_needed
                    if _gap2(x, y, ti, q, pos_x, pos_y, vel_x, vel_y, angle, omega, a_x, a_y, ab_x, ab_y,
                             ab2) < lim * lim:
                        blocked_at[r] = ti
                        break
                if blocked_at[r] < np.inf:
                    break
            if blocked_at[r] < np.inf:
                break
            side = -side
