"""Encircling crowd (paper §3.3 "closed environment", Fig. 10, Table 4).

``crowd_size`` cylinders stand on a ring around the robot and walk with it towards the
goal at ``crowd_speed`` (reached after ``crowd_accel_time``); each member breathes in and
out radially with its own amplitude, period and phase, so the free space around the robot
grows and shrinks and the members move at differing speeds. The ring's centre stays
free; keeping up with it needs more speed than the nominal period allows (10 cm / 0.8 s
= 12.5 cm/s) while the member ahead leaves no room for longer strides.

Members move on a schedule; their velocity is set once per footstep to the chord of that
schedule over the footstep, so a planner's constant-velocity prediction is only
approximately right, as it would be on a robot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from footstep_gym.config import interval, nonnegative, positive
from footstep_gym.errors import ConfigError
from footstep_gym.scenarios.base import Scenario, ScenarioConfig
from footstep_gym.world import World


@dataclass(frozen=True)
class CrowdConfig(ScenarioConfig):
    crowd_size: int = positive()  # cylinders on the ring
    crowd_speed: float = nonnegative(max_key="max_crowd_speed", unit="m/s")  # [m/s] mean speed along the start -> goal direction
    crowd_accel_time: float = positive()  # [s] to reach crowd_speed from rest (constant acceleration)
    ring_radius: float = positive()  # [m] member centres from the ring's centre
    member_radius: float = positive()  # [m]
    breathing_amplitude: float = nonnegative()  # [m] largest radial oscillation of a member
    breathing_period: tuple[float, float] = interval()  # [s] range each member's period is drawn from
    angle_jitter: float = nonnegative()  # [deg] uniform +- on each member's place on the ring
    max_crowd_speed: float = positive()  # [m/s] largest crowd_speed accepted (randomize ranges included)
    max_breathing_speed: float = positive()  # [m/s] largest radial breathing speed 2 pi amplitude / shortest period

    def validate(self) -> None:
        super().validate()
        if self.breathing_period[0] <= 0:
            raise ConfigError(f"crowd: breathing_period must be > 0, got {self.breathing_period}")
        if self.ring_radius - self.breathing_amplitude <= self.member_radius:
            raise ConfigError("crowd: ring_radius - breathing_amplitude must exceed member_radius")
        amplitude, period = self.largest("breathing_amplitude"), self.breathing_period[0]
        if 2 * math.pi * amplitude / period > self.max_breathing_speed:
            raise ConfigError(
                f"CrowdConfig: breathing_amplitude={amplitude:g} m over breathing_period[0]={period:g} s moves a "
                f"member radially at up to 2 pi A / T = {2 * math.pi * amplitude / period:g} m/s, above "
                f"max_breathing_speed={self.max_breathing_speed:g} m/s (the collision sweep's cost grows with it)")


class Crowd(Scenario):
    config_file = "scenarios/crowd.yaml"
    static_keys = ()  # no walls
    Config = CrowdConfig

    def __init__(self, cfg: CrowdConfig, rng: np.random.Generator) -> None:
        super().__init__(cfg, rng)
        n = cfg.crowd_size
        self.angles = 2 * np.pi * np.arange(n) / n + np.radians(cfg.angle_jitter) * rng.uniform(-1, 1, n)
        self.amplitudes = cfg.breathing_amplitude * rng.uniform(0.5, 1.0, n)
        self.periods = rng.uniform(*cfg.breathing_period, n)
        self.phases = rng.uniform(0.0, 2 * np.pi, n)
        gx, gy = cfg.goal
        sx, sy = cfg.start
        d = math.hypot(gx - sx, gy - sy)
        self.direction = np.array([(gx - sx) / d, (gy - sy) / d]) if d > 0 else np.array([1.0, 0.0])
        self.members: list = []

    def centre(self, t: float) -> np.ndarray:
        """Ring centre at time ``t`` [s]."""
        c = self.cfg
        ta = c.crowd_accel_time
        s = c.crowd_speed * (0.5 * t * t / ta if t < ta else t - 0.5 * ta)
        return np.asarray(self.cfg.start, dtype=float) + s * self.direction

    def positions(self, t: float) -> np.ndarray:
        """Member centres ``(n, 2)`` [m] at time ``t`` [s]."""
        radius = self.cfg.ring_radius + self.amplitudes * np.sin(2 * np.pi * t / self.periods + self.phases)
        # The ring turns with the walking direction, so member 0 is always ahead.
        heading = math.atan2(self.direction[1], self.direction[0])
        ang = self.angles + heading
        return self.centre(t) + radius[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)

    def build(self, world: World) -> None:
        for i, p in enumerate(self.positions(0.0)):
            self.members.append(world.add_circle(f"member_{i}", (float(p[0]), float(p[1])), self.cfg.member_radius))

    def before_step(self, world: World, t: float, duration: float) -> None:
        now, then = self.positions(t), self.positions(t + duration)
        for m, p0, p1 in zip(self.members, now, then):
            m.body.position = (float(p0[0]), float(p0[1]))
            m.body.velocity = (float(p1[0] - p0[0]) / duration, float(p1[1] - p0[1]) / duration)
