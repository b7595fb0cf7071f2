"""What the robot senses of the moving obstacles, in JAX: :func:`footstep_gym.sensing.sense` for the batched backend.

With the env's sensing options (``configs/env.yaml``: ``sensing_noise_*``, ``sensing_max_range``, ``sensing_fov``)
the observation's obstacle slots come from the sensed obstacles rather than the truth: each moving obstacle's
pose and velocity made noisy, then kept only when its (noisy) closest surface point lies within range and field
of view of the CoM. The arithmetic is the reference's (:func:`footstep_gym.sensing.sense`, ``World.nearest``'s
closest point), operation for operation; the noise's standard normals come from the env's JAX key instead of the
reference's numpy generator, so a replay agrees on everything but the draws (``tests/test_jax_sensing.py``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp

from footstep_gym.jax.shapes import Rods, centre_line, rod_endpoints, surface_point


class Sensing(NamedTuple):
    """The sensing options of an env config: noise stds ``sigma`` = (position [m], velocity [m/s], angle [rad],
    angular velocity [rad/s]), ``max_range`` [m] (``inf``: no limit) and ``fov`` [deg] (the full angle; 360: all
    around)."""

    sigma: tuple[float, float, float, float]
    max_range: float
    fov: float

    @classmethod
    def of(cls, cfg: object) -> "Sensing":
        """The options of an :class:`~footstep_gym.env_config.EnvConfig`."""
        return cls((cfg.sensing_noise_position, cfg.sensing_noise_velocity, cfg.sensing_noise_angle,
                    cfg.sensing_noise_angular_velocity), float(cfg.sensing_max_range), float(cfg.sensing_fov))

    @property
    def noisy(self) -> bool:
        """Whether any noise is on (then each observation draws ``(M, 6)`` standard normals)."""
        return any(s > 0.0 for s in self.sigma)


def noisy_rods(rods: Rods, z: jax.Array, sigma: tuple[float, float, float, float]) -> Rods:
    """The rods as sensed with the standard normals ``z`` ``(M, 6)`` = ``(x, y, vx, vy, angle, omega)`` per rod
    times ``sigma``'s stds: position and velocity always, angle and angular velocity only for a rod of non-zero
    length (a circle's outline has no angle; :func:`footstep_gym.sensing.sense`)."""
    sp, sv, sa, sw = sigma
    rod = jnp.any(rods.a != rods.b, axis=-1)
    return rods._replace(position=rods.position + sp * z[:, 0:2], velocity=rods.velocity + sv * z[:, 2:4],
                         angle=jnp.where(rod, rods.angle + sa * z[:, 4], rods.angle),
                         angular_velocity=jnp.where(rod, rods.angular_velocity + sw * z[:, 5], rods.angular_velocity))


def sensed(rods: Rods, px: jax.Array, py: jax.Array, heading: jax.Array, max_range: float, fov: float) -> jax.Array:
    """Which rods ``(M,)`` a robot with its CoM at ``(px, py)`` [m] facing ``heading`` [rad] senses: those whose
    closest surface point is within ``max_range`` [m] and within ``fov`` [deg] (inclusive) of it, and any it is
    inside or touching (gap <= 0)."""
    ax, ay, bx, by = rod_endpoints(rods)
    qx, qy, nx, ny, d = centre_line(px, py, ax, ay, bx - ax, by - ay)
    gap = d - rods.r
    keep = ~(gap > max_range)
    half = 0.5 * math.radians(fov)
    if half < math.pi:
        cx, cy = surface_point(qx, qy, nx, ny, d, rods.r)
        tx, ty = cx - px, cy - py
        c, s = jnp.cos(heading), jnp.sin(heading)
        keep = keep & (jnp.abs(jnp.arctan2(-s * tx + c * ty, c * tx + s * ty)) <= half)
    return ~(gap > 0.0) | keep


def sense(rods: Rods, key: jax.Array | None, px: jax.Array, py: jax.Array, heading: jax.Array,
          options: Sensing) -> tuple[Rods, jax.Array]:
    """The rods as sensed (noisy when ``options`` has noise; ``key`` draws it) and which of them are sensed ``(M,)``."""
    if options.noisy:
        z = jax.random.normal(key, (rods.r.shape[0], 6), rods.position.dtype)
        rods = noisy_rods(rods, z, options.sigma)
    if options.max_range == math.inf and options.fov >= 360.0:
        return rods, jnp.ones(rods.r.shape, bool)
    return rods, sensed(rods, px, py, heading, options.max_range, options.fov)
