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

``crowd_model: orca`` replaces the schedule with reactive pedestrians, as crowd-navigation
benchmarks (CrowdNav, CrowdNav++, SocNavGym) move them: ORCA through ``pyrvo``
(:mod:`footstep_gym.scenarios.orca`), each pedestrian with its own preferred speed, radius and
goal drawn per episode, seeing the robot or not (``robot_visible``), in one of the
``crowd_layout`` s: ``ring`` (the ring around the robot, walking with it to the goal),
``counter_flow`` (lanes walking at the robot from the goal side), ``crossing_flows`` (two
streams crossing its path, from the left and from the right) and ``closing_in`` (a ring whose
members head for points on the robot's path). Their chord over each footstep is their velocity
there; a planner's constant-velocity prediction misses how they react (docs/model.md §4.5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from footstep_gym.config import interval, nonnegative, pair, plain, positive
from footstep_gym.errors import ConfigError
from footstep_gym.scenarios.base import RobotMotion, Scenario, ScenarioConfig
from footstep_gym.scenarios.orca import OrcaCrowd, OrcaParams, require_pyrvo
from footstep_gym.scenes import crowd as scene
from footstep_gym.world import World

CROWD_MODELS = ("scripted", "orca")
CROWD_LAYOUTS = ("ring", "counter_flow", "crossing_flows", "closing_in")


@dataclass(frozen=True)
class CrowdConfig(ScenarioConfig):
    crowd_size: int = positive(default=8)  # cylinders on the ring
    crowd_speed: float = nonnegative(max_key="max_crowd_speed", unit="m/s", default=0.16)  # [m/s] mean speed along the start -> goal direction
    crowd_accel_time: float = positive(default=4.0)  # [s] to reach crowd_speed from rest (constant acceleration)
    ring_radius: float = positive(default=0.36)  # [m] member centres from the ring's centre
    member_radius: float = positive(default=0.08)  # [m]
    breathing_amplitude: float = nonnegative(default=0.04)  # [m] largest radial oscillation of a member
    breathing_period: tuple[float, float] = interval(default=(3.0, 6.0))  # [s] range each member's period is drawn from
    angle_jitter: float = nonnegative(default=8.0)  # [deg] uniform +- on each member's place on the ring
    max_crowd_speed: float = positive(default=2.0)  # [m/s] largest crowd_speed accepted (randomize ranges included)
    max_breathing_speed: float = positive(default=1.0)  # [m/s] largest radial breathing speed 2 pi amplitude / shortest period
    # The model; the keys below are the ORCA crowd's (crowd_size, ring_radius and angle_jitter serve it too).
    crowd_model: str = plain(default="scripted")  # "scripted" (the ring on its schedule) or "orca" (reactive pedestrians, pyrvo)
    crowd_layout: str = plain(default="ring")  # orca: "ring", "counter_flow", "crossing_flows" or "closing_in"; scripted: "ring"
    robot_visible: bool = plain(default=True)  # orca: the robot is an ORCA agent the pedestrians avoid (CrowdNav's robot.visible)
    pedestrian_speed: tuple[float, float] = interval(default=(0.12, 0.2))  # [m/s] range each one's preferred (= ORCA max) speed is drawn from
    pedestrian_radius: tuple[float, float] = interval(default=(0.07, 0.09))  # [m] range each one's radius is drawn from
    orca_time_step: float = positive(default=0.1)  # [s] longest ORCA step: a footstep runs in equal steps no longer
    orca_neighbor_dist: float = positive(default=2.0)  # [m] others farther (centre to centre) are not considered
    orca_max_neighbors: int = positive(default=10)  # the nearest this many others are considered
    orca_time_horizon: float = positive(default=5.0)  # [s] velocities are chosen collision-free for this long
    orca_safety_space: float = nonnegative(default=0.01)  # [m] added to every radius ORCA sees (not to the bodies)
    orca_robot_margin: float = nonnegative(default=0.03)  # [m] robot_visible: added to the robot's radius ORCA sees (its CoM sway)
    closing_radius: float = positive(default=1.2)  # [m] closing_in: the ring around the start the members start on
    closing_goal_along: tuple[float, float] = interval(default=(0.4, 2.4))  # [m] closing_in: range of a goal's distance along the path
    closing_goal_spread: float = nonnegative(default=0.15)  # [m] closing_in: uniform +- of a goal sideways off the path
    flow_lanes: int = positive(default=3)  # flows: lanes per stream (crowd_size pedestrians dealt over the lanes)
    lane_width: float = positive(default=0.35)  # [m] flows: between neighbouring lanes' centre lines
    flow_spacing: float = positive(default=0.8)  # [m] flows: between consecutive pedestrians of a lane
    flow_ahead: float = positive(default=1.0)  # [m] flows: a lane's first pedestrian from the start (counter) / the path (crossing)
    flow_behind: float = positive(default=1.0)  # [m] flows: goals this far past the start (counter) / the path (crossing)
    flow_jitter: float = nonnegative(default=0.15)  # [m] flows: uniform +- along its lane on each pedestrian's place
    crossing_points: tuple[float, float] = pair(default=(1.0, 2.0))  # [m] crossing_flows: along the path, where the left / right stream crosses
    # The keys every scenario has, at this scene's values (ScenarioConfig's defaults are generic).
    start_jitter: float = nonnegative(default=0.0)
    goal: tuple[float, float] = pair(default=(3.0, 0.0))
    goal_tolerance: float = positive(default=0.12)
    time_limit: float = positive(default=40.0)

    def validate(self) -> None:
        super().validate()
        self._validate_model()
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

    def _validate_model(self) -> None:
        """``crowd_model`` / ``crowd_layout`` known; the pedestrians' ranges within bounds; no two overlapping at 0 s."""
        if self.crowd_model not in CROWD_MODELS:
            raise ConfigError(f"crowd: unknown crowd_model {self.crowd_model!r}; known: {', '.join(CROWD_MODELS)}")
        if self.crowd_layout not in CROWD_LAYOUTS:
            raise ConfigError(f"crowd: unknown crowd_layout {self.crowd_layout!r}; known: {', '.join(CROWD_LAYOUTS)}")
        if self.crowd_model == "scripted" and self.crowd_layout != "ring":
            raise ConfigError(f"crowd: crowd_layout={self.crowd_layout!r} needs crowd_model='orca' (the scripted "
                              "crowd is the ring)")
        lo, hi = self.pedestrian_speed
        if lo < 0:
            raise ConfigError(f"crowd: pedestrian_speed must be >= 0, got {self.pedestrian_speed}")
        if hi > self.max_crowd_speed:
            raise ConfigError(
                f"CrowdConfig: pedestrian_speed reaches {hi:g} m/s, above max_crowd_speed={self.max_crowd_speed:g} m/s "
                "(the collision sweep's cost grows with it; raise max_crowd_speed to allow more, at a cost per step)")
        if self.pedestrian_radius[0] <= 0:
            raise ConfigError(f"crowd: pedestrian_radius must be > 0, got {self.pedestrian_radius}")
        if self.crowd_model != "orca":
            return
        require_pyrvo()  # a missing optional dependency is a clear error at gym.make, not at the first reset
        r = self.pedestrian_radius[1]
        n = self.crowd_size
        if self.crowd_layout in ("ring", "closing_in"):
            key = "ring_radius" if self.crowd_layout == "ring" else "closing_radius"
            radius = getattr(self, key)
            half_gap = math.pi / n - math.radians(self.angle_jitter)  # half the smallest angle between neighbours
            if radius <= r or (n > 1 and (half_gap <= 0 or 2 * radius * math.sin(min(half_gap, math.pi / 2)) < 2 * r)):
                raise ConfigError(
                    f"crowd: {key}={radius:g} m with crowd_size={n} and angle_jitter={self.angle_jitter:g} deg leaves "
                    f"pedestrians of pedestrian_radius up to {r:g} m overlapping (each other or the ring's centre)")
        else:
            if self.flow_spacing - 2 * self.flow_jitter < 2 * r:
                raise ConfigError(f"crowd: flow_spacing - 2 flow_jitter = {self.flow_spacing - 2 * self.flow_jitter:g} m "
                                  f"is below 2 x pedestrian_radius[1] = {2 * r:g} m: neighbours in a lane overlap")
            if self.flow_lanes > 1 and self.lane_width < 2 * r:
                raise ConfigError(f"crowd: lane_width={self.lane_width:g} m is below 2 x pedestrian_radius[1] = {2 * r:g} m")
            if self.flow_ahead - self.flow_jitter <= r:
                raise ConfigError(f"crowd: flow_ahead - flow_jitter = {self.flow_ahead - self.flow_jitter:g} m leaves a "
                                  f"pedestrian of radius {r:g} m on the robot's "
                                  f"{'start' if self.crowd_layout == 'counter_flow' else 'path'}")


class Crowd(Scenario):
    config_file = "scenarios/crowd.yaml"
    static_keys = ()  # no walls
    Config = CrowdConfig
    env_id = "FootstepCrowd-v0"
    sweep_axes = {"crowd_speed": "m/s"}
    vector_entry_point = "footstep_gym.jax.vector:FootstepVectorEnv"  # the batched JAX backend (ORCA: robot invisible)

    def __init__(self, cfg: CrowdConfig, rng: np.random.Generator) -> None:
        super().__init__(cfg, rng)
        n = cfg.crowd_size
        gx, gy = cfg.goal
        sx, sy = cfg.start
        d = math.hypot(gx - sx, gy - sy)
        self.direction = np.array([(gx - sx) / d, (gy - sy) / d]) if d > 0 else np.array([1.0, 0.0])
        self.members: list = []
        self.orca: OrcaCrowd | None = None  # built with the world (the robot's radius is the world's)
        if cfg.crowd_model == "orca":
            #: The episode's uniforms (:func:`footstep_gym.scenes.crowd.orca_draw_numpy`) and each pedestrian's
            #: radius, preferred speed, start and goal (:func:`footstep_gym.scenes.crowd.orca_layout`).
            self.draws = scene.orca_draw_numpy(rng, cfg)
            self.radii, self.speeds, self.starts, self.goals = scene.orca_layout(np, scene.orca_cell(cfg), self.draws, n)
            self._clock = 0.0
            return
        #: The episode's uniforms (:func:`footstep_gym.scenes.crowd.draw_numpy`), its members at 0 s and its ring.
        self.draws = scene.draw_numpy(rng, cfg)
        self.bodies, self.state = scene.start(np, scene.cell(cfg), self.draws, n)

    def centre(self, t: float) -> np.ndarray:
        """Ring centre at time ``t`` [s]."""
        return scene.centre(np, self.state, t)

    def positions(self, t: float) -> np.ndarray:
        """Member centres ``(n, 2)`` [m] at time ``t`` [s]."""
        return scene.positions(np, self.state, t)

    def positions_at(self, times: np.ndarray) -> np.ndarray:
        """Member centres ``(K, n, 2)`` [m] at each of ``times (K,)`` [s]: :meth:`positions` at each, in one call (the
        same function on the schedule broadcast over the times, so the same numbers)."""
        return scene.positions(np, self.state, np.asarray(times, dtype=float).reshape(-1, 1))

    def build(self, world: World) -> None:
        c = self.cfg
        if c.crowd_model == "orca":
            params = OrcaParams(c.orca_time_step, c.orca_neighbor_dist, c.orca_max_neighbors, c.orca_time_horizon,
                                c.orca_safety_space)
            self.orca = OrcaCrowd(self.starts.tolist(), self.goals.tolist(), self.radii.tolist(), self.speeds.tolist(),
                                  params, world.robot_radius + c.orca_robot_margin if c.robot_visible else None)
            for i, (p, r) in enumerate(zip(self.orca.positions, self.orca.radii)):
                self.members.append(world.add_circle(f"member_{i}", p, r))
            return
        for i, p in enumerate(self.bodies.position.tolist()):
            self.members.append(world.add_circle(f"member_{i}", tuple(p), self.cfg.member_radius))

    def before_step(self, world: World, t: float, duration: float, robot: RobotMotion | None = None) -> None:
        if self.orca is not None:
            # ORCA runs footstep after footstep from where it stopped: t must be where the last footstep ended.
            if abs(t - self._clock) > 1e-9 * max(1.0, abs(t)):
                raise RuntimeError(f"crowd (orca): before_step at t={t!r} s, but the crowd stands at {self._clock!r} s; "
                                   "ORCA pedestrians advance footstep by footstep")
            if robot is None:
                now, chords = self.orca.advance(duration)
            else:
                now, chords = self.orca.advance(duration, robot.position, robot.velocity)
            self._clock = t + duration
            for m, p, v in zip(self.members, now, chords):
                m.body.position = p
                m.body.velocity = v
            return
        now, chord = scene.before_step(np, self.state, None, None, t, duration)
        for m, p, v in zip(self.members, now.tolist(), chord.tolist()):
            m.body.position = tuple(p)
            m.body.velocity = tuple(v)
