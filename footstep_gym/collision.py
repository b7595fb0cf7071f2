"""The collision sweep's arithmetic, written once with an array namespace ``xp`` (docs/model.md §4.1).

A footstep's sweep moves the robot's circle along the CoM path (:func:`footstep_gym.lipm.com_world`)
and the kinematic obstacles on their velocities, and checks, at instants spaced by conservative
advancement, the distance from the robot's centre to the nearest obstacle surface. What happens at one
instant is here, as pure functions of scalars or arrays:

* a shape's distance from a point, with the operations of Chipmunk's point queries
  (:func:`segment_distance`, :func:`circle_distance`; a segment on a moving body placed with
  Chipmunk's transform by :func:`body_segment`), so that the compiled sweep equals pymunk bit for bit;
* a kinematic body's motion between checks (:func:`moved`: pymunk's ``cpBodyUpdatePosition``) and the
  bound of its speed (:func:`body_speed`);
* the spacing of the checks (:func:`check_spacing`, :func:`horizon`) and what a check decides
  (:func:`after_check`: contact, end, or the interval to the next check).

Three loops run them: :meth:`footstep_gym.world.World.sweep_pymunk` on Python numbers
(``xp`` = :mod:`footstep_gym.scalars`) with pymunk's own queries and ``Space.step`` (the oracle),
:func:`footstep_gym.kernels.sweep.sweep` compiled by numba (the same ``xp``), and
:func:`footstep_gym.jax.shapes.sweep` under ``jax.lax.while_loop`` (``xp`` = ``jax.numpy``).
Why the loops stay three, and the tests that hold them equal: docs/model.md §4.1.
"""

from __future__ import annotations

from typing import Any

#: [m] added to the sweep's horizon: a shape farther than ``radius + speed * (duration - t)`` at ``t``
#: cannot be reached in the step.
HORIZON_SLACK = 1e-9

#: What a check decides (:func:`after_check`).
GO, END, CONTACT = 0, 1, 2


def segment_frame(ax: Any, ay: Any, bx: Any, by: Any) -> tuple[Any, Any, Any]:
    """``(dx, dy, l2)``: a segment's ``a - b`` [m] and its squared length [m^2] (what a point query reads)."""
    dx = ax - bx
    dy = ay - by
    return dx, dy, dx * dx + dy * dy


def segment_distance(xp: Any, qx: Any, qy: Any, ax: Any, ay: Any, bx: Any, by: Any, dx: Any, dy: Any, l2: Any,
                     r: Any) -> Any:
    """Distance [m] from the point ``(qx, qy)`` to the surface of the thick segment ``a``-``b`` (half thickness
    ``r``; ``dx, dy, l2`` from :func:`segment_frame`): Chipmunk's ``cpSegmentShapePointQuery``
    (``cpClosetPointOnSegment``, where the clamp of a NaN is 1, and ``cpvlength``); negative inside."""
    nonzero = l2 != 0.0
    f = (dx * (qx - bx) + dy * (qy - by)) / xp.where(nonzero, l2, 1.0)
    f = xp.where(nonzero, f, 1.0)
    f = xp.where(f < 1.0, f, 1.0)
    f = xp.where(0.0 > f, 0.0, f)
    ex = qx - (bx + dx * f)
    ey = qy - (by + dy * f)
    return xp.sqrt(ex * ex + ey * ey) - r


def circle_distance(xp: Any, qx: Any, qy: Any, cx: Any, cy: Any, r: Any) -> Any:
    """Distance [m] from ``(qx, qy)`` to the surface of the circle of radius ``r`` at ``(cx, cy)``:
    Chipmunk's ``cpCircleShapePointQuery``."""
    ex = qx - cx
    ey = qy - cy
    return xp.sqrt(ex * ex + ey * ey) - r


def body_segment(xp: Any, px: Any, py: Any, angle: Any, lax: Any, lay: Any, lbx: Any, lby: Any) -> tuple[Any, ...]:
    """``(ax, ay, bx, by, dx, dy, l2)``: the world endpoints [m] of a segment ``(lax, lay)``-``(lbx, lby)`` of a
    body at ``(px, py)`` turned by ``angle`` [rad] (Chipmunk's ``cpTransformPoint`` with the body's transform
    ``(c, s, -s, c, p)``), and its :func:`segment_frame`."""
    c, s = xp.cos(angle), xp.sin(angle)
    ns = -s
    ax = c * lax + ns * lay + px
    ay = s * lax + c * lay + py
    bx = c * lbx + ns * lby + px
    by = s * lbx + c * lby + py
    dx, dy, l2 = segment_frame(ax, ay, bx, by)
    return ax, ay, bx, by, dx, dy, l2


def moved(x: Any, v: Any, dt: Any) -> Any:
    """A kinematic body's coordinate ``x`` (position [m] or angle [rad]) ``dt`` [s] later at the rate ``v``:
    pymunk's ``cpBodyUpdatePosition`` (``x += (v + bias) dt``, the bias velocity 0 for a kinematic body:
    ``v`` is ``v + 0``)."""
    return x + v * dt


def shape_reach(xp: Any, ax: Any, ay: Any, bx: Any, by: Any, r: Any) -> Any:
    """[m] The farthest a thick segment's surface (``a``-``b`` in its body's frame, half thickness ``r``; a circle on
    the origin: ``a = b = 0``) is from its body's origin."""
    return xp.maximum(xp.hypot(ax, ay), xp.hypot(bx, by)) + r


def body_speed(xp: Any, vx: Any, vy: Any, w: Any, reach: Any) -> Any:
    """[m/s] The largest speed of any point of a body's shape: its origin's speed plus its turn rate ``w``
    [rad/s] times ``reach`` [m], the farthest the shape's surface is from the origin."""
    return xp.hypot(vx, vy) + xp.abs(w) * reach


def check_spacing(xp: Any, duration: Any, speed: Any, max_check_interval: Any, motion_fraction: float,
                  radius: float, max_checks: int) -> tuple[Any, Any]:
    """``(fine, capped)``: the finest check interval [s] of a sweep of ``duration`` [s] where things move up to
    ``speed`` [m/s] (at most ``max_check_interval`` and the time to move ``motion_fraction`` of the robot's
    ``radius`` [m]), and whether ``max_checks`` widened it to ``duration / max_checks``."""
    fast = speed > 0
    fine = xp.where(fast, xp.minimum(max_check_interval, motion_fraction * radius / xp.where(fast, speed, 1.0)),
                    max_check_interval)
    floor = duration / max_checks * (1.0 + 1e-9)  # the slack absorbs rounding in the sum of the steps
    capped = fine < floor
    return xp.where(capped, floor, fine), capped


def horizon(radius: float, speed: Any, duration: Any, t: Any) -> Any:
    """[m] The farthest a shape's surface can be from the robot's centre at ``t`` [s] and still be reached by the
    sweep's end (things closing at ``speed`` [m/s]): farther shapes are not looked for."""
    return radius + speed * (duration - t) + HORIZON_SLACK


def after_check(xp: Any, t: Any, dist: Any, hit: Any, nearest: Any, duration: Any, radius: float, speed: Any,
                fine: Any) -> tuple[Any, Any, Any, Any]:
    """What the check at ``t`` [s] decides, ``(verdict, nearest, dt, t_next)``.

    ``dist`` [m]: the nearest surface's distance from the robot's centre (``hit``: a shape within the
    :func:`horizon`; else ``dist`` is the horizon). ``verdict``: :data:`CONTACT` (a shape hit closer than
    ``radius``), :data:`END` (``t`` is the sweep's end) or :data:`GO`; ``nearest``: the smallest ``dist`` of
    a hit so far; ``dt`` [s]: the interval to the next check (conservative advancement: nothing can touch
    for ``(dist - radius) / speed``, at least ``fine``, at most what is left); ``t_next``: the next check's
    instant (the end exactly when ``dt`` reaches it).
    """
    verdict = xp.where(hit & (dist < radius), CONTACT, xp.where(t >= duration, END, GO))
    nearest = xp.where(hit, xp.minimum(nearest, dist), nearest)
    remaining = duration - t
    dt = (dist - radius) / xp.where(speed > 0, speed, 1.0)
    dt = xp.where(dt > fine, dt, fine)
    dt = xp.where(dt < remaining, dt, remaining)
    dt = xp.where(speed <= 0, remaining, dt)
    return verdict, nearest, dt, xp.where(dt >= remaining, duration, t + dt)
