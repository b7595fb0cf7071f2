"""The world's shapes as arrays, their distances, the collision sweep and the nearest shapes (pure JAX).

The batched form of :mod:`footstep_gym.world`'s sweep for one env (``jax.vmap`` batches it): static walls are
thick segments in world coordinates (:class:`Walls`), each moving obstacle a thick segment on a kinematic body
(:class:`Rods`: its pose, velocity and turn rate; a circle on its body's origin is a segment of zero length,
whose Chipmunk distance is the circle's). Each check is :mod:`footstep_gym.collision`'s arithmetic run with
``jax.numpy`` (Chipmunk's point queries, conservative advancement: the reference's and the compiled sweep's,
written once; docs/model.md §4.1), so the sweep is the reference's check for check: the same instants, the same
first contact, the same bodies' poses, up to the last bits of libm's ``exp``/``sin``/``cos`` (XLA's differ from
the C library's by an ulp here and there). The observation's nearest shapes use ``World.nearest``'s arithmetic.

**How the sweep runs.** The reference takes one check at a time, each check's distance setting the interval to
the next. Here a ``lax.while_loop`` runs until the sweep ends, each of its iterations taking ``block`` checks one
after another (the loop unrolled ``block`` times; the checks after a contact or the step's end change nothing), so
the answers are the one-check loop's whatever ``block`` is (``tests/test_jax_door.py`` checks ``block=1`` against
wider blocks). Under ``vmap`` every env of a batch waits for the slowest; a wider block takes fewer iterations of
the loop, each costing more where most envs have ended.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from footstep_gym import collision

#: Collision checks per iteration of the sweep's loop (:func:`sweep`'s ``block``): speed only, never the answers.
DEFAULT_BLOCK = 2


class Walls(NamedTuple):
    """Static thick segments, world frame [m]: endpoints ``a``, ``b`` ``(W, 2)`` and half thickness ``r`` ``(W,)``."""

    a: jax.Array
    b: jax.Array
    r: jax.Array


class Rods(NamedTuple):
    """Kinematic thick segments, one per body: the body's ``position`` ``(M, 2)`` [m], ``angle`` ``(M,)`` [rad],
    ``velocity`` ``(M, 2)`` [m/s], ``angular_velocity`` ``(M,)`` [rad/s], the segment's endpoints in the body's
    frame ``a``, ``b`` ``(M, 2)`` [m] and half thickness ``r`` ``(M,)`` [m]."""

    position: jax.Array
    angle: jax.Array
    velocity: jax.Array
    angular_velocity: jax.Array
    a: jax.Array
    b: jax.Array
    r: jax.Array

    def reach(self) -> jax.Array:
        """Farthest distance of each rod's surface from its body's origin [m] (``Obstacle.reach``)."""
        return collision.shape_reach(jnp, self.a[:, 0], self.a[:, 1], self.b[:, 0], self.b[:, 1], self.r)

    def max_speed(self) -> jax.Array:
        """Largest speed [m/s] of any point of any rod (``World.max_obstacle_speed``; 0 with no rods)."""
        v = collision.body_speed(jnp, self.velocity[:, 0], self.velocity[:, 1], self.angular_velocity, self.reach())
        return jnp.max(v, initial=0.0)

    def moved(self, dt: Any) -> "Rods":
        """The rods ``dt`` [s] later (pymunk's kinematic update: ``p += v dt``, ``angle += w dt``), where
        ``dt > 0``; unchanged elsewhere (the reference does not step its space for a zero interval)."""
        go = dt > 0
        return self._replace(position=jnp.where(go, collision.moved(self.position, self.velocity, dt), self.position),
                             angle=jnp.where(go, collision.moved(self.angle, self.angular_velocity, dt), self.angle))


def wall_table(walls: Walls) -> jax.Array:
    """``(W, 8)``: ``ax, ay, bx, by, ax - bx, ay - by, |a - b|^2, r`` per wall (the compiled sweep's static rows)."""
    dx, dy, l2 = collision.segment_frame(walls.a[:, 0], walls.a[:, 1], walls.b[:, 0], walls.b[:, 1])
    return jnp.concatenate([walls.a, walls.b, jnp.stack([dx, dy, l2], axis=1), walls.r[:, None]], axis=1)


def rod_endpoints(rods: Rods) -> tuple[jax.Array, ...]:
    """World endpoints ``ax, ay, bx, by`` of each rod (``(..., M)``: the rods' leaves may lead with a batch
    axis), in ``World.nearest``'s order of operations (the sweep places them with ``collision.body_segment``)."""
    px, py = rods.position[..., 0], rods.position[..., 1]
    lax_, lay, lbx, lby = rods.a[..., 0], rods.a[..., 1], rods.b[..., 0], rods.b[..., 1]
    c, s = jnp.cos(rods.angle), jnp.sin(rods.angle)
    return (px + c * lax_ - s * lay, py + s * lax_ + c * lay, px + c * lbx - s * lby, py + s * lbx + c * lby)


def distances(qx: jax.Array, qy: jax.Array, table: jax.Array, rods: Rods) -> jax.Array:
    """Surface distance [m] from each point ``(qx[i], qy[i])`` (shape ``(B,)``) to every shape, walls first:
    ``(B, W + M)``; the rods' leaves lead with ``B`` (each point's own instant)."""
    qx, qy = qx[:, None], qy[:, None]
    t = table
    d_walls = collision.segment_distance(jnp, qx, qy, t[:, 0], t[:, 1], t[:, 2], t[:, 3], t[:, 4], t[:, 5], t[:, 6],
                                         t[:, 7])
    rod_segments = collision.body_segment(jnp, rods.position[..., 0], rods.position[..., 1], rods.angle,
                                          rods.a[..., 0], rods.a[..., 1], rods.b[..., 0], rods.b[..., 1])
    d_rods = collision.segment_distance(jnp, qx, qy, *rod_segments, rods.r)
    return jnp.concatenate([d_walls, d_rods], axis=-1)


class SweepResult(NamedTuple):
    """A footstep's sweep: ``collided``, the time [s] of the contact or the step's duration, the shape hit (its
    index, walls first; -1 if none), the number of checks, the smallest clearance [m] at the checks (``inf``
    if nothing came within reach) and the rods at the sweep's end (the contact's instant on a collision)."""

    collided: jax.Array
    time: jax.Array
    obstacle: jax.Array
    checks: jax.Array
    clearance: jax.Array
    rods: Rods


def sweep(path: Any, duration: jax.Array, robot_speed_bound: jax.Array, table: jax.Array, rods: Rods,
          radius: float, max_check_interval: float, motion_fraction: float, max_checks: int,
          block: int = DEFAULT_BLOCK, active: Any = True, cached: jax.Array | None = None) -> SweepResult:
    """The reference's collision sweep (``World.sweep``) over one footstep of ``duration`` [s].

    ``path(t) -> (x, y)`` is the CoM (body centre) at ``t`` (``(B,)`` times at once); ``robot_speed_bound``
    bounds its speed [m/s]. Checks are spaced by conservative advancement, at most ``max_check_interval`` and
    ``motion_fraction * radius / speed`` apart where contact is possible, and no closer than
    ``duration / max_checks``. ``block`` checks are evaluated per iteration (module docstring). Where
    ``active`` is False nothing is checked (a fall: the step takes no time) and the rods stay where they are.

    ``cached``: the rods' positions ``(M, 2)`` as pymunk last cached their shapes, where a scene has set the
    bodies elsewhere since (the crowd and the car stream put theirs at their scheduled places before a step):
    pymunk's query answers the first check there, so this one does too; the rods then move on from ``rods``.
    """
    dtype = duration.dtype
    speed = robot_speed_bound + rods.max_speed()
    fine, _ = collision.check_spacing(jnp, duration, speed, jnp.asarray(max_check_interval, dtype), motion_fraction,
                                      radius, max_checks)
    inf = jnp.asarray(jnp.inf, dtype)

    def body(carry):
        t, rods_now, checks, nearest, status, shape, dist = carry
        for _ in range(block):  # the reference's one-check loop, `block` checks per iteration; none after the last
            running = status == collision.GO
            qx, qy = path(t[None])
            seen = rods_now
            if cached is not None:  # the sweep's first check sees the shapes where pymunk cached them
                seen = rods_now._replace(position=jnp.where(checks == 0, cached, rods_now.position))
            d = distances(qx, qy, table, jax.tree.map(lambda x: x[None], seen))[0]
            horizon = collision.horizon(radius, speed, duration, t)
            dmin = jnp.min(d)
            hit = dmin < horizon
            dist_now = jnp.where(hit, dmin, horizon)
            verdict, nearest_now, dt, t_next = collision.after_check(jnp, t, dist_now, hit, nearest, duration, radius,
                                                                     speed, fine)
            go = running & (verdict == collision.GO)
            nearest = jnp.where(running, nearest_now, nearest)
            shape = jnp.where(running, jnp.where(hit, jnp.argmin(d), -1), shape).astype(jnp.int32)
            dist = jnp.where(running, dist_now, dist)
            checks = (checks + running).astype(jnp.int32)
            status = jnp.where(running, verdict, status).astype(jnp.int32)
            rods_now = jax.tree.map(lambda a, b: jnp.where(go, a, b), rods_now.moved(dt), rods_now)
            t = jnp.where(go, t_next, t)
        return t, rods_now, checks, nearest, status, shape, dist

    status0 = jnp.where(active, collision.GO, collision.END).astype(jnp.int32)
    carry0 = (jnp.zeros((), dtype), rods, jnp.zeros((), jnp.int32), inf, status0, jnp.full((), -1, jnp.int32), inf)
    t, rods_end, checks, nearest, status, shape, dist = jax.lax.while_loop(lambda c: c[4] == collision.GO, body, carry0)
    collided = status == collision.CONTACT
    clearance = jnp.where(collided, dist - radius, nearest - radius)
    return SweepResult(collided, t, jnp.where(collided, shape, -1), checks, clearance, rods_end)


def centre_line(px: jax.Array, py: jax.Array, ax: jax.Array, ay: jax.Array, dx: jax.Array, dy: jax.Array
                ) -> tuple[jax.Array, ...]:
    """``(qx, qy, nx, ny, d)``: the point of each centre line from ``(ax, ay)`` along ``(dx, dy)`` nearest ``(px, py)``
    [m], the offset from it to the point and its length (``World.nearest``'s arithmetic; broadcasts)."""
    l2 = dx * dx + dy * dy
    u = ((px - ax) * dx + (py - ay) * dy) / jnp.where(l2 == 0.0, 1.0, l2)
    u = jnp.where(l2 == 0.0, 0.0, u)
    u = jnp.where(0.0 > u, 0.0, u)
    u = jnp.where(1.0 < u, 1.0, u)
    qx, qy = ax + u * dx, ay + u * dy
    nx, ny = px - qx, py - qy
    return qx, qy, nx, ny, jnp.hypot(nx, ny)


def surface_point(qx: jax.Array, qy: jax.Array, nx: jax.Array, ny: jax.Array, d: jax.Array, r: jax.Array
                  ) -> tuple[jax.Array, jax.Array]:
    """The closest surface point [m] of a thick segment (half thickness ``r``) from :func:`centre_line`'s answer (a
    point on the centre line itself: the one ``r`` above it, as ``World.nearest``)."""
    pos_d = d > 0.0
    safe_d = jnp.where(pos_d, d, 1.0)
    return jnp.where(pos_d, qx + r * nx / safe_d, qx), jnp.where(pos_d, qy + r * ny / safe_d, qy + r)


def nearest_shapes(px: jax.Array, py: jax.Array, walls: Walls, rods: Rods, k: int, max_distance: float,
                   rods_sensed: jax.Array | None = None) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Up to ``k`` shapes nearest the point ``(px, py)`` within ``max_distance`` [m], nearest first, ties in the
    shapes' order (walls first): ``World.nearest``'s arithmetic. Returns their closest points ``(k, 2)`` [m],
    those points' velocities ``(k, 2)`` [m/s] and a mask ``(k,)`` (False: padding, its rows zero).
    ``rods_sensed`` ``(M,)``: only these rods count (``footstep_gym.sensing.nearest_views`` over what was sensed)."""
    ax_w, ay_w = walls.a[:, 0], walls.a[:, 1]
    dx_w, dy_w = walls.b[:, 0] - ax_w, walls.b[:, 1] - ay_w
    ax_r, ay_r, bx_r, by_r = rod_endpoints(rods)
    ax = jnp.concatenate([ax_w, ax_r])
    ay = jnp.concatenate([ay_w, ay_r])
    dx = jnp.concatenate([dx_w, bx_r - ax_r])
    dy = jnp.concatenate([dy_w, by_r - ay_r])
    radius = jnp.concatenate([walls.r, rods.r])
    qx, qy, nx, ny, d = centre_line(px, py, ax, ay, dx, dy)
    gap = d - radius
    inside = ~(gap > max_distance)
    if rods_sensed is not None:
        inside = inside & jnp.concatenate([jnp.ones(walls.r.shape, bool), rods_sensed])
    n = gap.shape[0]
    # The k smallest by (gap, index), one argmin at a time (argmin takes the first of equal gaps): for a dozen
    # shapes this is cheaper than a batched sort on XLA's CPU backend.
    key = jnp.where(inside, gap, jnp.inf)
    picked, valid = [], []
    for _ in range(min(k, n)):
        i = jnp.argmin(key)
        picked.append(i)
        valid.append(jnp.isfinite(key[i]))
        key = key.at[i].set(jnp.inf)
    order = jnp.stack(picked).astype(jnp.int32)
    mask = jnp.stack(valid)
    pad = k - min(k, n)
    if pad:
        order = jnp.concatenate([order, jnp.zeros((pad,), order.dtype)])
        mask = jnp.concatenate([mask, jnp.zeros((pad,), bool)])
    cx, cy = surface_point(qx[order], qy[order], nx[order], ny[order], d[order], radius[order])
    n_walls = walls.r.shape[0]
    mover = jnp.clip(order - n_walls, 0, max(rods.r.shape[0] - 1, 0))
    moving = order >= n_walls
    if rods.r.shape[0]:
        ox, oy = rods.position[mover, 0], rods.position[mover, 1]
        w = rods.angular_velocity[mover]
        vx = jnp.where(moving, rods.velocity[mover, 0] - w * (cy - oy), 0.0)
        vy = jnp.where(moving, rods.velocity[mover, 1] + w * (cx - ox), 0.0)
    else:
        vx = vy = jnp.zeros_like(cx)
    point = jnp.where(mask[:, None], jnp.stack([cx, cy], -1), 0.0)
    vel = jnp.where(mask[:, None], jnp.stack([vx, vy], -1), 0.0)
    return point, vel, mask


def walls_of(world: Any, dtype: Any) -> Walls:
    """The static walls of a reference :class:`footstep_gym.world.World`, in its obstacles' order."""
    statics = [o for o in world.obstacles if o.static]
    if any(o.kind != "segment" for o in statics):
        raise ValueError("the batched backend supports static segments only")
    a = np.array([o.local_a for o in statics], dtype=np.float64).reshape(-1, 2)
    b = np.array([o.local_b for o in statics], dtype=np.float64).reshape(-1, 2)
    r = np.array([o.radius for o in statics], dtype=np.float64)
    return Walls(jnp.asarray(a, dtype), jnp.asarray(b, dtype), jnp.asarray(r, dtype))
