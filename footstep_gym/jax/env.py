"""``FootstepJaxEnv``: the footstep envs as pure JAX functions over a state pytree (gymnax / Brax style).

``reset(key, params) -> (state, obs)`` and ``step(state, action, params) -> (state, obs, reward, terminated,
truncated, info)`` are jittable and vmappable: one env's arrays in, one env's arrays out; ``jax.vmap`` makes a
batch. The reference env (:class:`footstep_gym.env.FootstepEnv`, pymunk) is the spec and the judge: the same
action box and float32 handling, the same observation layout, reward terms, terminations and truncations
(docs/model.md), shown by replaying its episodes (:mod:`footstep_gym.jax.replay`).

Supported (the scenes of :mod:`footstep_gym.jax.scenes`, each with the ``randomize`` keys it lists):
``FootstepDoor-v0`` with one door or two, ``FootstepCrossing-v0`` (the timed car and the traffic lanes) and
``FootstepCrowd-v0``'s scripted ring (any size and ring), every other setting of their YAMLs including the
sensing options (noise, range, field of view: :mod:`footstep_gym.jax.sensing`, the noise drawn from the state's
key), and the tiers whose cells are such: every tier of the door, ``paper``, ``train``, ``shifted`` and ``noise``
of the crossing and the crowd, and the structure tier's cells but the ORCA crowd's by ``tier_cell``. Cells with
different walls (one door and two) each have their own (:meth:`FootstepJaxEnv.walls_of`). Anything else (the
ORCA crowd, ``fixed_period``, a tier whose cells sense differently) raises
:class:`~footstep_gym.errors.ConfigError` in one line naming it.

Precision: float32 by default; ``dtype="float64"`` needs JAX's 64-bit mode (``JAX_ENABLE_X64=1`` or
``jax.config.update("jax_enable_x64", True)`` before any array is made).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from footstep_gym import footstep, lipm, tiers
from footstep_gym.action import action_limits
from footstep_gym.env import FootstepEnv
from footstep_gym.errors import ConfigError
from footstep_gym.footstep import RIGHT
from footstep_gym.jax import shapes, walker
from footstep_gym.jax.scenes import (PARKED, SCENES, DoorParams, Scene,  # noqa: F401  (DoorParams re-exported)
                                     SceneParams, pad_to)
from footstep_gym.jax.sensing import Sensing, sense
from footstep_gym.observation import ObservationScales, command_to_unit, observations
from footstep_gym.world import World

#: Termination codes of ``info["termination"]`` (0: none): the reference's names in this order.
TERMINATION_CODES = {"goal": 1, "collision": 2, "fall": 3}
#: The scenes supported (:data:`footstep_gym.jax.scenes.SCENES`).
SUPPORTED_SCENES = tuple(SCENES)
#: The reward terms of ``info["rewards"]``, in the reference's order (their sum is the reward).
REWARD_TERMS = ("progress", "time", "step", "goal", "collision", "fall")


class State(NamedTuple):
    """One env's state. Feet ``(2, 3)``: row 0 the right foot, row 1 the left, ``(x, y, yaw)`` [m, rad];
    ``support``: +1 left, -1 right; CoM position [m] and velocity [m/s] in the world; ``previous``: the last
    command applied; ``goal_dist``: the robot centre's distance to the goal [m] now; ``rods``: the moving
    obstacles now; ``scene``: the episode's draws its scene moves them by (:mod:`footstep_gym.jax.scenes`)."""

    key: jax.Array
    feet: jax.Array
    support: jax.Array
    com: jax.Array
    com_vel: jax.Array
    time: jax.Array
    steps: jax.Array
    previous: jax.Array
    goal_dist: jax.Array
    rods: shapes.Rods
    scene: Any
    goal: jax.Array
    goal_tolerance: jax.Array
    time_limit: jax.Array
    max_steps: jax.Array
    cell: jax.Array


def _unsupported(what: str) -> ConfigError:
    scenes = "; ".join(f"{name} (randomize of {', '.join(cls.randomizable)})" for name, cls in SCENES.items())
    return ConfigError(f"FootstepJaxEnv: {what} is not supported by the batched JAX backend yet (supported: "
                       f"{scenes}; the scripted crowd); use the reference env")


def _dtype(dtype: Any) -> Any:
    dt = jnp.dtype(dtype)
    if dt not in (jnp.dtype(jnp.float32), jnp.dtype(jnp.float64)):
        raise ConfigError(f"FootstepJaxEnv: dtype must be 'float32' or 'float64', got {dtype!r}")
    if dt == jnp.dtype(jnp.float64) and not jax.config.jax_enable_x64:
        raise ConfigError("FootstepJaxEnv: dtype='float64' needs JAX's 64-bit mode: set JAX_ENABLE_X64=1 or call "
                          "jax.config.update('jax_enable_x64', True) before making the env")
    return dt


class FootstepJaxEnv:
    """A footstep scene as pure functions (module docstring); ``env_kwargs`` as for ``gymnasium.make``.

    ``block``: collision checks evaluated per iteration of the sweep (:mod:`footstep_gym.jax.shapes`; the
    answers do not depend on it). ``action_space`` and ``observation_space`` are the reference env's.
    """

    def __init__(self, scenario: str = "door", *, dtype: Any = "float32", tier: str | None = None,
                 tier_cell: str | None = None, block: int = shapes.DEFAULT_BLOCK, **env_kwargs: Any) -> None:
        if scenario not in SCENES:
            raise _unsupported(f"scene {scenario!r}")
        if "render_mode" in env_kwargs:
            raise _unsupported("render_mode")
        self.dtype = _dtype(dtype)
        if not (isinstance(block, int) and block >= 1):
            raise ConfigError(f"FootstepJaxEnv: block must be an integer >= 1, got {block!r}")
        self.block = block
        ref = tiers.make_env(scenario, tier=tier, tier_cell=tier_cell, **env_kwargs)  # validates every cell
        self.scenario, self.tier, self.cells = scenario, ref.tier, list(ref.cells)
        self.robot = robot = ref.robot
        self.config = env_cfg = ref.config
        self.action_space, self.observation_space = ref.action_space, ref.observation_space
        dt = self.dtype
        #: The scene's arrays and moves (:mod:`footstep_gym.jax.scenes`).
        self.scene: Scene = SCENES[scenario]([cfg for cfg, _ in ref._cell_configs], dt)
        options = {Sensing.of(ecfg) if ecfg.sensing_limited else None for _, ecfg in ref._cell_configs}
        if len(options) > 1:
            raise _unsupported(f"tier {self.tier!r}: cells with different sensing options")
        #: The sensing options (noise, range, field of view; :mod:`footstep_gym.jax.sensing`), ``None`` when off.
        self.sensing: Sensing | None = options.pop()
        for cell, (cfg, ecfg) in zip(self.cells, ref._cell_configs):
            if ecfg.fixed_period:
                raise _unsupported("fixed_period")
            what = self.scene.unsupported(cfg)
            if what:
                raise _unsupported(f"tier cell {cell!r}: {what}")
        self._build_walls(ref, env_cfg, robot)
        cells = [self.cell_params(cfg) for cfg, _ in ref._cell_configs]
        self.params: SceneParams = jax.tree.map(lambda *x: jnp.stack(x), *cells)
        # The action box, its float32-rounded limits, and the nominal command (the previous one after reset).
        limits = action_limits(robot)
        self.low, self.high = limits.low, limits.high
        self._limits = [pins.tolist() for pins in limits.pins]  # the values a float32 action is pinned at
        com_local, vel_local = lipm.steady_state(robot, robot.nominal_command, RIGHT)
        self._start_com = (com_local, vel_local)
        self.obs_size = int(self.observation_space.shape[0])
        ref.close()

    def _build_walls(self, ref: FootstepEnv, env_cfg: Any, robot: Any) -> None:
        """The static walls of each cell (the reference scenario's ``build_static``). Cells that share their walls
        (one ``static_key``) share one table; otherwise each cell has its own, padded to the most walls of any
        cell with walls of zero length :data:`PARKED` away (beyond the sweep's horizon and the sensing range)."""
        cls, dt = ref._scenario_cls, self.dtype
        by_key: dict[Any, tuple[shapes.Walls, list[str]]] = {}
        cell_keys = []
        for cfg, _ in ref._cell_configs:
            key = cls.static_key(cfg)
            if key not in by_key:
                world = World(robot.body_radius, env_cfg.collision_slop, env_cfg.max_check_interval,
                              env_cfg.collision_motion_fraction, env_cfg.max_sweep_checks, compiled=False)
                cls(cfg, np.random.default_rng(0)).build_static(world)
                by_key[key] = (shapes.walls_of(world, dt), [o.name for o in world.obstacles if o.static])
            cell_keys.append(key)
        #: The names of each cell's walls, in the order of ``info["obstacle"]``'s indices (walls first, then rods).
        self.wall_names = [by_key[k][1] for k in cell_keys]
        #: Each cell's wall count.
        self.wall_counts = jnp.asarray([len(names) for names in self.wall_names], jnp.int32)
        if len(by_key) == 1:
            self.walls = by_key[cell_keys[0]][0]
            self.wall_table = shapes.wall_table(self.walls)
            self.per_cell_walls = False
            return
        width = max(len(names) for names in self.wall_names)

        def pad(walls: shapes.Walls) -> shapes.Walls:
            return shapes.Walls(pad_to(walls.a, width, PARKED, dt), pad_to(walls.b, width, PARKED, dt),
                                pad_to(walls.r, width, 0.0, dt))

        #: The walls ``(W, ...)``; with per-cell walls (:attr:`per_cell_walls`), each cell's ``(C, W, ...)``.
        self.walls = jax.tree.map(lambda *x: jnp.stack(x), *(pad(by_key[k][0]) for k in cell_keys))
        self.wall_table = jax.vmap(shapes.wall_table)(self.walls)
        self.per_cell_walls = True

    def walls_of(self, cell: jax.Array) -> tuple[shapes.Walls, jax.Array]:
        """The walls and the sweep's wall table of tier cell ``cell`` (an index)."""
        if not self.per_cell_walls:
            return self.walls, self.wall_table
        return jax.tree.map(lambda x: x[cell], self.walls), self.wall_table[cell]

    # ------------------------------------------------------------------ settings
    def cell_params(self, cfg: Any) -> SceneParams:
        """The scene's params (:mod:`footstep_gym.jax.scenes`) of one scenario config (a ``DoorConfig``,
        ``CrossingConfig`` or ``CrowdConfig``)."""
        return self.scene.cell_params(cfg)

    @property
    def default_params(self) -> SceneParams:
        """Every tier cell's settings, stacked (a reset draws one cell uniformly; one cell: no draw)."""
        return self.params

    # ------------------------------------------------------------------ reset
    def reset(self, key: jax.Array, params: SceneParams | None = None) -> tuple[State, jax.Array]:
        """A new episode from ``key``: ``(state, observation)``. The episode's draws (cell, randomize keys, the
        obstacles' placement, start jitter) come from ``key``; they are not the reference env's numpy draws for
        a seed."""
        params = self.params if params is None else params
        dt = self.dtype
        key, k_cell, k_scene, k_start = jax.random.split(key, 4)
        n_cells = params.max_steps.shape[0]
        cell = jax.random.randint(k_cell, (), 0, n_cells) if n_cells > 1 else jnp.zeros((), jnp.int32)
        p = jax.tree.map(lambda x: x[cell], params)
        rods, scene = self.scene.draw(k_scene, p)
        jitter = p.start_jitter * jax.random.uniform(k_start, (2,), dt, -1.0, 1.0)
        centre = (p.start[0] + jitter[0], p.start[1] + jitter[1])
        half = 0.5 * self.robot.nominal_side_stride
        feet = jnp.stack([jnp.stack(footstep.foot_from_node(centre, p.start_yaw, side, half, xp=jnp))
                          for side in (RIGHT, -RIGHT)])
        return self.start_state(key, feet, rods, scene, p, cell)

    def start_state(self, key: jax.Array, feet: jax.Array, rods: shapes.Rods, scene: Any,
                    p: SceneParams, cell: jax.Array) -> tuple[State, jax.Array]:
        """The state (and observation) of an episode that starts with these feet, obstacles and scene draws:
        the robot on its right foot, its CoM in the steady gait of stepping in place (``FootstepEnv.reset``)."""
        dt = self.dtype
        com_local, vel_local = self._start_com
        support = feet[0]
        c, s = jnp.cos(support[2]), jnp.sin(support[2])
        rot = c + 1j * s
        com = support[0] + 1j * support[1] + complex(com_local) * rot
        vel = complex(vel_local) * rot
        zero = jnp.zeros((), dt)
        state = State(key, feet.astype(dt), jnp.asarray(RIGHT, jnp.int32), jnp.stack([com.real, com.imag]).astype(dt),
                      jnp.stack([vel.real, vel.imag]).astype(dt), zero, jnp.zeros((), jnp.int32),
                      jnp.asarray(self.robot.nominal_command, dt), self._goal_distance(feet, p.goal), rods, scene,
                      p.goal, p.goal_tolerance, p.time_limit, p.max_steps, jnp.asarray(cell, jnp.int32))
        state, k_obs = self._noise_key(state)
        return state, self.observation(state, k_obs)

    def _noise_key(self, state: State) -> tuple[State, jax.Array | None]:
        """The key of an observation's sensing noise, split off the state's (``None``, the state unchanged, when
        there is no noise)."""
        if self.sensing is None or not self.sensing.noisy:
            return state, None
        key, k_obs = jax.random.split(state.key)
        return state._replace(key=key), k_obs

    @staticmethod
    def _goal_distance(feet: jax.Array, goal: jax.Array) -> jax.Array:
        cx, cy = 0.5 * (feet[1, 0] + feet[0, 0]), 0.5 * (feet[1, 1] + feet[0, 1])
        return jnp.hypot(cx - goal[0], cy - goal[1])

    # ------------------------------------------------------------------ step
    def command(self, action: jax.Array) -> tuple[jax.Array, jax.Array]:
        """The command ``(5,)`` an action stands for, and whether it was clipped (``FootstepEnv``'s rule): a
        float32 action equal to a limit rounded to float32 is that limit; then each field is clipped to the
        box. A NaN field stays NaN, and the step is then a fall (the numpy vector env refuses it before)."""
        a = jnp.asarray(action)
        if a.shape != (5,):
            raise ValueError(f"FootstepJaxEnv.step: action shape={a.shape} but expected (5,) = [S, L, theta, "
                             f"T_SS, T_DS]")
        values = a.astype(self.dtype)
        if a.dtype == jnp.float32 and self.dtype == jnp.float64:
            snapped = []
            for i, limits in enumerate(self._limits):
                v = values[i]
                for exact in reversed(limits):  # of limits that round alike, the lowest wins
                    v = jnp.where(values[i] == float(np.float32(exact)), exact, v)
                snapped.append(v)
            values = jnp.stack(snapped)
        low, high = jnp.asarray(self.low, self.dtype), jnp.asarray(self.high, self.dtype)
        cmd = jnp.where(values < low, low, jnp.where(values > high, high, values))
        return cmd, jnp.any(cmd != values)

    def step(self, state: State, action: jax.Array, params: SceneParams | None = None
             ) -> tuple[State, jax.Array, jax.Array, jax.Array, jax.Array, dict[str, jax.Array]]:
        """One footstep: ``(state, obs, reward, terminated, truncated, info)`` (``FootstepEnv.step``).

        ``info``: ``termination`` (0 none, 1 goal, 2 collision, 3 fall), ``is_success``, ``feasible``,
        ``collision``, ``clipped``, ``command``, ``time`` [s], ``period`` [s], ``steps``, ``zmp_offset``
        [m], ``zmp_margin`` [m], ``clearance`` [m] (NaN on a fall), ``checks``, ``obstacle`` (index of the
        shape hit: its index among the cell's walls, then the rods; -1 if none), ``rewards`` (the terms of
        :data:`REWARD_TERMS`), ``cell`` (the episode's tier cell, an index into :attr:`cells`).
        """
        del params  # the episode's settings are in the state
        robot, cfg, dt = self.robot, self.config, self.dtype
        cmd, clipped = self.command(action)
        side = state.support
        sidx = (side + 1) // 2
        support = state.feet[sidx]
        c, s = jnp.cos(support[2]), jnp.sin(support[2])
        rot, unrot = c + 1j * s, c - 1j * s
        origin = support[0] + 1j * support[1]
        com = state.com[0] + 1j * state.com[1]
        vel = state.com_vel[0] + 1j * state.com_vel[1]
        com_local, vel_local = (com - origin) * unrot, vel * unrot
        v = walker.verdict(robot, com_local, vel_local, cmd, side)
        feasible = v.kinematic_ok & v.zmp_ok
        hx, hy = robot.zmp_half_extent
        zmp_margin = jnp.minimum(hx - jnp.abs(v.p.real), hy - jnp.abs(v.p.imag))
        period = cmd[3] + cmd[4]
        path, bound = walker.path_of(robot, v, cmd, side, origin, rot)
        rods = self.scene.before_step(state.scene, state.rods, state.time, period)
        walls, table = self.walls_of(state.cell)
        result = shapes.sweep(path, period, bound, table, rods, robot.body_radius,
                              cfg.max_check_interval, cfg.collision_motion_fraction, cfg.max_sweep_checks,
                              self.block, active=feasible, cached=state.rods.position if self.scene.moves else None)
        collided = feasible & result.collided
        moved = feasible & ~result.collided
        elapsed = jnp.where(feasible, result.time, 0.0)
        # Where the step leaves the robot: stopped at the contact, on the new foot, or (a fall) where it was.
        c_hit, v_hit = path.state(elapsed)
        com_hit, vel_hit = origin + c_hit * rot, v_hit * rot
        fx, fy, fyaw = footstep.place_foot((support[0], support[1], support[2]), side, cmd[0], cmd[1], cmd[2], xp=jnp)
        new_foot = jnp.stack([fx, fy, fyaw])
        nc, ns = jnp.cos(fyaw), jnp.sin(fyaw)
        new_rot = nc + 1j * ns
        com_new = fx + 1j * fy + v.end_com * new_rot
        vel_new = v.end_vel * new_rot
        com_out = jnp.where(moved, com_new, jnp.where(collided, com_hit, com))
        vel_out = jnp.where(moved, vel_new, jnp.where(collided, vel_hit, vel))
        swing_idx = 1 - sidx
        feet = jnp.where(moved, state.feet.at[swing_idx].set(new_foot), state.feet)
        new_side = jnp.where(moved, -side, side)
        rods = jax.tree.map(lambda a, b: jnp.where(feasible, a, b), result.rods, state.rods)
        time = state.time + elapsed
        steps = state.steps + 1
        d_after = self._goal_distance(feet, state.goal)
        goal = ~collided & feasible & (d_after <= state.goal_tolerance)
        termination = jnp.where(~feasible, 3, jnp.where(collided, 2, jnp.where(goal, 1, 0))).astype(jnp.int32)
        terminated = termination > 0
        truncated = ~terminated & ((steps >= state.max_steps) | (time >= state.time_limit))
        zero = jnp.zeros((), dt)
        rewards = {
            "progress": cfg.reward_progress * (state.goal_dist - d_after),
            "time": cfg.reward_time * elapsed,
            "step": jnp.asarray(cfg.reward_step, dt),
            "goal": jnp.where(termination == 1, jnp.asarray(cfg.reward_goal, dt), zero),
            "collision": jnp.where(termination == 2, jnp.asarray(cfg.reward_collision, dt), zero),
            "fall": jnp.where(termination == 3, jnp.asarray(cfg.reward_fall, dt), zero),
        }
        reward = rewards["progress"]
        for name in REWARD_TERMS[1:]:
            reward = reward + rewards[name]
        new_state = state._replace(feet=feet, support=new_side.astype(jnp.int32),
                                   com=jnp.stack([com_out.real, com_out.imag]).astype(dt),
                                   com_vel=jnp.stack([vel_out.real, vel_out.imag]).astype(dt), time=time,
                                   steps=steps, previous=cmd, goal_dist=d_after, rods=rods)
        new_state, k_obs = self._noise_key(new_state)
        info = {
            "termination": termination, "is_success": termination == 1, "feasible": feasible,
            "collision": collided, "clipped": clipped, "command": cmd, "time": time, "period": period,
            "steps": steps, "zmp_offset": jnp.stack([v.p.real, v.p.imag]), "zmp_margin": zmp_margin,
            "clearance": jnp.where(feasible, result.clearance, jnp.nan), "checks": result.checks,
            "obstacle": jnp.where(collided, self._cell_index(result.obstacle, state.cell, walls), -1),
            "rewards": rewards, "cell": state.cell,
        }
        if self.sensing is None:
            return new_state, self.observation(new_state), reward, terminated, truncated, info
        obs, n_sensed = self._observe(new_state, k_obs)
        info["sensed_obstacles"] = n_sensed
        return new_state, obs, reward, terminated, truncated, info

    def step_batch(self, state: State, actions: jax.Array, chunk: int = 64) -> tuple:
        """:meth:`step` over a batch (leaves lead with N), as ``vmap`` over chunks of ``chunk`` envs run one after
        another (``lax.map``) when N is a multiple of ``chunk`` larger than it; plain ``vmap`` otherwise.

        The answers are ``vmap``'s (discrete ones exactly; XLA may round a float an ulp otherwise in the two
        layouts); the chunks are faster on a CPU: each chunk's sweep runs only as many iterations as its own
        slowest env needs, and its arrays stay in cache.
        """
        return chunked_vmap(self.step, state, actions, chunk)

    def _cell_index(self, shape: jax.Array, cell: jax.Array, walls: shapes.Walls) -> jax.Array:
        """A sweep's shape index (walls first, padding included) as the index among the cell's own walls and then
        the rods, the order of the reference world's obstacles."""
        n_walls = walls.r.shape[0]
        return jnp.where(shape >= n_walls, shape - (n_walls - self.wall_counts[cell]), shape)

    # ------------------------------------------------------------------ observation
    def observation(self, state: State, key: jax.Array | None = None) -> jax.Array:
        """The observation ``(12 + 5K,)`` float32 (``FootstepEnv``'s layout): :func:`footstep_gym.observation.observations`
        on this env's state and its nearest shapes: those sensed (:attr:`sensing`; ``key`` draws the noise) when a
        sensing option is on."""
        return self._observe(state, key)[0]

    def _observe(self, state: State, key: jax.Array | None) -> tuple[jax.Array, jax.Array | None]:
        """The observation and, with a sensing option on, how many moving obstacles were sensed (``info``'s
        ``sensed_obstacles``; a crowd's parked padding members are not obstacles)."""
        cfg, dt = self.config, self.dtype
        support = state.feet[(state.support + 1) // 2]
        low = jnp.asarray(self.low, dt)
        span = jnp.asarray(self.high - self.low, dt)
        previous = command_to_unit(state.previous, low, span)
        rods, rods_sensed, n_sensed = state.rods, None, None
        if self.sensing is not None:
            if self.sensing.noisy and key is None:
                raise ValueError("FootstepJaxEnv.observation: the sensing noise needs a key")
            rods, rods_sensed = sense(rods, key, state.com[0], state.com[1], support[2], self.sensing)
            n_sensed = jnp.sum(rods_sensed & (jnp.abs(state.rods.position[:, 0]) < 0.5 * PARKED)).astype(jnp.int32)
        point, pvel, mask = shapes.nearest_shapes(state.com[0], state.com[1], self.walls_of(state.cell)[0], rods,
                                                  cfg.n_obstacles_observed, cfg.sensing_range, rods_sensed)
        return observations(support[None], state.support.astype(dt)[None], state.com[None], state.com_vel[None],
                            state.goal[None], previous[None], point[None], pvel[None], mask[None],
                            ObservationScales.of(cfg), xp=jnp)[0], n_sensed


def chunked_vmap(fn: Any, state: Any, actions: jax.Array, chunk: int) -> Any:
    """``jax.vmap(fn)(state, actions)`` over chunks of ``chunk`` envs run one after another (``lax.map``), the batch
    in one ``vmap`` when it has at most ``chunk`` envs or does not split evenly."""
    n = actions.shape[0]
    step = jax.vmap(fn)
    if n <= chunk or n % chunk:
        return step(state, actions)

    def split(x: jax.Array) -> jax.Array:
        return x.reshape((n // chunk, chunk) + x.shape[1:])

    out = jax.lax.map(lambda sa: step(*sa), (jax.tree.map(split, state), split(actions)))
    return jax.tree.map(lambda x: x.reshape((n,) + x.shape[2:]), out)


def termination_name(code: int) -> str | None:
    """The reference's ``info["termination"]`` for a code of :data:`TERMINATION_CODES` (0: ``None``)."""
    for name, value in TERMINATION_CODES.items():
        if value == code:
            return name
    return None
