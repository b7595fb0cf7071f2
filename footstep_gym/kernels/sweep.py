"""The collision sweep's inner loop, compiled (numba): the checks of one footstep (see :mod:`footstep_gym.world`).

Numba's compilation of the sweep's arithmetic written once in :mod:`footstep_gym.collision` (a shape's
distance with the operations of Chipmunk's point queries, the kinematic bodies' motion between checks as
pymunk's ``Space.step`` does it, the spacing of the checks) and of the CoM's path
(:func:`footstep_gym.lipm.com_world`), with ``xp`` = :mod:`footstep_gym.scalars` as on Python numbers.
Compiled without ``fastmath`` (no reassociation, no fused multiply-adds), so every number is the one
CPython and Chipmunk compute, bit for bit, on any CPU: the same IEEE operations, and the same libm
(``exp``, ``sin``, ``cos``) in one process; numpy's SIMD kernels, chosen per CPU, do not enter.
``tests/test_world.py`` checks the whole sweep against pymunk's.

The kernel does not decide what pymunk alone knows: which shape a contact is (ties), and the
first check of a sweep against shapes pymunk cached elsewhere. It stops and returns
:data:`ASK` there; the caller asks pymunk and calls it again with that answer.

Its test oracle is pymunk itself (:meth:`footstep_gym.world.World.sweep_pymunk`, which a world made
with ``compiled=False`` runs at every check). Compiled on first use and cached on disk
(``cache=True``): compiled once per install (and again after an edit of the modules it compiles), then
loaded from the cache by each new process.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numba
import numba.extending
import numpy as np

from footstep_gym import collision, lipm, scalars

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


def _shape_distance_py(j: int, qx: float, qy: float, rows: np.ndarray, states: np.ndarray) -> float:
    """Shape ``j``'s distance from ``(qx, qy)``: Chipmunk's point query (:mod:`footstep_gym.collision`)."""
    kind = rows[j, 0]
    if kind == STATIC_SEGMENT:
        return collision.segment_distance(scalars, qx, qy, rows[j, 2], rows[j, 3], rows[j, 4], rows[j, 5], rows[j, 6],
                                          rows[j, 7], rows[j, 8], rows[j, 9])
    mi = int(rows[j, 1])
    if kind == MOVING_CIRCLE:
        return collision.circle_distance(scalars, qx, qy, states[mi, 0], states[mi, 1], rows[j, 6])
    ax, ay, bx, by, dx, dy, l2 = collision.body_segment(scalars, states[mi, 0], states[mi, 1], states[mi, 2],
                                                        rows[j, 2], rows[j, 3], rows[j, 4], rows[j, 5])
    return collision.segment_distance(scalars, qx, qy, ax, ay, bx, by, dx, dy, l2, rows[j, 6])


def _com_path(prm: np.ndarray) -> lipm.ComPath:
    """The CoM path whose constants are ``prm[:P_DURATION]`` (``WorldPath.sweep_params``)."""
    return lipm.ComPath(prm[P_W], prm[P_T_SS], prm[P_END], complex(prm[P_P], prm[P_P + 1]),
                        complex(prm[P_PD], prm[P_PD + 1]), complex(prm[P_PDW], prm[P_PDW + 1]),
                        complex(prm[P_A_XI], prm[P_A_XI + 1]), complex(prm[P_A_ETA], prm[P_A_ETA + 1]),
                        complex(prm[P_B_XI], prm[P_B_XI + 1]), complex(prm[P_B_ETA], prm[P_B_ETA + 1]),
                        complex(prm[P_ORIGIN], prm[P_ORIGIN + 1]), complex(prm[P_ROT], prm[P_ROT + 1]))


def _path_py(t: float, prm: np.ndarray) -> tuple[float, float]:
    """The robot's centre at ``t``: :func:`footstep_gym.lipm.com_world` of :func:`_com_path`."""
    return lipm.com_world(scalars, _com_path(prm), t)


def _sweep(prm: np.ndarray, rows: np.ndarray, states: np.ndarray, keys: np.ndarray, candidates: np.ndarray,
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
    path = _com_path(prm)
    checks, last, given, n_cand = ival[0], ival[1], ival[4], ival[5]
    t, nearest, world_time = fval[0], fval[1], fval[2]
    n_movers = states.shape[0]
    if ival[6] > 0:  # first call of a sweep: the carried bounds, less what moved since; the candidates
        jump = 0.0
        if ival[6] == 2:  # bounds carried from the point (P_END_X, P_END_Y)
            x0, y0 = lipm.com_world(scalars, path, 0.0)
            jump = scalars.hypot(x0 - prm[P_END_X], y0 - prm[P_END_Y]) + slack
        ival[6] = 0
        reach = collision.horizon(radius, speed, duration, 0.0) + slack
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
        qx, qy = lipm.com_world(scalars, path, t)
        horizon = collision.horizon(radius, speed, duration, t)
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
                d = _shape_distance_py(last, qx, qy, rows, states)
                keys[last] = d + st_now
                if d < best:
                    best = d
                    hit = last
                cut = st_now + slack
                for i in range(n_cand):
                    j = candidates[i]
                    if keys[j] - cut < best and j != last:
                        d = _shape_distance_py(j, qx, qy, rows, states)
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
        verdict, nearest, dt, t_next = collision.after_check(scalars, t, dist, hit >= 0, nearest, duration, radius,
                                                             speed, fine)
        if verdict == collision.CONTACT:
            status = COLLIDED
            break
        if verdict == collision.END:
            break
        if dt > 0:  # Space.step(dt) for kinematic bodies
            for m in range(n_movers):
                states[m, 0] = collision.moved(states[m, 0], states[m, 3], dt)
                states[m, 1] = collision.moved(states[m, 1], states[m, 4], dt)
                states[m, 2] = collision.moved(states[m, 2], states[m, 5], dt)
            world_time += dt
            ival[3] = 1
        t = t_next
    ival[0], ival[1], ival[2], ival[4] = checks, last, hit, given
    fval[0], fval[1], fval[2], fval[3], fval[4], fval[5] = t, nearest, world_time, dist, qx, qy
    if status == DONE:  # what the next sweep starts from: each shape's bound at the end
        cut = speed * t + slack
        for j in range(keys.size):
            keys[j] -= cut
    return status


# The shared functions and the loop, compilable inside the compiled sweep (they stay plain Python outside it).
for _fn in (scalars.where, scalars.minimum, scalars.maximum, collision.segment_frame, collision.segment_distance,
            collision.circle_distance, collision.body_segment, collision.moved, collision.check_spacing,
            collision.horizon, collision.after_check, lipm.com_state, lipm.com_world, _shape_distance_py,
            _com_path, _path_py, _sweep):
    numba.extending.register_jitable(_fn)

#: Compiled alone, for the tests (not cached: :data:`sweep` carries its own compiled copies).
_shape_distance = numba.njit(fastmath=False)(_shape_distance_py)
_path = numba.njit(fastmath=False)(_path_py)

#: numba's disk cache is keyed by this file and the compiled function's own code, not by the modules it calls; the
#: sources of those, hashed into the compiled function's closure (which the key includes), recompile it when they
#: change.
_SOURCES_STAMP = hashlib.sha256(b"".join(Path(m.__file__).read_bytes() for m in (collision, lipm, scalars))).hexdigest()


def _compile(stamp: str):
    """:func:`_sweep` compiled and cached on disk; ``stamp``: :data:`_SOURCES_STAMP` (read only into numba's key)."""

    def sweep(prm: np.ndarray, rows: np.ndarray, states: np.ndarray, keys: np.ndarray, candidates: np.ndarray,
              ival: np.ndarray, fval: np.ndarray) -> int:
        stamp  # noqa: B018
        return _sweep(prm, rows, states, keys, candidates, ival, fval)

    sweep.__doc__ = _sweep.__doc__
    return numba.njit(cache=True, fastmath=False)(sweep)


#: The compiled :func:`_sweep`.
sweep = _compile(_SOURCES_STAMP)
