"""The planners' kernels compiled (numba): :class:`NumbaKernels`, the same arithmetic as :mod:`.numpy_kernels`.

The loops run over points and shapes once, stopping at the first shape that blocks a point:

* :func:`points_free` — :meth:`NumbaKernels.points_free` (and :meth:`~NumbaKernels.body_free`): points
  against thick segments moving at constant velocity and angular velocity, or accelerating as sensed
  for a while (docs/model.md §5);
* :func:`walks_survival` — :meth:`NumbaKernels.walks_survival`: the body points of whole walks (each
  at its own period) generated and checked in one loop, each walk stopping at its first blocked point;
* :func:`pursue_lanes` — :meth:`NumbaKernels.pursue_lanes`: the pure pursuit of the rollouts' lanes;
* :func:`extend_tree` and :func:`insert_walks` — a batch of the modified RRT and its seed walks, on the
  tree's arrays.

They read the shapes from a :class:`~footstep_gym.kernels.ShapeTable`, so they take a body check that
has one (``body.shapes``: a :class:`footstep_gym.planners.prediction.BodyModel`) and refuse any other.
The kernels call libm (``math.cos``, ``math.atan2``, ...) and never fuse a multiply-add; numpy picks SIMD
kernels per CPU at run time, which round some results an ulp otherwise (``arctan2``, ``exp`` with
AVX-512; complex products fused with AVX2), so the two implementations agree bit for bit on some CPUs
and to a few ulps on others (``tests/test_kernels.py``).

Compiled on first use and cached on disk (``cache=True``): the first call of a fresh install
pays the compilation, later processes load them from the cache.
"""

from __future__ import annotations

import math

from typing import Sequence

import numba
import numpy as np

from footstep_gym.kernels import (
    AB2,
    AB_X,
    AB_Y,
    ACC_T,
    ACC_X,
    ACC_Y,
    ANGLE,
    A_X,
    A_Y,
    COS0,
    OMEGA,
    POS_X,
    POS_Y,
    SIN0,
    VEL_X,
    VEL_Y,
    BodyCheck,
    Lanes,
    ShapeTable,
    TreeArrays,
    TreeStep,
    WalkStart,
    step_fractions,
)


@numba.njit(cache=True, fastmath=False, inline="always")
def _pose(t: float, q: int, shapes: np.ndarray) -> tuple[float, float, float, float]:
    """Shape ``q``'s centre line at time ``t`` [s]: its start ``(ox, oy)`` [m] and its direction ``(bx, by)`` [m], the
    body-frame segment ``a``..``a + ab`` rotated by ``angle + omega t`` and carried by ``pos + vel t`` (plus
    ``acc tau (t - tau / 2)``, ``tau = min(t, ACC_T)``, for a shape with a sensed acceleration)."""
    sh = shapes[q]
    if sh[OMEGA] == 0.0:
        c, sn = sh[COS0], sh[SIN0]
    else:
        ang = sh[ANGLE] + sh[OMEGA] * t
        c, sn = math.cos(ang), math.sin(ang)
    px = sh[POS_X] + sh[VEL_X] * t
    py = sh[POS_Y] + sh[VEL_Y] * t
    if sh[ACC_T] > 0.0:
        tau = min(t, sh[ACC_T])
        k = tau * (t - 0.5 * tau)
        px = px + sh[ACC_X] * k
        py = py + sh[ACC_Y] * k
    ox = px + (c * sh[A_X] - sn * sh[A_Y])
    oy = py + (sn * sh[A_X] + c * sh[A_Y])
    return ox, oy, c * sh[AB_X] - sn * sh[AB_Y], sn * sh[AB_X] + c * sh[AB_Y]


@numba.njit(cache=True, fastmath=False, inline="always")
def _gap2_to(x: float, y: float, ox: float, oy: float, bx: float, by: float, ab2: float) -> float:
    """Squared distance [m^2] from ``(x, y)`` to the segment from ``(ox, oy)`` along ``(bx, by)`` (``ab2``: its
    squared length)."""
    apx, apy = x - ox, y - oy
    u = 0.0
    if ab2 > 0:
        u = min(max((apx * bx + apy * by) / ab2, 0.0), 1.0)
    dx, dy = apx - u * bx, apy - u * by
    return dx * dx + dy * dy


@numba.njit(cache=True, fastmath=False, inline="always")
def _gap2(x: float, y: float, t: float, q: int, shapes: np.ndarray) -> float:
    """Squared distance [m^2] from ``(x, y)`` to shape ``q``'s centre line at time ``t`` [s] (:func:`_pose`)."""
    ox, oy, bx, by = _pose(t, q, shapes)
    return _gap2_to(x, y, ox, oy, bx, by, shapes[q, AB2])


@numba.njit(cache=True, fastmath=False, inline="always")
def _point_free(x: float, y: float, t: float, shapes: np.ndarray, need2: np.ndarray, horizon: np.ndarray) -> bool:
    """Whether ``(x, y)`` [m] at time ``t`` [s] is at least ``sqrt(need2[s])`` from every shape ``s`` whose
    horizon ``horizon[s]`` [s] reaches ``t`` (stopping at the first that blocks it)."""
    for s in range(shapes.shape[0]):
        if t <= horizon[s] and _gap2(x, y, t, s, shapes) < need2[s]:
            return False
    return True


@numba.njit(cache=True, fastmath=False)
def points_free(px: np.ndarray, py: np.ndarray, t: np.ndarray, shapes: np.ndarray, need2: np.ndarray,
                horizon: np.ndarray, out: np.ndarray) -> None:
    """Whether each point ``(px[i], py[i])`` [m] at time ``t[i]`` [s] clears every shape, into ``out`` (bool).

    Shape ``s`` (a row of the shape table) blocks a point closer than ``sqrt(need2[s])`` to its centre
    line, for times up to ``horizon[s]``.
    """
    for i in range(px.size):
        out[i] = _point_free(px[i], py[i], t[i], shapes, need2, horizon)


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
                   shapes: np.ndarray, radius: np.ndarray, horizon: np.ndarray, blocked_at: np.ndarray) -> None:
    """:meth:`NumbaKernels.walks_survival`, one walk after the other: into
    ``blocked_at[r]`` [s] the time of walk ``r``'s first blocked point (``inf`` if it stays free).

    Walk ``r`` has its own period ``T = period[r]`` [s] and its first ``n_nodes[r]`` nodes (so that
    one call checks walks at several periods). The body of step ``d`` moves from ``bodies[d]`` to
    ``bodies[d + 1]`` during ``[d T, (d + 1) T]``, sampled at the fractions ``samples``, shifted by
    ``shift[r]`` [m] towards the step's support foot, and needs ``needed[r]`` [m] of clearance; once
    a walk's body has reached the goal region it is not checked further (the env ends the episode
    when the robot centre, the midpoint of the feet, is within the goal tolerance).
    """
    n_roll = nodes.shape[0]
    n_shapes = shapes.shape[0]
    n_s = samples.size
    # The shapes' poses at the k-th sampled instant of step d (index d * n_s + k), computed once for all the
    # walks of one period (consecutive rows) as far as any of them gets.
    poses = np.empty((nodes.shape[1] * n_s, n_shapes, 4))
    posed_period, n_posed = np.nan, 0
    for r in range(n_roll):
        blocked_at[r] = np.inf
        ax, ay = body_x, body_y
        side = side0
        walk_period, walk_shift, walk_needed = period[r], shift[r], needed[r]
        if walk_period != posed_period:
            posed_period, n_posed = walk_period, 0
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
            for k in range(n_s):
                s = samples[k]
                x = ax + s * (bx - ax) + walk_shift * nrm_x
                y = ay + s * (by - ay) + walk_shift * nrm_y
                ti = t0 + s * (t1 - t0)
                i = d * n_s + k
                if i == n_posed:  # instants are visited in order from 0: the next one not posed yet
                    for q in range(n_shapes):
                        poses[i, q, 0], poses[i, q, 1], poses[i, q, 2], poses[i, q, 3] = _pose(ti, q, shapes)
                    n_posed += 1
                for q in range(n_shapes):
                    if ti > horizon[q]:
                        continue
                    lim = radius[q] + walk_needed
                    if _gap2_to(x, y, poses[i, q, 0], poses[i, q, 1], poses[i, q, 2], poses[i, q, 3],
                                shapes[q, AB2]) < lim * lim:
                        blocked_at[r] = ti
                        break
                if blocked_at[r] < np.inf:
                    break
            if blocked_at[r] < np.inf:
                break
            side = -side


@numba.njit(cache=True, fastmath=False, inline="always")
def _in_goal(x: float, y: float, goal_x: float, goal_y: float, goal_radius: float) -> bool:
    """Whether the body at ``(x, y)`` [m] is in the goal region (the arithmetic of ``np.linalg.norm``)."""
    dx, dy = x - goal_x, y - goal_y
    return math.sqrt(dx * dx + dy * dy) <= goal_radius


@numba.njit(cache=True, fastmath=False)
def extend_tree(xy: np.ndarray, heading: np.ndarray, side: np.ndarray, parent: np.ndarray, cost: np.ndarray,
                depth: np.ndarray, body: np.ndarray, n: int, samples: np.ndarray, redraw: np.ndarray,
                goal_x: float, goal_y: float, goal_radius: float, step_size: float, has_first: bool,
                first_lo: float, first_hi: float, left_lo: float, left_hi: float, right_lo: float, right_hi: float,
                period: float, time_aware: bool, fractions: np.ndarray, shift: float, shapes: np.ndarray,
                need2: np.ndarray, horizon: np.ndarray, goal_nodes: np.ndarray,
                check_node: bool = False) -> tuple[int, int]:
    """One batch of the modified RRT (Algorithm 2, steps 5-16) on the tree's arrays, in place.

    Each sample ``samples[i]`` [m] extends from its nearest node among the first ``n`` (the tree as
    it was at the start of the batch); a turn outside the limits of the parent's support side
    (``left_*`` for a left support, ``right_*`` for a right one) is replaced by
    ``lo + (hi - lo) * redraw[i]``; the distance is clamped to ``step_size`` [m] (and into
    ``first_lo``..``first_hi`` from the root if ``has_first``). A parent whose body is already in
    the goal region (the root excepted) is not extended. The body segment from the parent's body
    to the midpoint of parent and new node is checked at ``fractions`` of the step during
    ``[depth T, (depth + 1) T]`` (at ``T`` if not ``time_aware``), shifted by ``shift`` [m] towards
    the parent's foot, against the shapes (blocked closer than ``sqrt(need2[s])``, up to
    ``horizon[s]``). With ``check_node`` (``prediction.check: node``, the paper's check) the new node
    itself is checked instead, at the start and at the end of its step (``depth T`` and
    ``(depth + 1) T``; ``0`` and ``T`` if not ``time_aware``). Free extensions are appended from index
    ``n`` on; those whose body lands in the goal region are written to ``goal_nodes``. Returns the
    new node count and how many goal nodes were written: the same arithmetic, in the same order, as
    :meth:`.numpy_kernels.NumpyKernels.extend_tree`.
    """
    n0 = n
    n_goal = 0
    for i in range(samples.shape[0]):
        sx, sy = samples[i, 0], samples[i, 1]
        best, best_d2 = 0, np.inf
        for j in range(n0):
            dx, dy = sx - xy[j, 0], sy - xy[j, 1]
            d2 = dx * dx + dy * dy
            if d2 < best_d2:
                best, best_d2 = j, d2
        p = best
        px, py, ph, pside = xy[p, 0], xy[p, 1], heading[p], side[p]
        vx, vy = sx - px, sy - py
        delta = (math.atan2(vy, vx) - ph + math.pi) % (2.0 * math.pi) - math.pi
        lo, hi = (left_lo, left_hi) if pside > 0 else (right_lo, right_hi)
        if delta < lo or delta > hi:
            delta = lo + (hi - lo) * redraw[i]
        length = min(math.sqrt(vx * vx + vy * vy), step_size)
        if has_first and p == 0:
            length = min(max(length, first_lo), first_hi)
        h = (ph + delta + math.pi) % (2.0 * math.pi) - math.pi
        nx = px + length * math.cos(h)
        ny = py + length * math.sin(h)
        bx0, by0 = body[p, 0], body[p, 1]
        if p != 0 and _in_goal(bx0, by0, goal_x, goal_y, goal_radius):
            continue  # its path already ended in the goal region
        bx1, by1 = 0.5 * (px + nx), 0.5 * (py + ny)
        nrm_x, nrm_y = -float(pside) * math.sin(ph), float(pside) * math.cos(ph)
        t0 = depth[p] * period
        t1 = t0 + period
        free = True
        if check_node:
            x, y = nx + shift * nrm_x, ny + shift * nrm_y
            free = (_point_free(x, y, t0 if time_aware else 0.0, shapes, need2, horizon)
                    and _point_free(x, y, t1 if time_aware else period, shapes, need2, horizon))
        else:
            for k in range(fractions.size):
                s = fractions[k]
                x = bx0 + s * (bx1 - bx0) + shift * nrm_x
                y = by0 + s * (by1 - by0) + shift * nrm_y
                if not _point_free(x, y, t0 + s * (t1 - t0) if time_aware else period, shapes, need2, horizon):
                    free = False
                    break
        if not free:
            continue
        xy[n, 0], xy[n, 1], heading[n], parent[n] = nx, ny, h, p
        side[n], cost[n], depth[n] = -pside, cost[p] + length, depth[p] + 1
        body[n, 0], body[n, 1] = bx1, by1
        if _in_goal(bx1, by1, goal_x, goal_y, goal_radius):
            goal_nodes[n_goal] = n
            n_goal += 1
        n += 1
    return n, n_goal


@numba.njit(cache=True, fastmath=False)
def insert_walks(xy: np.ndarray, heading: np.ndarray, side: np.ndarray, parent: np.ndarray, cost: np.ndarray,
                 depth: np.ndarray, body: np.ndarray, n: int, walk_nodes: np.ndarray, walk_first: np.ndarray,
                 goal_x: float, goal_y: float, goal_radius: float, goal_nodes: np.ndarray) -> tuple[int, int]:
    """:meth:`.numpy_kernels.NumpyKernels.insert_walks` on the tree's arrays, in place: walk ``w`` (rows
    ``walk_first[w]`` .. ``walk_first[w + 1] - 1`` of ``walk_nodes`` [m], its first row the root) becomes a chain
    of nodes from the root, each the parent of the next; a step of zero length keeps the heading of the
    walk's last step that moved (the root's if none did). Appended from index ``n`` on; nodes whose
    body (midpoint of node and parent) is in the goal region go to ``goal_nodes``. Returns the new node count
    and how many goal nodes were written.
    """
    n_goal = 0
    for w in range(walk_first.size - 1):
        a, b = walk_first[w], walk_first[w + 1]
        if b - a < 2:
            continue
        h_last = heading[0]
        total = 0.0
        for r in range(a + 1, b):
            vx = walk_nodes[r, 0] - walk_nodes[r - 1, 0]
            vy = walk_nodes[r, 1] - walk_nodes[r - 1, 1]
            length = math.hypot(vx, vy)
            if length > 1e-9:
                h_last = math.atan2(vy, vx)
            total += length
            k = r - a - 1  # the walk's step index
            px, py = (xy[0, 0], xy[0, 1]) if k == 0 else (walk_nodes[r - 1, 0], walk_nodes[r - 1, 1])
            xy[n, 0], xy[n, 1], heading[n] = walk_nodes[r, 0], walk_nodes[r, 1], h_last
            parent[n] = 0 if k == 0 else n - 1
            side[n] = -side[0] if k % 2 == 0 else side[0]
            cost[n], depth[n] = total, k + 1
            body[n, 0], body[n, 1] = 0.5 * (px + walk_nodes[r, 0]), 0.5 * (py + walk_nodes[r, 1])
            if _in_goal(body[n, 0], body[n, 1], goal_x, goal_y, goal_radius):
                goal_nodes[n_goal] = n
                n_goal += 1
            n += 1
    return n, n_goal


# ---------------------------------------------------------------------- the interface
def shape_table_of(body: BodyCheck) -> ShapeTable:
    """The shape table ``body`` checks against (``body.shapes``), or ``TypeError``: the compiled loops read it."""
    shapes = getattr(body, "shapes", None)
    if not isinstance(shapes, ShapeTable):
        raise TypeError(f"the compiled kernels (kernels.compiled: true) need a prediction.BodyModel, whose shape "
                        f"table they read; got {type(body).__name__}: plan with kernels.compiled false (the numpy "
                        f"kernels) to check walks with any BodyCheck")
    return shapes


class NumbaKernels:
    """:class:`~footstep_gym.kernels.Kernels` as compiled loops (this module's functions) over a body check's
    :class:`~footstep_gym.kernels.ShapeTable`."""

    name = "numba"

    def check_body(self, body: BodyCheck) -> None:
        shape_table_of(body)

    def points_free(self, shapes: ShapeTable, points: np.ndarray, times: np.ndarray,
                    safe_distance: float | np.ndarray) -> np.ndarray:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        times = np.broadcast_to(np.asarray(times, dtype=float), pts.shape[:1])
        out = np.empty(len(pts), dtype=bool)
        points_free(np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]), np.ascontiguousarray(times),
                    shapes.rows, (shapes.radius + safe_distance) ** 2, shapes.horizon, out)
        return out

    def body_free(self, body: BodyCheck, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray,
                  period: float) -> np.ndarray:
        shapes = shape_table_of(body)
        centres, needed = body.centres(points, support_normals, period)
        return self.points_free(shapes, centres, times, needed)

    def walks_survival(self, body: BodyCheck, start: WalkStart, walks: Sequence[tuple[np.ndarray, np.ndarray]],
                       periods: Sequence[float], edge_samples: int, goal: np.ndarray,
                       goal_radius: float) -> list[np.ndarray]:
        """All groups in one compiled call (a period search asks about many periods)."""
        shapes = shape_table_of(body)
        counts = [len(n) for n, _ in walks]
        widths = [n.shape[1] for n, _ in walks]
        rows, depth = sum(counts), max(widths)
        first = np.cumsum([0, *counts])
        if min(widths) == depth:  # the usual case: one call each
            nodes, headings = np.concatenate([n for n, _ in walks]), np.concatenate([h for _, h in walks])
        else:
            nodes = np.empty((rows, depth, 2))  # a row's nodes beyond its own n_nodes are never read
            headings = np.empty((rows, depth))
            for (n, h), a, b in zip(walks, first[:-1], first[1:]):
                nodes[a:b, : n.shape[1]], headings[a:b, : n.shape[1]] = n, h
        n_nodes = np.repeat(np.asarray(widths, dtype=np.int64), counts)
        period = np.repeat(np.asarray(periods, dtype=float), counts)
        shift, needed = np.repeat(np.array([body.shift_and_clearance(T) for T in periods]).reshape(-1, 2), counts,
                                  axis=0).T
        blocked_at = np.empty(rows)
        walks_survival(float(start.previous_node[0]), float(start.previous_node[1]), float(start.body[0]),
                       float(start.body[1]), nodes, headings, n_nodes, int(start.side), period,
                       step_fractions(edge_samples), float(goal[0]), float(goal[1]), float(goal_radius),
                       np.ascontiguousarray(shift), np.ascontiguousarray(needed), shapes.rows, shapes.radius,
                       shapes.horizon, blocked_at)
        return [blocked_at[a:b] for a, b in zip(first[:-1], first[1:])]

    def pursue_lanes(self, lanes: Lanes, window: tuple[float, float] | None,
                     depth: int) -> tuple[np.ndarray, np.ndarray]:
        (l_lo, l_hi), (r_lo, r_hi) = lanes.left, lanes.right
        w_lo, w_hi = window if window is not None else (0.0, 0.0)
        return pursue_lanes(float(lanes.node[0]), float(lanes.node[1]), float(lanes.axis[0]), float(lanes.axis[1]),
                            float(lanes.goal[0]), float(lanes.goal[1]), float(lanes.length), float(lanes.lookahead),
                            float(lanes.goal_radius), float(lanes.heading), int(lanes.side), lanes.offsets,
                            lanes.strides, lanes.waits, float(l_lo), float(l_hi), float(r_lo), float(r_hi),
                            window is not None, float(w_lo), float(w_hi), int(depth))

    def extend_tree(self, tree: TreeArrays, step: TreeStep, body: BodyCheck, samples: np.ndarray,
                    redraw: np.ndarray) -> list[int]:
        shapes = shape_table_of(body)
        shift, needed = body.shift_and_clearance(step.period)
        (l_lo, l_hi), (r_lo, r_hi) = step.left, step.right
        first_lo, first_hi = step.first_stride if step.first_stride is not None else (0.0, 0.0)
        goal_nodes = np.empty(len(samples), dtype=np.int64)
        tree.n, n_goal = extend_tree(
            tree.xy, tree.heading, tree.side, tree.parent, tree.cost, tree.depth, tree.body, tree.n, samples, redraw,
            float(step.goal[0]), float(step.goal[1]), float(step.goal_radius), float(step.step_size),
            step.first_stride is not None, float(first_lo), float(first_hi), float(l_lo), float(l_hi), float(r_lo),
            float(r_hi), float(step.period), bool(step.time_aware), step_fractions(step.edge_samples), float(shift),
            shapes.rows, (shapes.radius + needed) ** 2, shapes.horizon, goal_nodes, bool(step.check_node))
        return goal_nodes[:n_goal].tolist()

    def insert_walks(self, tree: TreeArrays, walks: Sequence[np.ndarray], goal: np.ndarray,
                     goal_radius: float) -> list[int]:
        if not walks:
            return []
        walk_nodes = np.concatenate(walks).reshape(-1, 2)
        walk_first = np.cumsum([0, *(len(nodes) for nodes in walks)])
        goal_nodes = np.empty(len(walk_nodes), dtype=np.int64)
        tree.n, n_goal = insert_walks(tree.xy, tree.heading, tree.side, tree.parent, tree.cost, tree.depth, tree.body,
                                      tree.n, walk_nodes, walk_first, float(goal[0]), float(goal[1]),
                                      float(goal_radius), goal_nodes)
        return goal_nodes[:n_goal].tolist()


#: The compiled kernels (:func:`footstep_gym.kernels.select_kernels` with ``compiled=True``).
NUMBA = NumbaKernels()
