"""The revolving door's maths (:class:`footstep_gym.scenarios.door.Door`; its YAML ``configs/scenarios/door.yaml``).

One rod per door (two wings of ``door_radius``) turning clockwise at its speed from its start angle, jittered per
episode; nothing sets it before a footstep. The walls (a corridor, a half drum over each door) follow from the
config alone.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

from footstep_gym.scenes import PARKED, Bodies, Shape, Wall

#: The config keys an episode may draw (``randomize``) that :func:`start` reads as drawn values.
RANDOMIZABLE = ("door_speed", "second_door_speed", "second_door_start_angle")
#: Whether :func:`before_step` puts the bodies elsewhere (no: the doors turn at their velocities).
MOVES = False
#: The reference world's names of the moving obstacles, in order.
NAMES = ("door", "door_2")


class Cell(NamedTuple):
    """A cell's door settings (units the YAML's: [deg/s], [deg], [m]); ``door_count`` 1 or 2 (the second door's
    keys are read only with 2)."""

    door_count: int
    door_speed: float
    door_start_angle: float
    door_angle_jitter: float
    door_centre: tuple[float, float]
    second_door_speed: float
    second_door_start_angle: float
    second_door_angle_jitter: float
    second_door_centre: tuple[float, float]


class Draws(NamedTuple):
    """An episode's standard uniforms: ``jitter`` ``(M,)``, one per door (the first door's first)."""

    jitter: Any


def cell(cfg: Any) -> Cell:
    """The door settings of a ``DoorConfig``."""
    second = (cfg.door_centre[0] + cfg.second_door_offset, cfg.door_centre[1])
    return Cell(int(cfg.door_count), cfg.door_speed, cfg.door_start_angle, cfg.door_angle_jitter,
                tuple(cfg.door_centre), cfg.second_door_speed, cfg.second_door_start_angle,
                cfg.second_door_angle_jitter, second)


def size(cfg: Any) -> int:
    """Moving obstacles of a config: its doors."""
    return int(cfg.door_count)


def shape(cfg: Any) -> Shape:
    """Every rod in its body's frame: from ``-door_radius`` to ``+door_radius`` along x, ``door_thickness`` thick."""
    r = cfg.door_radius
    return Shape((-r, 0.0), (r, 0.0), 0.5 * cfg.door_thickness)


def draw_shapes(m: int) -> Draws:
    """The shapes of an episode's uniforms for ``m`` doors."""
    return Draws((m,))


def draw_numpy(rng: Any, cfg: Any) -> Draws:
    """An episode's uniforms from the reference env's generator (after its ``randomize`` keys)."""
    return Draws(rng.random(cfg.door_count))


def start(xp: Any, c: Cell, u: Draws, m: int) -> tuple[Bodies, tuple]:
    """The rods at 0 s ``(m, ...)`` (a door past ``door_count`` :data:`PARKED`, still) and the scene state
    (none: nothing moves a rod but its turn)."""
    dt = u.jitter.dtype

    def per_door(first: Any, second: Any) -> Any:
        return xp.asarray([first, second][:m], dtype=dt)

    angle = xp.deg2rad(per_door(c.door_start_angle, c.second_door_start_angle)
                       + (-1.0 + 2.0 * u.jitter[:m]) * per_door(c.door_angle_jitter, c.second_door_angle_jitter))
    omega = -xp.deg2rad(per_door(c.door_speed, c.second_door_speed))
    there = xp.arange(m) < c.door_count
    return Bodies(xp.where(there[:, None], per_door(c.door_centre, c.second_door_centre), PARKED),
                  xp.where(there, angle, 0.0), xp.zeros((m, 2), dtype=dt), xp.where(there, omega, 0.0)), ()


def before_step(xp: Any, state: tuple, position: Any, velocity: Any, t: Any, duration: Any) -> tuple[Any, Any]:
    """The rods as they are: they turn at their velocities (:data:`MOVES` is False)."""
    return position, velocity


def walls(cfg: Any) -> list[Wall]:
    """The corridor's walls and the half drum over each door (``Door``'s module docstring), in the reference
    world's order: ``wall_bottom``, ``wall_top_left``, ``wall_top_middle`` (two doors whose drums do not touch),
    ``wall_top_right``, then each drum's segments."""
    c = cfg
    cx, cy = c.door_centre
    x0, x1 = c.corridor_x
    bottom, top = c.corridor_y
    edge = c.drum_radius
    t = c.wall_thickness
    # With a second door the walls run on to corridor_x[1] past its centre.
    far = c.second_door_offset if c.door_count == 2 else 0.0
    out = [Wall("wall_bottom", (cx + x0, cy + bottom), (cx + far + x1, cy + bottom), t),
           Wall("wall_top_left", (cx + x0, cy + top), (cx - edge, cy + top), t)]
    if c.door_count == 2 and far - 2 * edge > 0.0:
        out.append(Wall("wall_top_middle", (cx + edge, cy + top), (cx + far - edge, cy + top), t))
    out.append(Wall("wall_top_right", (cx + far + edge, cy + top), (cx + far + x1, cy + top), t))
    if c.drum_segments:
        # Vertices on the circle of radius ``edge``, from the right wall's end over the top to the left one's
        # (DoorConfig.validate keeps the chords' sag inside wall_gap).
        a0 = math.asin(top / edge)
        angles = [a0 + (math.pi - 2 * a0) * k / c.drum_segments for k in range(c.drum_segments + 1)]
        for prefix, dx in (("drum", 0.0), ("drum2", far))[:c.door_count]:
            pts = [(cx + dx + edge * math.cos(a), cy + edge * math.sin(a)) for a in angles]
            out.extend(Wall(f"{prefix}_{k}", a, b, t) for k, (a, b) in enumerate(zip(pts, pts[1:])))
    return out
