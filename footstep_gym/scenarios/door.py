"""Revolving door (paper §3.1, Fig. 7-8, Table 2).

A rod through the door's centre (two wings of ``door_radius``) turns clockwise at
``door_speed`` deg/s, starting from the vertical. A corridor leads the robot across the
disc's lower half, where the wings sweep *against* its direction of travel: the upper
wall stops at the disc on both sides, the lower wall runs past the rod's tip, and a
half drum (a polygon of ``drum_segments`` walls just outside the tip's circle) closes
the upper half, as a revolving door's enclosure does, so the co-rotating half is a dead
end rather than a way round. A
straight crossing at the nominal period's top speed (12.5 cm/s) finds a gap at 8 deg/s
but not at 14 or 17; quicker steps find one (docs/model.md §4).

``door_count: 2`` adds a second revolving door of the same size ``second_door_offset`` metres
further along the corridor (+x), turning clockwise at its own ``second_door_speed`` from its own
phase (``second_door_start_angle`` +- ``second_door_angle_jitter``): the corridor's walls and a
second half drum are laid around both discs (``corridor_x[1]`` then counts from the second
door's centre), so the robot crosses two gaps in sequence, with room to wait between the two
discs. The default, one door, is the paper's scene.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from footstep_gym.config import interval, nonnegative, pair, plain, positive
from footstep_gym.errors import ConfigError
from footstep_gym.scenarios.base import Scenario, ScenarioConfig
from footstep_gym.scenes import door as scene
from footstep_gym.world import World


@dataclass(frozen=True)
class DoorConfig(ScenarioConfig):
    door_speed: float = nonnegative(max_key="max_door_speed", unit="deg/s", default=17.0)  # [deg/s] clockwise
    door_radius: float = positive(max_key="max_door_radius", unit="m", default=0.5)  # [m] wing length
    door_thickness: float = positive(default=0.02)  # [m] of the rod
    door_centre: tuple[float, float] = pair(default=(0.0, 0.0))  # [m]
    door_start_angle: float = plain(default=90.0)  # [deg] of the rod from +x, counter-clockwise (90 = vertical)
    door_angle_jitter: float = nonnegative(default=10.0)  # [deg] uniform +- per episode
    corridor_y: tuple[float, float] = interval(default=(-0.66, 0.0))  # [m] lower and upper wall, relative to the door centre
    corridor_x: tuple[float, float] = interval(default=(-1.8, 1.8))  # [m] extent of the walls, relative to the door centre
    wall_thickness: float = positive(default=0.02)  # [m]
    wall_gap: float = nonnegative(default=0.02)  # [m] between the rod's tip circle and the upper wall's ends
    drum_segments: int = nonnegative(default=8)  # walls of the half drum over the upper half (0: open, no drum)
    max_door_speed: float = positive(default=360.0)  # [deg/s] largest door_speed accepted (randomize ranges included)
    max_door_radius: float = positive(default=2.0)  # [m] largest door_radius accepted (the tip's speed grows with it)
    # A second revolving door further along the corridor (door_count: 2); the defaults leave the paper's scene.
    door_count: int = positive(default=1)  # 1: the paper's door; 2: a second door of the same size follows it along +x
    second_door_offset: float = positive(unit="m", default=1.8)  # [m] from the first door's centre to the second's, along +x
    second_door_speed: float = nonnegative(max_key="max_door_speed", unit="deg/s", default=17.0)  # [deg/s] clockwise
    second_door_start_angle: float = plain(default=90.0)  # [deg] of the second rod from +x, counter-clockwise
    second_door_angle_jitter: float = nonnegative(default=10.0)  # [deg] uniform +- per episode on the second rod
    # The keys every scenario has, at this scene's values (ScenarioConfig's defaults are generic).
    start: tuple[float, float] = pair(default=(-1.3, -0.33))
    goal: tuple[float, float] = pair(default=(1.3, -0.33))

    def validate(self) -> None:
        super().validate()
        if self.corridor_y[0] > -self.door_radius - 0.5 * self.door_thickness:
            raise ConfigError(
                f"door: corridor_y[0]={self.corridor_y[0]} must lie below the rod's tip "
                f"(-door_radius - door_thickness/2 = {-self.door_radius - 0.5 * self.door_thickness})"
            )
        if self.drum_segments and abs(self.corridor_y[1]) >= self.drum_radius:
            raise ConfigError(f"door: corridor_y[1]={self.corridor_y[1]} must cut the drum "
                              f"(|y| < drum radius {self.drum_radius:.3f}) when drum_segments > 0")
        if self.drum_segments:
            step = (math.pi - 2 * math.asin(self.corridor_y[1] / self.drum_radius)) / self.drum_segments
            sag = self.drum_radius * (1 - math.cos(0.5 * step))
            if sag >= self.wall_gap:
                raise ConfigError(f"door: drum_segments={self.drum_segments} is too few: the drum's walls sag "
                                  f"{sag * 1e3:.1f} mm inwards, into the rod's sweep (wall_gap {self.wall_gap} m)")
        if self.door_count not in (1, 2):
            raise ConfigError(f"door: door_count must be 1 or 2, got {self.door_count}")
        if self.door_count == 2:
            if self.second_door_offset < 2 * self.drum_radius:
                raise ConfigError(f"door: second_door_offset={self.second_door_offset:g} m must be >= twice the drum "
                                  f"radius ({2 * self.drum_radius:.3f} m): the two doors' drums would overlap")
            if self.corridor_x[1] < self.drum_radius:
                raise ConfigError(f"door: with door_count 2, corridor_x[1]={self.corridor_x[1]:g} m (counted from the "
                                  f"second door's centre) must reach past its drum ({self.drum_radius:.3f} m)")

    @property
    def drum_radius(self) -> float:
        """Radius [m] of the drum's (and the upper walls' ends') centre line around the door centre."""
        return self.door_radius + 0.5 * self.door_thickness + self.wall_gap + 0.5 * self.wall_thickness


class Door(Scenario):
    config_file = "scenarios/door.yaml"
    Config = DoorConfig
    env_id = "FootstepDoor-v0"
    sweep_axes = {"door_speed": "deg/s"}
    vector_entry_point = "footstep_gym.jax.vector:FootstepVectorEnv"  # the batched JAX backend (footstep_gym.jax)
    static_keys = ("door_centre", "corridor_x", "corridor_y", "wall_thickness", "drum_segments",
                   "door_radius", "door_thickness", "wall_gap",  # drum_radius reads these three
                   "door_count")  # and, with door_count 2, second_door_offset (static_key adds it)

    @classmethod
    def static_key(cls, cfg: DoorConfig) -> tuple:
        """The keys of :attr:`static_keys`, and ``second_door_offset`` where a second door reads it (it moves
        that door's drum and the walls' ends; with one door it is read by nothing)."""
        key = tuple(getattr(cfg, k) for k in cls.static_keys)
        return key + (cfg.second_door_offset,) if cfg.door_count == 2 else key

    def __init__(self, cfg: DoorConfig, rng: np.random.Generator) -> None:
        super().__init__(cfg, rng)
        #: The episode's uniforms (:func:`footstep_gym.scenes.door.draw_numpy`).
        self.draws = scene.draw_numpy(rng, cfg)

    def build(self, world: World) -> None:
        c = self.cfg
        bodies, _ = scene.start(np, scene.cell(c), self.draws, c.door_count)
        a, b, r = scene.shape(c)
        for name, p, angle, omega in zip(scene.NAMES, bodies.position.tolist(), bodies.angle.tolist(),
                                         bodies.angular_velocity.tolist()):
            world.add_rod(name, tuple(p), a, b, 2 * r, angle=angle, angular_velocity=omega)

    def build_static(self, world: World) -> None:
        for w in scene.walls(self.cfg):
            world.add_wall(w.name, w.a, w.b, w.thickness)
