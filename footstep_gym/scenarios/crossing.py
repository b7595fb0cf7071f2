"""Crossing obstacle (paper §3.2 "general environment", Fig. 9, Table 3).

A car-like capsule crosses the robot's straight path at ``crossing_x`` moving +y at
``obstacle_speed``, timed to reach the path when a robot walking at ``arrival_speed``
(the nominal period's top speed, 10 cm / 0.8 s) does. Quick steps beat it to the
crossing; at the nominal period the robot must wait or detour.
"""

from __future__ import annotations

from dataclasses import dataclass

from footstep_gym.config import nonnegative, positive
from footstep_gym.scenarios.base import Scenario, ScenarioConfig
from footstep_gym.world import World


@dataclass(frozen=True)
class CrossingConfig(ScenarioConfig):
    obstacle_speed: float = positive(max_key="max_obstacle_speed", unit="m/s")  # [m/s] along +y
    obstacle_length: float = positive()  # [m] along its motion
    obstacle_width: float = positive()  # [m] across it
    crossing_x: float = positive()  # [m] ahead of the start, where it crosses the straight path
    arrival_speed: float = positive(max_key="max_arrival_speed", unit="m/s")  # [m/s] it meets a robot walking this fast
    timing_jitter: float = nonnegative()  # [s] uniform +- on the meeting time per episode
    max_obstacle_speed: float = positive()  # [m/s] largest obstacle_speed accepted (randomize ranges included)
    max_arrival_speed: float = positive()  # [m/s] largest arrival_speed accepted


class Crossing(Scenario):
    config_file = "scenarios/crossing.yaml"
    static_keys = ()  # no walls
    Config = CrossingConfig
    env_id = "FootstepCrossing-v0"
    sweep_axes = {}  # one setting, the YAML's (the paper's §3.2)
    command_tables = False  # the paper gives no command table for it (its Table 3 compares totals)

    def build(self, world: World) -> None:
        c = self.cfg
        sx, sy = c.start
        t_meet = c.crossing_x / c.arrival_speed + self.rng.uniform(-1.0, 1.0) * c.timing_jitter
        half = 0.5 * (c.obstacle_length - c.obstacle_width)
        world.add_rod("car", (sx + c.crossing_x, sy - c.obstacle_speed * t_meet), (0.0, -half), (0.0, half),
                      c.obstacle_width, velocity=(0.0, c.obstacle_speed))
