"""The observation: its layout, its space, and how it is built from the robot's state and the sensed shapes.

``12 + 5K`` float32, the same layout for every scene (the env's docstring, "Observation Space", is the table).
"Local" means in the support foot's frame (x forward, y left). :func:`observation` builds one in plain
Python (the env's step); :func:`observations` builds a batch with numpy, or with any namespace that has
numpy's ``cos``, ``sin``, ``stack``, ``concatenate`` and ``where`` (``jax.numpy``). Units: m, m/s, rad.
"""

from __future__ import annotations

import cmath
from typing import Any, NamedTuple, Sequence

import numpy as np
from gymnasium import spaces

#: Slots of the layout: the goal (local, / position scale), the support side (+1 left, -1 right), the CoM's
#: offset from the support foot (local, / CoM scale), its velocity (local, / velocity scale), the previous
#: command mapped to [-1, 1]; then :data:`SLOT` floats per observed shape from :data:`HEAD` on.
GOAL, SIDE, COM, COM_VEL, PREVIOUS = slice(0, 2), 2, slice(3, 5), slice(5, 7), slice(7, 12)
HEAD = 12
#: Per shape: its closest point relative to the CoM (local, / position scale), that point's velocity (local,
#: / velocity scale), 1 if the slot holds a shape (0: padding, the slot all zeros).
SLOT = 5


class ObservationScales(NamedTuple):
    """What the observation divides by (keys of ``configs/env.yaml``)."""

    position: float  # [m] observation_position_scale: the goal and the shapes' points
    velocity: float  # [m/s] observation_velocity_scale: the CoM's and the shapes' velocities
    com: float  # [m] observation_com_scale: the CoM's offset from the support foot

    @classmethod
    def of(cls, cfg: Any) -> "ObservationScales":
        """The scales of an :class:`~footstep_gym.env_config.EnvConfig`."""
        return cls(cfg.observation_position_scale, cfg.observation_velocity_scale, cfg.observation_com_scale)


def observation_size(n_obstacles: int) -> int:
    """Length of the observation with ``n_obstacles`` shape slots."""
    return HEAD + SLOT * n_obstacles


def command_to_unit(command: Any, low: Any, span: Any) -> Any:
    """A command mapped field by field from the box ``[low, low + span]`` to [-1, 1] (scalars or arrays)."""
    return 2.0 * (command - low) / span - 1.0


def observation_bounds(command_low: np.ndarray, command_high: np.ndarray, nominal_command: np.ndarray,
                       sensing_range: float, position_scale: float, n_obstacles: int
                       ) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)`` float32 of the observation, inclusive (the env's docstring says why each slot's).

    The previous command lies in [-1, 1] once a command was applied (each is clipped to the box); after
    ``reset`` it is the nominal one, outside when the box leaves out S = 0, and the bounds widen to hold it.
    A shape's closest point lies within ``sensing_range`` [m] of the CoM; the relative slack covers float64's
    rounding of that point. Each bound is the float64 one cast to float32 as the values are: float32
    rounding is monotone, so every value within its bound in float64 lies within it in float32.
    """
    inf = np.inf
    low64, span = np.asarray(command_low, dtype=float), np.asarray(command_high, dtype=float) - command_low
    nominal = [command_to_unit(c, lo, s) for c, lo, s in zip(np.asarray(nominal_command, dtype=float).tolist(),
                                                              low64.tolist(), span.tolist())]
    reach = sensing_range / position_scale * (1.0 + 1e-9)
    low = [-inf, -inf, -1.0, -inf, -inf, -inf, -inf, *(min(-1.0, v) for v in nominal)]
    high = [inf, inf, 1.0, inf, inf, inf, inf, *(max(1.0, v) for v in nominal)]
    low += [-reach, -reach, -inf, -inf, 0.0] * n_obstacles
    high += [reach, reach, inf, inf, 1.0] * n_obstacles
    return np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)


def observation_space(command_low: np.ndarray, command_high: np.ndarray, nominal_command: np.ndarray,
                      sensing_range: float, position_scale: float, n_obstacles: int) -> spaces.Box:
    """The observation's ``Box`` (:func:`observation_bounds`)."""
    low, high = observation_bounds(command_low, command_high, nominal_command, sensing_range, position_scale,
                                   n_obstacles)
    return spaces.Box(low, high, dtype=np.float32)


def observation(support: tuple[float, float, float], side: int, com: complex, com_vel: complex,
                goal: tuple[float, float], previous_unit: Sequence[float],
                shapes: Sequence[tuple[Any, tuple[float, float], tuple[float, float], Any]],
                n_obstacles: int, scales: ObservationScales) -> np.ndarray:
    """One observation (float32), in plain Python.

    ``support``: the support foot's pose (x [m], y [m], yaw [rad]); ``side``: +1 left, -1 right; ``com``,
    ``com_vel``: the CoM's position [m] and velocity [m/s], world, as complex ``x + iy``; ``goal`` [m];
    ``previous_unit``: the previous command mapped by :func:`command_to_unit`; ``shapes``: the observed
    shapes nearest first, at most ``n_obstacles``, each ``(_, closest point [m], its velocity [m/s], _)``
    (``World.nearest``'s and ``sensing.nearest_views``'s rows).
    """
    ps, vs = scales.position, scales.velocity
    rot = cmath.exp(-1j * support[2])  # world -> the support foot's frame
    origin = complex(support[0], support[1])
    com_local, vel_local = (com - origin) * rot, com_vel * rot
    goal_local = (complex(*goal) - origin) * rot / ps
    obs = [goal_local.real, goal_local.imag, float(side), com_local.real / scales.com, com_local.imag / scales.com,
           vel_local.real / vs, vel_local.imag / vs, *previous_unit]
    for _, (x, y), (vx, vy), _ in shapes:
        rel = (complex(x, y) - com) * rot / ps
        v = complex(vx, vy) * rot / vs
        obs += (rel.real, rel.imag, v.real, v.imag, 1.0)
    if len(shapes) < n_obstacles:
        obs += [0.0] * (SLOT * (n_obstacles - len(shapes)))
    return np.array(obs, dtype=np.float32)


def observations(support: Any, side: Any, com: Any, com_vel: Any, goal: Any, previous_unit: Any,
                 points: Any, velocities: Any, present: Any, scales: ObservationScales, xp: Any = np) -> Any:
    """A batch of observations ``(B, 12 + 5K)`` float32 (:func:`observation`'s twin, equal to a few ulps).

    ``support (B, 3)`` [m, m, rad], ``side (B,)`` (+1 left, -1 right), ``com (B, 2)`` [m], ``com_vel (B, 2)``
    [m/s], ``goal (B, 2)`` [m], all world; ``previous_unit (B, 5)``; per shape slot ``points (B, K, 2)`` [m]
    (closest points, world), ``velocities (B, K, 2)`` [m/s] and ``present (B, K)`` (False: padding, whose
    values are ignored). ``xp``: the array namespace (``numpy``, ``jax.numpy``).
    """
    c, s = xp.cos(support[:, 2]), xp.sin(support[:, 2])

    def local(dx: Any, dy: Any) -> Any:  # a world vector in the support foot's frame, stacked on the last axis
        return xp.stack([c * dx + s * dy, c * dy - s * dx], axis=-1)

    origin = support[:, :2]
    goal_local = local(goal[:, 0] - origin[:, 0], goal[:, 1] - origin[:, 1]) / scales.position
    com_local = local(com[:, 0] - origin[:, 0], com[:, 1] - origin[:, 1]) / scales.com
    vel_local = local(com_vel[:, 0], com_vel[:, 1]) / scales.velocity
    c, s = c[:, None], s[:, None]  # per shape slot
    rel = local(points[..., 0] - com[:, None, 0], points[..., 1] - com[:, None, 1]) / scales.position
    vel = local(velocities[..., 0], velocities[..., 1]) / scales.velocity
    mask = present[..., None]
    slots = xp.concatenate([xp.where(mask, rel, 0.0), xp.where(mask, vel, 0.0),
                            xp.where(mask, 1.0, 0.0)], axis=-1)
    head = xp.concatenate([goal_local, side[:, None] * xp.ones_like(goal_local[:, :1]), com_local, vel_local,
                           previous_unit], axis=-1)
    return xp.concatenate([head, slots.reshape(slots.shape[0], -1)], axis=-1).astype(xp.float32)
