"""The collision sweep's inner loop, compiled (numba): the checks of one footstep (see :mod:`footstep_gym.world`).

Between two checks the loop moves the kinematic bodies as pymunk's ``Space.step`` does
(``cpBodyUpdatePosition``: ``p += (v + 0) dt``, ``angle += (w + 0) dt``) and at each check
computes the distance from the robot's centre to every shape that could be the nearest,
with the operations of Chipmunk's point queries (``cpSegmentShapePointQuery`` /
``cpCircleShapePointQuery`` on the geometry ``cpBody``'s transform gives the shape). The
robot's centre comes from the LIPM's closed forms with the operations of
:meth:`footstep_gym.lipm.StepTrajectory.world_path`. Compiled without ``fastmath`` (no
reassociation, no fused multiply-adds), so every number is the one CPython and Chipmunk
compute, bit for bit, on any CPU: the same IEEE operations, and the same libm (``exp``, ``sin``,
``cos``) in one process; numpy's SIMD kernels, chosen per CPU, do not enter.
``tests/test_world.py`` checks the whole sweep against pymunk's.

The kernel does not decide what pymunk alone knows: which shape a contact is (ties), and the
first check of a sweep against shapes pymunk cached elsewhere. It stops and returns
:data:`ASK` there; the caller asks pymunk and calls it again with that answer.

Its test oracle is pymunk itself (:meth:`footstep_gym.world.World.sweep_pymunk`, which a world made
with ``compiled=False`` runs at every check). Compiled on first use and cached on disk
(``cache=True``): compiled once per install, then loaded from the cache by each new process.
"""

from __future__ import annotations

import math

import numba
import numpy as np

DONE = 0  # the sweep reached its end without contact
ASK = 1  # the check at the returned time needs pymunk's answer (a contact, or the first check on stale shapes)
COLLIDED = 2  # the check at the returned time (with the answer given) is a contact

# Row kinds of the shape table.
STATIC_SEGMENT = 0  # columns 2..9: ax, ay, bx, by, ax - bx, ay - by, |a - b|^2, r (world frame)
MOVING_SEGMENT = 1  # columns 2..6: the segment's local ax, ay, bx, by, r
MOVING_CIRCLE = 2  # column 6: r (the circle sits on its body's origin)

# Indices of the float parameters (one array, one argument).
P_W, P_T_SS, P_END = 0, 1, 2
P_P, P_PD, P_PDW, P_A_XI, P_A_ETA, P_B_XI, P_B_ETA, P_ORIGIN, P_ROT = 3, 5, 7, 9, 11, 13, 15, 17, 19  # complex: 2 each
P_DURATION, P_SPEED, P_RADIUS, P_FINE, P_SLACK, P_END_X, P_END_Y = 21, 22, 23, 24, 25, 26, 27
N_PARAMS = 28


@numba.njit(cache=True, fastmath=False)
def _shape_distance(j: int, qx: float, qy: float, rows: np.ndarray, states: np.ndarray) -> float:
    """Shape ``j``'s distance from ``(qx, qy)``: Chipmunk's point query, same operations in the same order."""
    kind = rows[j, 0]
    if kind == STATIC_SEGMENT:
        ax, ay, bx, by = rows[j, 2], rows[j, 3], rows[j, 4], rows[j, 5]
        dx, dy, l2, r = rows[j, 6], rows[j, 7], rows[j, 8], rows[j, 9]
    else:
        mi = int(rows[j, 1])
        px, py = states[mi, 0], states[mi, 1]
        if kind == MOVING_CIRCLE:
            ex = qx - px
            ey = qy - py
            return math.sqrt(ex * ex + ey * ey) - rows[j, 6]
        a = states[mi, 2]
        c, s = math.cos(a), math.sin(a)  # cpvforangle
        ns = -s
        lax, lay, lbx, lby, r = rows[j, 2], rows[j, 3], rows[j, 4], rows[j, 5], rows[j, 6]
        # cpTransformPoint(t, v) = (t.a v.x + t.c v.y + t.tx, t.b v.x + t.d v.y + t.ty), t = (c, s, -s, c, p).
        ax = c * lax + ns * lay + px
        ay = s * lax + c * lay + py
        bx = c * lbx + ns * lby + px
        by = s * lbx + c * lby + py
        dx = ax - bx
        dy = ay - by
        l2 = dx * dx + dy * dy
    # cpClosetPointOnSegment (cpfclamp01 of a NaN is 1), cpvlength.
    if l2 != 0.0:
        f = (dx * (qx - bx) + dy * (qy - by)) / l2
        if not f < 1.0:
            f = 1.0
        if 0.0 > f:
            f = 0.0
    else:
        f = 1.0
    ex = qx - (bx + dx * f)
    ey = qy - (by + dy * f)
    return math.sqrt(ex * ex + ey * ey) - r


@numba.njit(cache=True, fastmath=False)
def _path(t: float, prm: np.ndarray) -> tuple[float, float]:
    """The robot's centre at ``t``: :meth:`StepTrajectory.world_path`'s operations."""
    w, t_ss, end = prm[P_W], prm[P_T_SS], prm[P_END]
    nw = -w
    p = complex(prm[P_P], prm[P_P + 1])
    pd = complex(prm[P_PD], prm[P_PD + 1])
    pdw = complex(prm[P_PDW], prm[P_PDW + 1])
    if t <= t_ss:
        xi = p + complex(prm[P_A_XI], prm[P_A_XI + 1]) * complex(math.exp(w * t), 0.0)
        eta = p + complex(prm[P_A_ETA], prm[P_A_ETA + 1]) * complex(math.exp(nw * t), 0.0)
    else:
        tau = (end if end < t else t) - t_ss
        pt = p + pd * complex(tau, 0.0)
        xi = pt + pdw + complex(prm[P_B_XI], prm[P_B_XI + 1]) * complex(math.exp(w * tau), 0.0)
        eta = pt - pdw + complex(prm[P_B_ETA], prm[P_B_ETA + 1]) * complex(math.exp(nw * tau), 0.0)
    z = complex(prm[P_ORIGIN], prm[P_ORIGIN + 1]) + complex(0.5, 0.0) * (xi + eta) * complex(prm[P_ROT], prm[P_ROT + 1])
    return z.real, z.imag


@numba.njit(cache=True, fastmath=False)
def sweep(prm: np.ndarray, rows: np.ndarray, states: np.ndarray, keys: np.ndarray, candidates: np.ndarray,
          ival: np.ndarray, fval: np.ndarray) -> int:
    """Run the checks from ``fval[0]`` (t) on; returns :data:`DONE`, :data:`ASK` or :data:`COLLIDED`.

    ``states`` (movers, 7): x, y, angle, vx + 0, vy + 0, w + 0 (moved in place) and how far the
    body may have moved since the carried bounds were taken. ``keys[j] - speed * t`` bounds
    shape ``j``'s distance at ``t`` from below (less ``slack``), updated in place;
    ``candidates`` (its first n_candidates entries) are the shapes that can matter.

    ``ival``: [checks, last, hit, advanced, given, n_candidates, prepare]; ``fval``: [t,
    nearest, world time, dist, point x, point y].

    * ``prepare`` (a sweep's first call): 2 when the keys are the last sweep's bounds at its end,
      at the point ``prm[P_END_X], prm[P_END_Y]`` (they lose how far the robot moved since and
      each body's ``states[:, 6]``), 1 when they are all -inf; then the candidates are chosen.
    * ``given``: 2 stops at the first check for pymunk's answer; 1 makes the check at ``t`` take
      ``(dist, hit)`` from ``fval[3]`` / ``ival[2]``.

    On return ``t``, the point and the check's ``dist`` / ``hit`` say where it stopped; on
    :data:`DONE` the keys are bounds at the sweep's end.
    """
    duration, speed, radius, fine, slack = prm[P_DURATION], prm[P_SPEED], prm[P_RADIUS], prm[P_FINE], prm[P_SLACK]
    checks, last, given, n_cand = ival[0], ival[1], ival[4], ival[5]
    t, nearest, world_time = fval[0], fval[1], fval[2]
    n_movers = states.shape[0]
    if ival[6] > 0:  # first call of a sweep: the carried bounds, less what moved since; the candidates
        jump = 0.0
        if ival[6] == 2:  # bounds carried from the point (P_END_X, P_END_Y)
            x0, y0 = _path(0.0, prm)
            jump = math.hypot(x0 - prm[P_END_X], y0 - prm[P_END_Y]) + slack
        ival[6] = 0
        reach = radius + speed * duration + 1e-9 + slack
        n_cand = 0
        for j in range(rows.shape[0]):
            if rows[j, 0] != STATIC_SEGMENT:
                keys[j] -= jump + states[int(rows[j, 1]), 6]
            elif jump != 0.0:
                keys[j] -= jump
            # A shape whose bound starts at or beyond the first horizon stays beyond every later one (both fall
            # at ``speed``): it is never the answer in this sweep, and its bound stays valid.
            if keys[j] < reach:
                candidates[n_cand] = j
                n_cand += 1
        ival[5] = n_cand
        found = False
        for i in range(n_cand):
            found = found or candidates[i] == last
        if not found:
            last = candidates[0] if n_cand > 0 else -1
    status = DONE
    dist = 0.0
    hit = -1
    while True:
        qx, qy = _path(t, prm)
        horizon = radius + speed * (duration - t) + 1e-9
        if given == 2:  # the caller asks pymunk first
            status = ASK
            break
        if given == 1:
            given = 0
            dist = fval[3]
            hit = ival[2]
        else:
            st_now = speed * t
            best = horizon
            hit = -1
            if last >= 0:
                d = _shape_distance(last, qx, qy, rows, states)
                keys[last] = d + st_now
                if d < best:
                    best = d
                    hit = last
                cut = st_now + slack
                for i in range(n_cand):
                    j = candidates[i]
                    if keys[j] - cut < best and j != last:
                        d = _shape_distance(j, qx, qy, rows, states)
                        keys[j] = d + st_now
                        if d < best:
                            best = d
                            hit = j
            dist = best if hit >= 0 else horizon
            if hit >= 0 and best < radius:
                status = ASK
                break
        if hit >= 0:
            last = hit
        checks += 1
        if hit >= 0:
            if dist < nearest:
                nearest = dist
            if dist < radius:
                status = COLLIDED
                break
        if t >= duration:
            break
        remaining = duration - t
        if speed <= 0:
            dt = remaining
        else:  # min(remaining, max(fine, (dist - radius) / speed))
            dt = (dist - radius) / speed
            if not dt > fine:
                dt = fine
            if not dt < remaining:
                dt = remaining
        if dt > 0:  # Space.step(dt) for kinematic bodies (cpBodyUpdatePosition)
            for m in range(n_movers):
                states[m, 0] = states[m, 0] + states[m, 3] * dt
                states[m, 1] = states[m, 1] + states[m, 4] * dt
                states[m, 2] = states[m, 2] + states[m, 5] * dt
            world_time += dt
            ival[3] = 1
        t = duration if dt >= remaining else t + dt
    ival[0], ival[1], ival[2], ival[4] = checks, last, hit, given
    fval[0], fval[1], fval[2], fval[3], fval[4], fval[5] = t, nearest, world_time, dist, qx, qy
    if status == DONE:  # what the next sweep starts from: each shape's bound at the end
        cut = speed * t + slack
        for j in range(keys.size):
            keys[j] -= cut
    return status
