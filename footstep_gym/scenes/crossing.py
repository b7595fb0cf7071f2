"""The crossing's maths (:class:`footstep_gym.scenarios.crossing.Crossing`; ``configs/scenarios/crossing.yaml``).

``traffic_lanes: 0``: one car timed to meet a robot walking at ``arrival_speed`` (+- ``timing_jitter``), driving
on at ``obstacle_speed``; nothing sets it before a footstep. ``traffic_lanes`` >= 1: lanes of cars on loops
(the scenario module's docstring), each lane's phase drawn per episode; before each footstep every car is put
at its scheduled place (:func:`positions`) and keeps its lane's velocity through the step. No walls.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from footstep_gym.scenes import PARKED, Bodies, Shape, Wall, float_of, uniform

#: The config keys an episode may draw (``randomize``) that :func:`start` reads as drawn values.
RANDOMIZABLE = ("obstacle_speed", "arrival_speed", "timing_jitter", "traffic_speed", "traffic_gap")
#: Whether :func:`before_step` moves the bodies (the traffic's cars re-enter their loops).
MOVES = True


class Cell(NamedTuple):
    """A cell's crossing settings ([m], [m/s], [s]): ``lanes`` 0 (the timed car) or the traffic's lanes of
    ``per_lane`` cars, ``count`` cars in all."""

    lanes: int
    per_lane: int
    count: int
    obstacle_speed: float
    arrival_speed: float
    timing_jitter: float
    traffic_speed: float
    traffic_gap: float
    crossing_x: float
    traffic_spacing: float
    traffic_lane_width: float
    start: tuple[float, float]


class Draws(NamedTuple):
    """An episode's standard uniforms: the timed car's meeting time ``timing`` ``()``; each lane's phase
    ``phases`` ``(M,)`` (lane ``k``'s at ``k``)."""

    timing: Any
    phases: Any


class State(NamedTuple):
    """An episode's cars: each car's lane line ``x`` [m], place along its loop at 0 s ``offset`` [m] and
    ``direction`` (+1: +y) ``(M,)``; the loop's length ``loop`` and start ``y0`` [m]; the cars' ``speed``
    [m/s]; which of the ``M`` are cars (``active``); ``traffic``: False for the one timed car."""

    x: Any
    offset: Any
    direction: Any
    loop: Any
    y0: Any
    speed: Any
    active: Any
    traffic: Any


def counts(cfg: Any) -> tuple[int, int, int]:
    """``(lanes, cars per lane, cars)`` of a config: the fewest cars per lane that span ``2 traffic_extent``."""
    if not cfg.traffic_lanes:
        return 0, 1, 1
    per_lane = max(1, math.ceil(2.0 * cfg.traffic_extent / cfg.traffic_spacing - 1e-9))
    return cfg.traffic_lanes, per_lane, cfg.traffic_lanes * per_lane


def cell(cfg: Any) -> Cell:
    """The crossing settings of a ``CrossingConfig``."""
    return Cell(*counts(cfg), cfg.obstacle_speed, cfg.arrival_speed, cfg.timing_jitter, cfg.traffic_speed,
                cfg.traffic_gap, cfg.crossing_x, cfg.traffic_spacing, cfg.traffic_lane_width, tuple(cfg.start))


def size(cfg: Any) -> int:
    """Moving obstacles of a config: its cars."""
    return counts(cfg)[2]


def shape(cfg: Any) -> Shape:
    """Every car in its body's frame: a capsule ``obstacle_length`` long along y, ``obstacle_width`` wide."""
    half = 0.5 * (cfg.obstacle_length - cfg.obstacle_width)
    return Shape((0.0, -half), (0.0, half), 0.5 * cfg.obstacle_width)


def walls(cfg: Any) -> list[Wall]:
    """None."""
    return []


def draw_shapes(m: int) -> Draws:
    """The shapes of an episode's uniforms for ``m`` cars."""
    return Draws((), (m,))


def draw_numpy(rng: Any, cfg: Any) -> Draws:
    """An episode's uniforms from the reference env's generator (after its ``randomize`` keys): a phase per lane,
    or the timed car's meeting time (0.5 stands for what is not drawn)."""
    if cfg.traffic_lanes:
        return Draws(np.float64(0.5), rng.random(cfg.traffic_lanes))
    return Draws(np.float64(rng.random()), np.full(1, 0.5))


def start(xp: Any, c: Cell, u: Draws, m: int) -> tuple[Bodies, State]:
    """The cars at 0 s ``(m, ...)`` (those past ``count`` :data:`PARKED`, still) and the episode's schedule."""
    like = u.phases
    i = xp.arange(m)
    active = i < c.count
    k, j = i // c.per_lane, i % c.per_lane
    spacing = c.traffic_spacing
    loop = float_of(xp, c.per_lane - 1, like) * spacing + xp.where(c.traffic_gap > 0, c.traffic_gap, spacing)
    sx, sy = c.start[0], c.start[1]
    x = sx + c.crossing_x + (float_of(xp, k, like) - 0.5 * float_of(xp, c.lanes - 1, like)) * c.traffic_lane_width
    direction = float_of(xp, xp.where(k % 2 == 0, 1.0, -1.0), like)  # lane 0 along +y, then alternating
    # Each lane's phase anywhere in the loop's repeating unit (with a gap, the whole loop).
    phases = uniform(0.0, xp.where(c.traffic_gap > 0, loop, spacing), u.phases)
    offset = phases[k] + float_of(xp, j, like) * spacing
    traffic = c.lanes > 0
    state = State(x, offset, direction, loop, sy - 0.5 * loop, float_of(xp, c.traffic_speed, like), active, traffic)
    # The one timed car: it meets a robot walking at arrival_speed, +- the jitter.
    t_meet = c.crossing_x / c.arrival_speed + uniform(-1.0, 1.0, u.timing) * c.timing_jitter
    car = xp.stack([float_of(xp, sx + c.crossing_x, like), float_of(xp, sy - c.obstacle_speed * t_meet, like)])
    timed = xp.where((i == 0)[:, None], car, 0.0)
    position = xp.where(traffic, positions(xp, state, 0.0), timed)
    vy = xp.where(traffic, direction * state.speed, float_of(xp, c.obstacle_speed, like))
    velocity = xp.stack([xp.zeros((m,), dtype=like.dtype), vy], axis=1)
    zero = xp.zeros((m,), dtype=like.dtype)
    return Bodies(xp.where(active[:, None], position, PARKED), zero, xp.where(active[:, None], velocity, 0.0),
                  zero), state


def positions(xp: Any, s: State, t: Any) -> Any:
    """The traffic's car centres ``(M, 2)`` [m] at time ``t`` [s] on their schedule (``active`` or not: an env that
    holds more cars than its cell parks the others itself)."""
    along = xp.mod(s.offset + s.direction * s.speed * t, s.loop)
    return xp.stack([s.x, s.y0 + along], axis=1)


def before_step(xp: Any, s: State, position: Any, velocity: Any, t: Any, duration: Any) -> tuple[Any, Any]:
    """The cars for the footstep from ``t`` [s]: the traffic's at their scheduled places (:func:`positions`: the
    caller parks cars that are not ``active``), their velocities kept; the timed car as it is."""
    return xp.where(s.traffic, positions(xp, s, t), position), velocity
