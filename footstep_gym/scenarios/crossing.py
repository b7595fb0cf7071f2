"""Crossing obstacle (paper §3.2 "general environment", Fig. 9, Table 3).

A car-like capsule crosses the robot's straight path at ``crossing_x`` moving +y at
``obstacle_speed``, timed to reach the path when a robot walking at ``arrival_speed``
(the nominal period's top speed, 10 cm / 0.8 s) does. Quick steps beat it to the
crossing; at the nominal period the robot must wait or detour.

``traffic_lanes`` >= 1 replaces the one timed car by steady traffic (the benchmark's hard
tier, configs/benchmark.yaml): that many lanes side by side, ``traffic_lane_width`` apart and
centred on ``crossing_x``, each a stream of cars (capsules of ``obstacle_length`` x
``obstacle_width``) ``traffic_spacing`` apart, centre to centre, driving at ``traffic_speed``,
lane 0 (the nearest the start) along +y and each next lane the other way, so traffic comes
from both sides. A car that has driven ``traffic_extent`` past the path re-enters the same
distance before it (its lane is a loop of ``n * traffic_spacing``, ``n`` the fewest cars that
span ``2 * traffic_extent``), so the gaps pass the path at a steady rhythm for the whole
episode; each lane's phase is drawn per episode. A gap of ``traffic_spacing -
obstacle_length`` at ``traffic_speed`` is open for too short a time to be crossed at the
nominal period: only quicker steps use it (or waiting between the lanes, where they are far
enough apart).

``traffic_gap`` > 0 makes each lane a stream with one open gap that moves: the lane's cars follow
each other ``traffic_spacing`` apart except once per loop, where the next car comes
``traffic_gap`` behind (centre to centre); the loop is ``(n - 1) * traffic_spacing + traffic_gap``
long, and the lane's phase, drawn per episode, decides when the gap reaches the path. With the
spacing too tight to cross at any period and the gap wide enough only at quick steps, a robot
must sense where the gap is, wait for it and take it at a short period; a blind walker, whatever
its speed, crosses in the gap only in the few episodes whose phase happens to suit it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from footstep_gym.config import nonnegative, positive
from footstep_gym.errors import ConfigError
from footstep_gym.scenarios.base import RobotMotion, Scenario, ScenarioConfig
from footstep_gym.scenes import crossing as scene
from footstep_gym.world import World


@dataclass(frozen=True)
class CrossingConfig(ScenarioConfig):
    obstacle_speed: float = positive(max_key="max_obstacle_speed", unit="m/s", default=0.25)  # [m/s] along +y
    obstacle_length: float = positive(default=0.5)  # [m] along its motion
    obstacle_width: float = positive(default=0.24)  # [m] across it
    crossing_x: float = positive(default=0.9)  # [m] ahead of the start, where it crosses the straight path
    arrival_speed: float = positive(max_key="max_arrival_speed", unit="m/s", default=0.125)  # [m/s] it meets a robot walking this fast
    timing_jitter: float = nonnegative(default=1.0)  # [s] uniform +- on the meeting time per episode
    max_obstacle_speed: float = positive(default=5.0)  # [m/s] largest obstacle_speed accepted (randomize ranges included)
    max_arrival_speed: float = positive(default=2.0)  # [m/s] largest arrival_speed accepted
    # Steady traffic instead of the timed car (traffic_lanes >= 1); the defaults leave the paper's scene.
    traffic_lanes: int = nonnegative(default=0)  # 0: the one timed car; >= 1: lanes of cars, directions alternating
    traffic_lane_width: float = positive(unit="m", default=0.6)  # [m] between neighbouring lanes' centre lines
    traffic_spacing: float = positive(unit="m", default=1.5)  # [m] between consecutive cars of a lane, centre to centre
    traffic_speed: float = positive(max_key="max_obstacle_speed", unit="m/s", default=0.3)  # [m/s] of every car
    traffic_extent: float = positive(unit="m", default=2.5)  # [m] cars re-enter after driving this far past the path
    traffic_gap: float = nonnegative(unit="m", default=0.0)  # [m] 0: none; > 0: one gap this long (centre to centre) per loop

    def smallest(self, key: str) -> float:
        """The smallest value numeric ``key`` can take in an episode: its ``randomize`` lower end, else its value."""
        if key in self.randomize:
            return min(float(b) for b in self.randomize[key])
        return float(getattr(self, key))

    def validate(self) -> None:
        super().validate()
        if not self.traffic_lanes:
            return
        length, spacing = self.largest("obstacle_length"), self.smallest("traffic_spacing")
        if spacing <= length:
            raise ConfigError(f"crossing: traffic_spacing (down to {spacing:g} m) must exceed obstacle_length (up to "
                              f"{length:g} m): the cars of a lane would overlap")
        gap = self.smallest("traffic_gap")
        if self.largest("traffic_gap") > 0 and gap <= length:
            raise ConfigError(f"crossing: traffic_gap (down to {gap:g} m) must exceed obstacle_length (up to "
                              f"{length:g} m), or be 0 (no gap): the cars around the gap would overlap")
        width, lane = self.largest("obstacle_width"), self.smallest("traffic_lane_width")
        if self.traffic_lanes > 1 and lane <= width:
            raise ConfigError(f"crossing: traffic_lane_width (down to {lane:g} m) must exceed obstacle_width (up to "
                              f"{width:g} m): neighbouring lanes' cars would overlap")


class Crossing(Scenario):
    """The crossing scene. With ``traffic_lanes`` >= 1, constructing it gives a :class:`CrossingTraffic`
    (the one timed car's scene itself never changes a velocity, so it has no :meth:`before_step`)."""

    config_file = "scenarios/crossing.yaml"
    static_keys = ()  # no walls
    Config = CrossingConfig
    env_id = "FootstepCrossing-v0"
    vector_entry_point = "footstep_gym.jax.vector:FootstepVectorEnv"  # the batched JAX backend (footstep_gym.jax)
    sweep_axes = {}  # one setting, the YAML's (the paper's §3.2)
    command_tables = False  # the paper gives no command table for it (its Table 3 compares totals)

    def __new__(cls, cfg: Any = None, rng: Any = None) -> "Crossing":
        if cls is Crossing and getattr(cfg, "traffic_lanes", 0):
            cls = CrossingTraffic
        return super().__new__(cls)

    def __init__(self, cfg: CrossingConfig, rng: np.random.Generator) -> None:
        super().__init__(cfg, rng)
        #: The episode's uniforms (:func:`footstep_gym.scenes.crossing.draw_numpy`), its cars at 0 s and schedule.
        self.draws = scene.draw_numpy(rng, cfg)
        self.bodies, self.state = scene.start(np, scene.cell(cfg), self.draws, scene.size(cfg))
        self.members: list = []

    def build(self, world: World) -> None:
        a, b, r = scene.shape(self.cfg)
        per_lane = scene.counts(self.cfg)[1]
        for i, (p, v) in enumerate(zip(self.bodies.position.tolist(), self.bodies.velocity.tolist())):
            name = "car_{}_{}".format(*divmod(i, per_lane)) if self.cfg.traffic_lanes else "car"
            self.members.append(world.add_rod(name, tuple(p), a, b, 2 * r, velocity=tuple(v)))


class CrossingTraffic(Crossing):
    """Steady two-way traffic across the path (``traffic_lanes`` >= 1; the module's doc).

    Every car follows a schedule, :meth:`positions` (:func:`footstep_gym.scenes.crossing.positions`). Before
    each footstep the cars are put at their scheduled places (a car past the loop's end re-enters at its start)
    and keep their lane's velocity through the step, so between re-entries they move as one steady car does.
    """

    def positions(self, t: float) -> np.ndarray:
        """Car centres ``(n, 2)`` [m] at time ``t`` [s] (lane by lane, car by car)."""
        return scene.positions(np, self.state, t)

    def positions_at(self, times: np.ndarray) -> np.ndarray:
        """Car centres ``(K, n, 2)`` [m] at each of ``times (K,)`` [s]: :meth:`positions` at each, in one call (the
        same function on the schedule broadcast over the times, so the same numbers)."""
        times = np.asarray(times, dtype=float).reshape(-1, 1)
        lanes = np.broadcast_to(self.state.x, (len(times), np.size(self.state.x)))
        return scene.positions(np, self.state._replace(x=lanes), times).transpose(0, 2, 1)

    def before_step(self, world: World, t: float, duration: float, robot: RobotMotion | None = None) -> None:
        for m, p in zip(self.members, self.positions(t).tolist()):
            m.body.position = tuple(p)
