"""The scenes of the batched backend: what each one draws per episode and how its obstacles move.

One class per scene, the twin of its reference scenario (:mod:`footstep_gym.scenarios`): a
:class:`Scene` turns each tier cell's config into arrays (its ``Params``, stacked over the cells by
:class:`~footstep_gym.jax.env.FootstepJaxEnv`), draws an episode's obstacles from a JAX key
(:meth:`Scene.draw`), sets their places and velocities before a footstep (:meth:`Scene.before_step`, the reference's
``Scenario.before_step``) and reads a reference episode's start for a replay (:meth:`Scene.reference_start`).
The moving obstacles are :class:`~footstep_gym.jax.shapes.Rods`: the door's rod, the crossing's capsules, the
crowd's cylinders (a circle is a rod of zero length, the same distance in Chipmunk's arithmetic).

Every ``Params`` has the keys all scenarios share (``start``, ``start_yaw``, ``start_jitter``, ``goal``,
``goal_tolerance``, ``time_limit``, ``max_steps``). Units are the YAML's.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, NamedTuple, Union

import jax
import jax.numpy as jnp
import numpy as np

from footstep_gym.jax.shapes import Rods
from footstep_gym.scenes import PARKED, door, uniform



def _arr(x: Any, dtype: Any) -> jax.Array:
    return jnp.asarray(np.asarray(x, dtype=np.float64), dtype)


def _range(cfg: Any, key: str) -> tuple[float, float]:
    """``(lo, hi)`` of a numeric key: its ``randomize`` range, else its value twice."""
    lo, hi = cfg.randomize.get(key, (getattr(cfg, key), getattr(cfg, key)))
    return float(lo), float(hi)


def pad_to(x: Any, size: int, value: float, dtype: Any) -> jax.Array:
    """``x`` as ``dtype``, its leading axis filled up to ``size`` with ``value`` (unchanged if it has as many)."""
    x = jnp.asarray(x, dtype)
    extra = size - x.shape[0]
    return jnp.concatenate([x, jnp.full((extra,) + x.shape[1:], value, dtype)]) if extra > 0 else x


def _draw(key: jax.Array, bounds: jax.Array, dtype: Any) -> jax.Array:
    """A uniform draw in ``[lo, hi]`` (``bounds = (lo, hi)``; ``lo`` exactly where ``lo == hi``)."""
    return bounds[0] + (bounds[1] - bounds[0]) * jax.random.uniform(key, (), dtype)


class Scene:
    """A scene of the batched backend (module docstring). ``cfgs``: the tier cells' scenario configs."""

    name: ClassVar[str]
    #: The ``randomize`` keys an episode may draw (others raise ``ConfigError`` when the env is made).
    randomizable: ClassVar[tuple[str, ...]] = ()
    #: Whether :meth:`before_step` puts the bodies elsewhere than they were (then a sweep's first check sees
    #: them where pymunk last cached them: ``shapes.sweep``'s ``cached``).
    moves: ClassVar[bool] = False

    def __init__(self, cfgs: list[Any], dtype: Any) -> None:
        self.dtype = dtype

    def unsupported(self, cfg: Any) -> str | None:
        """What of a cell's config this backend does not do (a phrase), or ``None``."""
        extra = sorted(set(cfg.randomize) - set(self.randomizable))
        return f"randomize of {', '.join(extra)}" if extra else None

    def common(self, cfg: Any) -> dict[str, jax.Array]:
        dt = self.dtype
        return {"start": _arr(cfg.start, dt), "start_yaw": _arr(cfg.start_yaw, dt),
                "start_jitter": _arr(cfg.start_jitter, dt), "goal": _arr(cfg.goal, dt),
                "goal_tolerance": _arr(cfg.goal_tolerance, dt), "time_limit": _arr(cfg.time_limit, dt),
                "max_steps": jnp.asarray(cfg.max_steps, jnp.int32)}

    def cell_params(self, cfg: Any) -> Any:
        """This scene's ``Params`` of one scenario config."""
        raise NotImplementedError

    def draw(self, key: jax.Array, p: Any) -> tuple[Rods, Any]:
        """An episode's moving obstacles at 0 s and its scene state (what :meth:`before_step` reads)."""
        raise NotImplementedError

    def before_step(self, scene: Any, rods: Rods, t: jax.Array, duration: jax.Array) -> Rods:
        """The obstacles for the footstep from ``t`` to ``t + duration`` [s] (the reference's ``before_step``):
        where the scene puts them at ``t``, moving at their velocity over the step. ``rods``: where they are."""
        return rods

    @staticmethod
    def reference_start(env: Any) -> dict[str, np.ndarray]:
        """A reset reference env's (``FootstepEnv``) obstacles and draws, as numpy arrays (float64)."""
        raise NotImplementedError

    def start_from(self, start: dict[str, Any], p: Any) -> tuple[Rods, Any]:
        """:meth:`draw`'s answer for a reference episode's :meth:`reference_start` (``p``: its ``Params``)."""
        raise NotImplementedError


# ---------------------------------------------------------------------------------------------------- a scene module
class ModuleParams(NamedTuple):
    """One tier cell's settings of a scene of :mod:`footstep_gym.scenes` (leaves lead with the cell axis in
    ``FootstepJaxEnv.params``): its ``cell`` (the module's ``Cell`` as arrays), the ``(lo, hi)`` ``ranges`` of the
    keys an episode draws (its ``RANDOMIZABLE``; ``lo == hi`` where the cell does not randomize one) and the moving
    obstacles' segment in their body's frame (``a``, ``b``, ``r``)."""

    cell: Any
    ranges: dict
    a: jax.Array
    b: jax.Array
    r: jax.Array
    start: jax.Array
    start_yaw: jax.Array
    start_jitter: jax.Array
    goal: jax.Array
    goal_tolerance: jax.Array
    time_limit: jax.Array
    max_steps: jax.Array


def cell_arrays(cell: NamedTuple, dtype: Any) -> NamedTuple:
    """A scene module's ``Cell`` of plain numbers as arrays: integers int32, the rest ``dtype``."""
    def arr(v: Any) -> jax.Array:
        if isinstance(v, (bool, np.bool_)):
            return jnp.asarray(v)
        if isinstance(v, (int, np.integer)):
            return jnp.asarray(v, jnp.int32)
        return _arr(v, dtype)
    return type(cell)(*(arr(v) for v in cell))


class ModuleScene(Scene):
    """A scene whose maths is a module of :mod:`footstep_gym.scenes` (``module``): this class only draws its
    uniforms from a JAX key and holds its bodies as :class:`Rods`."""

    module: ClassVar[Any]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.randomizable, cls.moves = cls.module.RANDOMIZABLE, cls.module.MOVES

    def __init__(self, cfgs: list[Any], dtype: Any) -> None:
        super().__init__(cfgs, dtype)
        #: Moving obstacles held per env: the most of the tier's cells.
        self.size = max(self.module.size(c) for c in cfgs)

    def cell_params(self, cfg: Any) -> ModuleParams:
        dt = self.dtype
        a, b, r = self.module.shape(cfg)
        return ModuleParams(cell_arrays(self.module.cell(cfg), dt), {k: _arr(_range(cfg, k), dt) for k in
                                                                      self.randomizable},
                            _arr(a, dt), _arr(b, dt), _arr(r, dt), **self.common(cfg))

    def _rods(self, p: ModuleParams, bodies: Any) -> Rods:
        m = self.size
        return Rods(*bodies, jnp.broadcast_to(p.a, (m, 2)), jnp.broadcast_to(p.b, (m, 2)), jnp.broadcast_to(p.r, (m,)))

    def draw(self, key: jax.Array, p: ModuleParams) -> tuple[Rods, Any]:
        dt, mod = self.dtype, self.module
        shapes_ = mod.draw_shapes(self.size)
        keys = jax.random.split(key, len(self.randomizable) + len(shapes_))
        drawn = {k: uniform(p.ranges[k][0], p.ranges[k][1], jax.random.uniform(kk, (), dt))
                 for k, kk in zip(self.randomizable, keys)}
        u = type(shapes_)(*(jax.random.uniform(kk, shape, dt) for kk, shape in
                            zip(keys[len(self.randomizable):], shapes_)))
        bodies, scene = mod.start(jnp, p.cell._replace(**drawn), u, self.size)
        return self._rods(p, bodies), scene

    def before_step(self, scene: Any, rods: Rods, t: jax.Array, duration: jax.Array) -> Rods:
        moved = self.module.motion(jnp, scene, t, duration)
        if moved is None:
            return rods
        position, velocity = moved
        return rods._replace(position=position, velocity=rods.velocity if velocity is None else velocity)

    @staticmethod
    def reference_start(env: Any) -> dict[str, Any]:
        return {"draws": env.scenario.draws}

    def start_from(self, start: dict[str, Any], p: ModuleParams, cfg: Any = None) -> tuple[Rods, Any]:
        """The reference's start computed by the same function, in numpy float64 from the reference's uniforms
        (padded to :attr:`size`), then cast: the reference's obstacles and scene state bit for bit."""
        mod, m = self.module, self.size
        shapes_ = mod.draw_shapes(m)
        u = type(shapes_)(*(_pad_draw(np.asarray(x, np.float64), shape) for x, shape in zip(start["draws"], shapes_)))
        bodies, scene = mod.start(np, mod.cell(cfg), u, m)
        cast = lambda x: jnp.asarray(x, self.dtype if np.issubdtype(np.asarray(x).dtype, np.floating) else None)  # noqa: E731
        return self._rods(p, jax.tree.map(cast, bodies)), jax.tree.map(cast, scene)


def _pad_draw(x: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """A reference's uniforms ``x`` filled up to ``shape`` with 0.5 (for obstacles it does not have)."""
    out = np.full(shape, 0.5)
    out[tuple(slice(0, n) for n in x.shape)] = x
    return out


# ---------------------------------------------------------------------------------------------------- the door
class DoorScene(ModuleScene):
    """``FootstepDoor-v0`` (:mod:`footstep_gym.scenes.door`), with one door or two; a cell with one door parks
    the second rod (:data:`PARKED`, still)."""

    name = "door"
    module = door


# ---------------------------------------------------------------------------------------------------- the crowd
class CrowdParams(NamedTuple):
    """One tier cell's settings of the scripted crowd (:class:`footstep_gym.scenarios.crowd.CrowdConfig`):
    ``(lo, hi)`` pairs for the keys an episode may draw, [m], [m/s], [s], [deg]. ``size``: members in the cell
    (the env holds the tier's largest count; the others stand :data:`PARKED`)."""

    size: jax.Array
    crowd_speed: jax.Array
    crowd_accel_time: jax.Array
    breathing_amplitude: jax.Array
    angle_jitter: jax.Array
    ring_radius: jax.Array
    member_radius: jax.Array
    breathing_period: jax.Array
    start: jax.Array
    start_yaw: jax.Array
    start_jitter: jax.Array
    goal: jax.Array
    goal_tolerance: jax.Array
    time_limit: jax.Array
    max_steps: jax.Array


class CrowdState(NamedTuple):
    """An episode's scripted crowd: each member's place on the ring ``angles`` [rad], breathing ``amplitudes``
    [m], ``periods`` [s] and ``phases`` [rad] ``(M,)``, whether it is one (``active``); the ring's walk
    (``speed`` [m/s], ``accel_time`` [s], ``radius`` [m]) from ``start`` along the unit ``direction``."""

    angles: jax.Array
    amplitudes: jax.Array
    periods: jax.Array
    phases: jax.Array
    active: jax.Array
    speed: jax.Array
    accel_time: jax.Array
    radius: jax.Array
    start: jax.Array
    direction: jax.Array


class CrowdScene(Scene):
    """``FootstepCrowd-v0``'s scripted ring (:class:`footstep_gym.scenarios.crowd.Crowd`, ``crowd_model:
    scripted``): the members' places follow :meth:`positions`; before each footstep they are put at their
    places at its start and move at the chord of their schedule over it. ORCA pedestrians have no JAX version."""

    name = "crowd"
    moves = True
    randomizable = ("crowd_speed", "crowd_accel_time", "breathing_amplitude", "angle_jitter")

    def __init__(self, cfgs: list[Any], dtype: Any) -> None:
        super().__init__(cfgs, dtype)
        #: Members held per env: the largest crowd of the tier's cells.
        self.size = max(c.crowd_size for c in cfgs)

    def unsupported(self, cfg: Any) -> str | None:
        if cfg.crowd_model != "scripted":
            return f"crowd_model={cfg.crowd_model!r} (ORCA pedestrians have no JAX version)"
        return super().unsupported(cfg)

    def cell_params(self, cfg: Any) -> CrowdParams:
        dt = self.dtype
        return CrowdParams(jnp.asarray(cfg.crowd_size, jnp.int32), *(_arr(_range(cfg, k), dt) for k in self.randomizable),
                           _arr(cfg.ring_radius, dt), _arr(cfg.member_radius, dt), _arr(cfg.breathing_period, dt),
                           **self.common(cfg))

    def _walk(self, p: CrowdParams) -> tuple[jax.Array, jax.Array]:
        """The ring's start and unit direction to the goal (``Crowd.__init__``'s)."""
        gx, gy, sx, sy = p.goal[0], p.goal[1], p.start[0], p.start[1]
        d = jnp.hypot(gx - sx, gy - sy)
        safe = jnp.where(d > 0, d, 1.0)
        direction = jnp.where(d > 0, jnp.stack([(gx - sx) / safe, (gy - sy) / safe]),
                              jnp.asarray([1.0, 0.0], self.dtype))
        return p.start, direction

    def draw(self, key: jax.Array, p: CrowdParams) -> tuple[Rods, CrowdState]:
        dt, m = self.dtype, self.size
        keys = jax.random.split(key, 7)
        speed, accel, amplitude, jitter = (_draw(k, b, dt) for k, b in
                                           zip(keys[:4], (p.crowd_speed, p.crowd_accel_time, p.breathing_amplitude,
                                                          p.angle_jitter)))
        i = jnp.arange(m)
        n = p.size.astype(dt)
        angles = 2 * math.pi * i.astype(dt) / n + jnp.deg2rad(jitter) * jax.random.uniform(keys[4], (m,), dt, -1.0, 1.0)
        u = jax.random.uniform(keys[5], (3, m), dt)
        amplitudes = amplitude * (0.5 + 0.5 * u[0])
        periods = p.breathing_period[0] + (p.breathing_period[1] - p.breathing_period[0]) * u[1]
        phases = 2 * math.pi * u[2]
        start, direction = self._walk(p)
        scene = CrowdState(angles, amplitudes, periods, phases, i < p.size, speed, accel, p.ring_radius, start,
                           direction)
        return self._rods(scene, p.member_radius, self.positions(scene, jnp.zeros((), dt))), scene

    def _rods(self, scene: CrowdState, radius: jax.Array, position: jax.Array, velocity: Any = None) -> Rods:
        dt, m = self.dtype, self.size
        zero = jnp.zeros((m, 2), dt)
        return Rods(position, jnp.zeros((m,), dt), zero if velocity is None else velocity, jnp.zeros((m,), dt),
                    zero, zero, jnp.broadcast_to(radius, (m,)).astype(dt))

    def positions(self, scene: CrowdState, t: jax.Array) -> jax.Array:
        """Member centres ``(M, 2)`` [m] at time ``t`` [s] (``Crowd.positions``, operation for operation; padding
        members :data:`PARKED`)."""
        ta = scene.accel_time
        s = scene.speed * jnp.where(t < ta, 0.5 * t * t / ta, t - 0.5 * ta)
        centre = scene.start + s * scene.direction
        radius = scene.radius + scene.amplitudes * jnp.sin(2 * math.pi * t / scene.periods + scene.phases)
        heading = jnp.arctan2(scene.direction[1], scene.direction[0])
        ang = scene.angles + heading
        pos = centre + radius[:, None] * jnp.stack([jnp.cos(ang), jnp.sin(ang)], axis=1)
        return jnp.where(scene.active[:, None], pos, PARKED)

    def before_step(self, scene: CrowdState, rods: Rods, t: jax.Array, duration: jax.Array) -> Rods:
        now, then = self.positions(scene, t), self.positions(scene, t + duration)
        return rods._replace(position=now, velocity=(then - now) / duration)

    @staticmethod
    def reference_start(env: Any) -> dict[str, np.ndarray]:
        sc = env.scenario
        if sc.orca is not None:
            raise ValueError("reference_start: an ORCA crowd has no JAX version")
        members = [o.body for o in env.world.obstacles if not o.static]
        return {"angles": np.asarray(sc.angles, np.float64), "amplitudes": np.asarray(sc.amplitudes, np.float64),
                "periods": np.asarray(sc.periods, np.float64), "phases": np.asarray(sc.phases, np.float64),
                "position": np.array([tuple(b.position) for b in members], dtype=np.float64)}

    def start_from(self, start: dict[str, Any], p: CrowdParams, cfg: Any = None) -> tuple[Rods, CrowdState]:
        dt, m = self.dtype, self.size
        k = start["angles"].shape[-1]

        def pad(x: Any, value: float = 0.0) -> jax.Array:
            return pad_to(x, m, value, dt)

        start_pt, direction = self._walk(p)
        scene = CrowdState(pad(start["angles"]), pad(start["amplitudes"]), pad(start["periods"], 1.0),
                           pad(start["phases"]), jnp.arange(m) < k, p.crowd_speed[0], p.crowd_accel_time[0],
                           p.ring_radius, start_pt, direction)
        return self._rods(scene, p.member_radius, pad(start["position"], PARKED)), scene


# ---------------------------------------------------------------------------------------------------- the crossing
class CrossingParams(NamedTuple):
    """One tier cell's settings of the crossing (:class:`footstep_gym.scenarios.crossing.CrossingConfig`):
    ``(lo, hi)`` pairs for the keys an episode may draw; ``lanes`` 0 is the paper's one timed car, else the
    traffic's lanes of ``per_lane`` cars (``count`` cars in all; the env holds the tier's most, the others stand
    :data:`PARKED`). Each car is a capsule: a rod from ``(0, -half)`` to ``(0, half)`` of half thickness ``r``."""

    lanes: jax.Array
    per_lane: jax.Array
    count: jax.Array
    obstacle_speed: jax.Array
    arrival_speed: jax.Array
    timing_jitter: jax.Array
    traffic_speed: jax.Array
    traffic_gap: jax.Array
    crossing_x: jax.Array
    traffic_spacing: jax.Array
    traffic_lane_width: jax.Array
    half: jax.Array
    r: jax.Array
    start: jax.Array
    start_yaw: jax.Array
    start_jitter: jax.Array
    goal: jax.Array
    goal_tolerance: jax.Array
    time_limit: jax.Array
    max_steps: jax.Array


class CrossingState(NamedTuple):
    """An episode's traffic (``CrossingTraffic``'s draws): each car's lane line ``x`` [m], place along its loop
    at 0 s ``offset`` [m] and ``direction`` (+1: +y) ``(M,)``, the loop's length and start ``loop``, ``y0`` [m],
    the cars' ``speed`` [m/s], which of the ``M`` are cars (``active``); ``traffic``: False for the one timed car
    (it is never set before a step)."""

    x: jax.Array
    offset: jax.Array
    direction: jax.Array
    loop: jax.Array
    y0: jax.Array
    speed: jax.Array
    active: jax.Array
    traffic: jax.Array


class CrossingScene(Scene):
    """``FootstepCrossing-v0`` (:class:`footstep_gym.scenarios.crossing.Crossing`): the paper's one timed car
    (``traffic_lanes: 0``), or lanes of cars on loops (``CrossingTraffic``), put at their scheduled places
    before each footstep (a car past its loop's end re-enters at its start) and driving at their lane's
    velocity through it."""

    name = "crossing"
    moves = True
    randomizable = ("obstacle_speed", "arrival_speed", "timing_jitter", "traffic_speed", "traffic_gap")

    def __init__(self, cfgs: list[Any], dtype: Any) -> None:
        super().__init__(cfgs, dtype)
        #: Cars held per env: the most of the tier's cells.
        self.size = max(self._counts(c)[2] for c in cfgs)

    @staticmethod
    def _counts(cfg: Any) -> tuple[int, int, int]:
        """``(lanes, cars per lane, cars)`` of a config (``CrossingTraffic.__init__``'s rule)."""
        if not cfg.traffic_lanes:
            return 0, 1, 1
        per_lane = max(1, math.ceil(2.0 * cfg.traffic_extent / cfg.traffic_spacing - 1e-9))
        return cfg.traffic_lanes, per_lane, cfg.traffic_lanes * per_lane

    def cell_params(self, cfg: Any) -> CrossingParams:
        dt = self.dtype
        lanes, per_lane, count = self._counts(cfg)
        return CrossingParams(jnp.asarray(lanes, jnp.int32), jnp.asarray(per_lane, jnp.int32),
                              jnp.asarray(count, jnp.int32), *(_arr(_range(cfg, k), dt) for k in self.randomizable),
                              _arr(cfg.crossing_x, dt), _arr(cfg.traffic_spacing, dt), _arr(cfg.traffic_lane_width, dt),
                              _arr(0.5 * (cfg.obstacle_length - cfg.obstacle_width), dt),
                              _arr(0.5 * cfg.obstacle_width, dt), **self.common(cfg))

    def _rods(self, p: CrossingParams, position: jax.Array, velocity: jax.Array) -> Rods:
        dt, m = self.dtype, self.size
        zero = jnp.zeros((m,), dt)
        a = jnp.broadcast_to(jnp.stack([jnp.zeros((), dt), -p.half]), (m, 2))
        b = jnp.broadcast_to(jnp.stack([jnp.zeros((), dt), p.half]), (m, 2))
        return Rods(position, zero, velocity, zero, a, b, jnp.broadcast_to(p.r, (m,)).astype(dt))

    def draw(self, key: jax.Array, p: CrossingParams) -> tuple[Rods, CrossingState]:
        dt, m = self.dtype, self.size
        keys = jax.random.split(key, 7)
        obstacle_speed, arrival_speed, jitter, speed, gap = (_draw(k, b, dt) for k, b in
                                                             zip(keys[:5], (p.obstacle_speed, p.arrival_speed,
                                                                            p.timing_jitter, p.traffic_speed,
                                                                            p.traffic_gap)))
        sx, sy = p.start[0], p.start[1]
        i = jnp.arange(m)
        active = i < p.count
        # The traffic (CrossingTraffic.__init__): lane k, car j; each lane's phase anywhere in its repeating unit.
        k, j = i // p.per_lane, i % p.per_lane
        loop = (p.per_lane - 1).astype(dt) * p.traffic_spacing + jnp.where(gap > 0, gap, p.traffic_spacing)
        x = sx + p.crossing_x + (k.astype(dt) - 0.5 * (p.lanes - 1).astype(dt)) * p.traffic_lane_width
        direction = jnp.where(k % 2 == 0, 1.0, -1.0).astype(dt)
        phases = jax.random.uniform(keys[5], (m,), dt) * jnp.where(gap > 0, loop, p.traffic_spacing)
        offset = phases[k] + j.astype(dt) * p.traffic_spacing
        traffic = p.lanes > 0
        scene = CrossingState(x, offset, direction, loop, sy - 0.5 * loop, speed, active, traffic)
        # The one timed car (Crossing.build): it meets a robot walking at arrival_speed, +- the jitter.
        t_meet = p.crossing_x / arrival_speed + jax.random.uniform(keys[6], (), dt, -1.0, 1.0) * jitter
        car = jnp.stack([sx + p.crossing_x, sy - obstacle_speed * t_meet])
        timed = jnp.zeros((m, 2), dt).at[0].set(car)
        position = jnp.where(traffic, self.positions(scene, jnp.zeros((), dt)), timed)
        vy = jnp.where(traffic, direction * speed, obstacle_speed)
        velocity = jnp.stack([jnp.zeros((m,), dt), vy], axis=1)
        return self._park(p, position, velocity, active), scene

    def _park(self, p: CrossingParams, position: jax.Array, velocity: jax.Array, active: jax.Array) -> Rods:
        return self._rods(p, jnp.where(active[:, None], position, PARKED), jnp.where(active[:, None], velocity, 0.0))

    @staticmethod
    def positions(scene: CrossingState, t: jax.Array) -> jax.Array:
        """Car centres ``(M, 2)`` [m] at time ``t`` [s] (``CrossingTraffic.positions``, operation for operation)."""
        along = jnp.mod(scene.offset + scene.direction * scene.speed * t, scene.loop)
        return jnp.stack([scene.x, scene.y0 + along], axis=1)

    def before_step(self, scene: CrossingState, rods: Rods, t: jax.Array, duration: jax.Array) -> Rods:
        now = jnp.where(scene.active[:, None], self.positions(scene, t), PARKED)
        return rods._replace(position=jnp.where(scene.traffic, now, rods.position))

    @staticmethod
    def reference_start(env: Any) -> dict[str, np.ndarray]:
        sc = env.scenario
        bodies = [o.body for o in env.world.obstacles if not o.static]
        out = {"position": np.array([tuple(b.position) for b in bodies], dtype=np.float64),
               "velocity": np.array([tuple(b.velocity) for b in bodies], dtype=np.float64)}
        if hasattr(sc, "offset"):  # the traffic's draws
            out.update(x=np.asarray(sc.x, np.float64), offset=np.asarray(sc.offset, np.float64),
                       direction=np.asarray(sc.direction, np.float64), loop=np.float64(sc.loop),
                       y0=np.float64(sc.y0))
        return out

    def start_from(self, start: dict[str, Any], p: CrossingParams, cfg: Any = None) -> tuple[Rods, CrossingState]:
        dt, m = self.dtype, self.size
        n = start["position"].shape[0]

        def pad(x: Any, value: float = 0.0) -> jax.Array:
            return pad_to(x, m, value, dt)

        traffic = "offset" in start
        zeros = np.zeros(n)
        scene = CrossingState(pad(start.get("x", zeros)), pad(start.get("offset", zeros)),
                              pad(start.get("direction", zeros)), jnp.asarray(start.get("loop", 1.0), dt),
                              jnp.asarray(start.get("y0", 0.0), dt), p.traffic_speed[0], jnp.arange(m) < n,
                              jnp.asarray(traffic))
        return self._park(p, pad(start["position"]), pad(start["velocity"]), scene.active), scene


SCENES: dict[str, type[Scene]] = {cls.name: cls for cls in (DoorScene, CrossingScene, CrowdScene)}
#: Any scene's ``Params``.
SceneParams = Union[ModuleParams, CrossingParams, CrowdParams]
DoorParams = ModuleParams
