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

import numpy as np

from footstep_gym.scenes import PARKED, Bodies, Shape, Wall, float_of, orca, uniform

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
    """The ring's centre ``(2,)`` [m] at time ``t`` [s] (``(..., 2)`` at times ``(..., 1)``)."""
    ta = s.accel_time
    along = s.speed * xp.where(t < ta, 0.5 * t * t / ta, t - 0.5 * ta)
    return s.start + along * s.direction


def positions(xp: Any, s: State, t: Any) -> Any:
    """Member centres ``(M, 2)`` [m] at time ``t`` [s] on their schedule (``active`` or not: an env that holds
    more members than its cell parks the others itself); ``(..., M, 2)`` at times ``t (..., 1)``, each time's
    numbers those of a call at that time alone."""
    radius = s.radius + s.amplitudes * xp.sin(2 * math.pi * t / s.periods + s.phases)
    ang = s.angles + s.heading  # the ring turns with the walking direction, so member 0 is always ahead
    return centre(xp, s, t)[..., None, :] + radius[..., None] * xp.stack([xp.cos(ang), xp.sin(ang)], axis=-1)


def before_step(xp: Any, s: State, position: Any, velocity: Any, t: Any, duration: Any) -> tuple[Any, Any]:
    """The members for the footstep from ``t`` to ``t + duration`` [s]: at their places at ``t``, moving at the
    chord of their schedule over the step (:func:`positions`: the caller parks members that are not ``active``)."""
    now, then = positions(xp, s, t), positions(xp, s, t + duration)
    return now, (then - now) / duration


# ------------------------------------------------------------------ ORCA pedestrians (crowd_model: orca)
#: ``crowd_layout`` s of the ORCA crowd, in the order of :attr:`OrcaCell.layout`'s code.
LAYOUTS = ("ring", "counter_flow", "crossing_flows", "closing_in")


class OrcaCell(NamedTuple):
    """An ORCA cell's layout and RVO2 settings (``CrowdConfig``'s keys; ``layout``: an index of :data:`LAYOUTS`;
    the unit ``direction`` from ``start`` to the goal and its ``heading`` [rad]); lengths [m], speeds [m/s],
    ``angle_jitter`` [deg], ``time_step`` and ``time_horizon`` [s]."""

    size: int
    layout: int
    pedestrian_radius: tuple[float, float]
    pedestrian_speed: tuple[float, float]
    start: tuple[float, float]
    goal: tuple[float, float]
    direction: tuple[float, float]
    heading: float
    ring_radius: float
    closing_radius: float
    angle_jitter: float
    closing_goal_along: tuple[float, float]
    closing_goal_spread: float
    flow_lanes: int
    lane_width: float
    flow_spacing: float
    flow_ahead: float
    flow_behind: float
    flow_jitter: float
    crossing_points: tuple[float, float]
    time_step: float
    neighbor_dist: float
    max_neighbors: int
    time_horizon: float
    safety_space: float


class OrcaDraws(NamedTuple):
    """An ORCA episode's standard uniforms ``(M,)`` per pedestrian: its radius, preferred speed, place's jitter
    and (``closing_in``) its goal's distance along the path and sideways."""

    radius: Any
    speed: Any
    place: Any
    along: Any
    aside: Any


class OrcaState(NamedTuple):
    """An ORCA episode's pedestrians: the ``crowd`` (:class:`footstep_gym.scenes.orca.Crowd`, ``(M, ...)``),
    which of them are ones (``active`` ``(M,)``) and the longest ORCA step ``time_step`` [s]."""

    crowd: Any
    active: Any
    time_step: Any


def orca_cell(cfg: Any) -> OrcaCell:
    """The ORCA layout and settings of a ``CrowdConfig`` (any ``crowd_model``: the keys have defaults)."""
    ring = cell(cfg)
    return OrcaCell(int(cfg.crowd_size), LAYOUTS.index(cfg.crowd_layout), tuple(cfg.pedestrian_radius),
                    tuple(cfg.pedestrian_speed), tuple(cfg.start), tuple(cfg.goal), ring.direction, ring.heading,
                    cfg.ring_radius, cfg.closing_radius, cfg.angle_jitter, tuple(cfg.closing_goal_along),
                    cfg.closing_goal_spread, int(cfg.flow_lanes), cfg.lane_width, cfg.flow_spacing, cfg.flow_ahead,
                    cfg.flow_behind, cfg.flow_jitter, tuple(cfg.crossing_points), cfg.orca_time_step,
                    cfg.orca_neighbor_dist, int(cfg.orca_max_neighbors), cfg.orca_time_horizon, cfg.orca_safety_space)


def orca_draw_shapes(m: int) -> OrcaDraws:
    """The shapes of an ORCA episode's uniforms for ``m`` pedestrians."""
    return OrcaDraws((m,), (m,), (m,), (m,), (m,))


def orca_draw_numpy(rng: Any, cfg: Any) -> OrcaDraws:
    """An ORCA episode's uniforms from the reference env's generator (after its ``randomize`` keys), in the order
    it always drew them: radii, speeds, places, then (``closing_in``) the goals' distances along and aside; the
    draws a layout does not take are 0.5."""
    n = cfg.crowd_size
    rows = 5 if cfg.crowd_layout == "closing_in" else 3
    u = np.full((5, n), 0.5)
    u[:rows] = rng.random((rows, n))
    return OrcaDraws(*u)


def orca_layout(xp: Any, c: OrcaCell, u: OrcaDraws, m: int) -> tuple[Any, Any, Any, Any]:
    """Each of ``m`` pedestrians' ``(radius, speed, start, goal)`` (``(m,)``, ``(m,)``, ``(m, 2)``, ``(m, 2)``:
    [m], [m/s], [m], [m]) for the cell's layout; those past ``size`` are padding (the caller parks them)."""
    like = u.radius
    radii = uniform(c.pedestrian_radius[0], c.pedestrian_radius[1], u.radius)
    speeds = uniform(c.pedestrian_speed[0], c.pedestrian_speed[1], u.speed)
    start, goal = float_of(xp, c.start, like), float_of(xp, c.goal, like)
    d = float_of(xp, c.direction, like)
    left = xp.stack([-d[1], d[0]])  # left of the walking direction
    i = xp.arange(m)
    fi, n = float_of(xp, i, like), float_of(xp, c.size, like)
    # ring, closing_in: around the start, member 0 straight ahead
    ang = 2 * math.pi * fi / n + xp.deg2rad(c.angle_jitter) * uniform(-1.0, 1.0, u.place) + c.heading
    radius = xp.where(c.layout == LAYOUTS.index("ring"), c.ring_radius, c.closing_radius)
    around = start + radius * xp.stack([xp.cos(ang), xp.sin(ang)], axis=1)
    along = uniform(c.closing_goal_along[0], c.closing_goal_along[1], u.along)
    aside = c.closing_goal_spread * uniform(-1.0, 1.0, u.aside)
    closing = start + along[:, None] * d + aside[:, None] * left
    # counter_flow: lanes along the path, walking from the goal side past the start
    lanes = float_of(xp, c.flow_lanes, like)
    jitter = c.flow_jitter * uniform(-1.0, 1.0, u.place)
    lane, rank = float_of(xp, i % c.flow_lanes, like), float_of(xp, i // c.flow_lanes, like)
    offset = ((lane - (lanes - 1) / 2) * c.lane_width)[:, None] * left
    ahead = c.flow_ahead + rank * c.flow_spacing + jitter
    counter = (start + ahead[:, None] * d + offset, start - c.flow_behind * d + offset)
    # crossing_flows: even pedestrians come from the left, odd ones from the right, each stream in lanes
    side = xp.where(i % 2 == 0, 1.0, -1.0)
    lane2, rank2 = float_of(xp, (i // 2) % c.flow_lanes, like), float_of(xp, (i // 2) // c.flow_lanes, like)
    x = xp.where(side > 0, c.crossing_points[0], c.crossing_points[1]) + (lane2 - (lanes - 1) / 2) * c.lane_width
    lateral = c.flow_ahead + rank2 * c.flow_spacing + jitter
    on_path = start + x[:, None] * d
    crossing = (on_path + (side * lateral)[:, None] * left, on_path - (side * c.flow_behind)[:, None] * left)
    code = c.layout
    starts = xp.where(code == 1, counter[0], xp.where(code == 2, crossing[0], around))
    goals = xp.where(code == 0, around + (goal - start), xp.where(code == 1, counter[1],
                                                                  xp.where(code == 2, crossing[1], closing)))
    return radii, speeds, starts, goals


def orca_start(xp: Any, c: OrcaCell, u: OrcaDraws, m: int, dtype: Any) -> tuple[Bodies, OrcaState]:
    """The pedestrians at 0 s ``(m, ...)`` at rest (those past ``size`` :data:`PARKED`; ``radius`` their own)
    and their ORCA crowd (:func:`footstep_gym.scenes.orca.crowd_of`: the robot invisible, no agent)."""
    radii, speeds, starts, goals = orca_layout(xp, c, u, m)
    active = xp.arange(m) < c.size
    starts = xp.where(active[:, None], starts, PARKED)
    goals = xp.where(active[:, None], goals, starts)
    crowd = orca.crowd_of(starts, goals, radii, speeds, c.neighbor_dist, c.max_neighbors, c.time_horizon,
                          c.safety_space, None, xp=xp, dtype=dtype)
    crowd = crowd._replace(agents=crowd.agents._replace(active=active))
    like = crowd.goal
    zero = xp.zeros((m,), dtype=like.dtype)
    position = xp.asarray(crowd.agents.position, dtype=like.dtype)  # ORCA's float32 places, as the reference's bodies
    bodies = Bodies(position, zero, xp.zeros((m, 2), dtype=like.dtype), zero)
    return bodies, OrcaState(crowd, active, float_of(xp, c.time_step, like)[()])


def orca_before_step(xp: Any, s: OrcaState, duration: Any, k: int) -> tuple[OrcaState, Any, Any]:
    """The pedestrians for the next footstep of ``duration`` [s]: ORCA over it
    (:func:`footstep_gym.scenes.orca.advance`, ``k`` neighbour slots); ``(state, positions, chords)``: where they
    stand at its start [m] and their chord velocities over it [m/s] (padding: where it is, at rest)."""
    crowd, now, chords = orca.advance(s.crowd, duration, s.time_step, None, None, k, xp)
    return s._replace(crowd=crowd), now, xp.where(s.active[:, None], chords, 0.0)
