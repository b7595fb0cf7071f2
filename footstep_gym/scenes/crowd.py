"""The scripted crowd's maths (:class:`footstep_gym.scenarios.crowd.Crowd` with ``crowd_model: scripted``;
``configs/scenarios/crowd.yaml``).

``crowd_size`` members on a ring that walks from the start towards the goal (accelerating for
``crowd_accel_time``, then at ``crowd_speed``), each breathing radially with its own amplitude, period and phase
(:func:`positions`). Before each footstep the members are put at their places at its start and move at the chord
of their schedule over it (:func:`before_step`). No walls. Another crowd model (ORCA's pedestrians) is a
module of its own with the same functions.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

from footstep_gym.scenes import PARKED, Bodies, Shape, Wall, float_of, uniform

#: The config keys an episode may draw (``randomize``) that :func:`start` reads as drawn values.
RANDOMIZABLE = ("crowd_speed", "crowd_accel_time", "breathing_amplitude", "angle_jitter")
#: Whether :func:`before_step` moves the bodies (each member to its schedule's place).
MOVES = True


class Cell(NamedTuple):
    """A cell's ring: ``size`` members; [m/s], [s], [m], [deg]; the unit ``direction`` from ``start`` to the goal
    and its ``heading`` [rad] (member 0 is always ahead)."""

    size: int
    crowd_speed: float
    crowd_accel_time: float
    breathing_amplitude: float
    angle_jitter: float
    ring_radius: float
    breathing_period: tuple[float, float]
    start: tuple[float, float]
    direction: tuple[float, float]
    heading: float


class Draws(NamedTuple):
    """An episode's standard uniforms ``(M,)`` per member: its place's jitter, amplitude, period and phase."""

    angle: Any
    amplitude: Any
    period: Any
    phase: Any


class State(NamedTuple):
    """An episode's ring: each member's place ``angles`` [rad], breathing ``amplitudes`` [m], ``periods`` [s] and
    ``phases`` [rad] ``(M,)``, whether it is one (``active``); the ring's walk (``speed`` [m/s], ``accel_time``
    [s], ``radius`` [m]) from ``start`` along the unit ``direction`` (``heading`` [rad])."""

    angles: Any
    amplitudes: Any
    periods: Any
    phases: Any
    active: Any
    speed: Any
    accel_time: Any
    radius: Any
    start: Any
    direction: Any
    heading: Any


def cell(cfg: Any) -> Cell:
    """The ring of a ``CrowdConfig`` (its direction from the start to the goal; +x where they coincide)."""
    (sx, sy), (gx, gy) = cfg.start, cfg.goal
    d = math.hypot(gx - sx, gy - sy)
    direction = ((gx - sx) / d, (gy - sy) / d) if d > 0 else (1.0, 0.0)
    return Cell(int(cfg.crowd_size), cfg.crowd_speed, cfg.crowd_accel_time, cfg.breathing_amplitude, cfg.angle_jitter,
                cfg.ring_radius, tuple(cfg.breathing_period), tuple(cfg.start), direction,
                math.atan2(direction[1], direction[0]))


def size(cfg: Any) -> int:
    """Moving obstacles of a config: its members."""
    return int(cfg.crowd_size)


def shape(cfg: Any) -> Shape:
    """Every member: a circle of ``member_radius``."""
    return Shape((0.0, 0.0), (0.0, 0.0), cfg.member_radius)


def walls(cfg: Any) -> list[Wall]:
    """None."""
    return []


def draw_shapes(m: int) -> Draws:
    """The shapes of an episode's uniforms for ``m`` members."""
    return Draws((m,), (m,), (m,), (m,))


def draw_numpy(rng: Any, cfg: Any) -> Draws:
    """An episode's uniforms from the reference env's generator (after its ``randomize`` keys)."""
    return Draws(*rng.random((4, cfg.crowd_size)))


def start(xp: Any, c: Cell, u: Draws, m: int) -> tuple[Bodies, State]:
    """The members at 0 s ``(m, ...)`` (those past ``size`` :data:`PARKED`), at rest, and the episode's ring."""
    like = u.angle
    i = xp.arange(m)
    angles = 2 * math.pi * float_of(xp, i, like) / float_of(xp, c.size, like) + xp.deg2rad(c.angle_jitter) * uniform(
        -1.0, 1.0, u.angle)
    state = State(angles, c.breathing_amplitude * uniform(0.5, 1.0, u.amplitude),
                  uniform(c.breathing_period[0], c.breathing_period[1], u.period), uniform(0.0, 2 * math.pi, u.phase),
                  i < c.size, float_of(xp, c.crowd_speed, like)[()], float_of(xp, c.crowd_accel_time, like)[()],
                  float_of(xp, c.ring_radius, like)[()], float_of(xp, c.start, like), float_of(xp, c.direction, like),
                  float_of(xp, c.heading, like)[()])
    zero = xp.zeros((m,), dtype=like.dtype)
    position = xp.where(state.active[:, None], positions(xp, state, 0.0), PARKED)
    return Bodies(position, zero, xp.zeros((m, 2), dtype=like.dtype), zero), state


def centre(xp: Any, s: State, t: Any) -> Any:
    """The ring's centre ``(2,)`` [m] at time ``t`` [s]."""
    ta = s.accel_time
    along = s.speed * xp.where(t < ta, 0.5 * t * t / ta, t - 0.5 * ta)
    return s.start + along * s.direction


def positions(xp: Any, s: State, t: Any) -> Any:
    """Member centres ``(M, 2)`` [m] at time ``t`` [s] on their schedule (``active`` or not: an env that holds
    more members than its cell parks the others itself)."""
    radius = s.radius + s.amplitudes * xp.sin(2 * math.pi * t / s.periods + s.phases)
    ang = s.angles + s.heading  # the ring turns with the walking direction, so member 0 is always ahead
    return centre(xp, s, t) + radius[:, None] * xp.stack([xp.cos(ang), xp.sin(ang)], axis=1)


def before_step(xp: Any, s: State, position: Any, velocity: Any, t: Any, duration: Any) -> tuple[Any, Any]:
    """The members for the footstep from ``t`` to ``t + duration`` [s]: at their places at ``t``, moving at the
    chord of their schedule over the step (:func:`positions`: the caller parks members that are not ``active``)."""
    now, then = positions(xp, s, t), positions(xp, s, t + duration)
    return now, (then - now) / duration
