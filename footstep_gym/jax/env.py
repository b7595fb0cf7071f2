"""``FootstepJaxEnv``: the footstep envs as pure JAX functions over a state pytree (gymnax / Brax style).

``reset(key, params) -> (state, obs)`` and ``step(key, state, action, params) -> (state, obs, reward,
terminated, truncated, info)`` are jittable and vmappable: one env's arrays in, one env's arrays out; ``jax.vmap``
makes a batch. ``params`` (:class:`EnvParams`, :attr:`FootstepJaxEnv.default_params`) holds every per-episode
setting (gymnax's ``EnvParams``): the tier cells' scenes, starts, goals, limits, reward weights and walls. The reference env (:class:`footstep_gym.env.FootstepEnv`, pymunk) is the spec and the judge: the same
action box and float32 handling, the same observation layout, reward terms, terminations and truncations
(docs/model.md), shown by replaying its episodes (:mod:`footstep_gym.jax.replay`).

Supported (the scenes of :mod:`footstep_gym.jax.scenes`, each with the ``randomize`` keys it lists):
``FootstepDoor-v0`` with one door or two, ``FootstepCrossing-v0`` (the timed car and the traffic lanes) and
``FootstepCrowd-v0``'s scripted ring (any size and ring) and ORCA pedestrians (every ``crowd_layout``, the robot
invisible to them), every other setting of their YAMLs including the
sensing options (noise, range, field of view: :mod:`footstep_gym.jax.sensing`, the noise drawn from the step's
key), and the tiers whose cells are such: every cell of every tier of the three scenes. Cells with
different walls (one door and two) each have their own (:class:`EnvParams`). Anything else (ORCA pedestrians that
see the robot, ``fixed_period``, a tier whose cells sense differently) raises
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
from footstep_gym.action import action_limits, action_space
from footstep_gym.env import DEFAULT_CELL, cell_configs
from footstep_gym.errors import ConfigError
from footstep_gym.footstep import RIGHT
from footstep_gym.jax import shapes, walker
from footstep_gym.jax.scenes import PARKED, SCENES, Scene, SceneParams, pad_to
from footstep_gym.jax.sensing import Sensing, sense
from footstep_gym.observation import ObservationScales, command_to_unit, observation_space, observations
from footstep_gym.scenarios import SCENARIOS

#: Termination codes of ``info["termination"]`` (0: none): the reference's names in this order.
TERMINATION_CODES = {"goal": 1, "collision": 2, "fall": 3}
#: The scenes supported (:data:`footstep_gym.jax.scenes.SCENES`).
SUPPORTED_SCENES = tuple(SCENES)
#: The reward terms of ``info["rewards"]``, in the reference's order (their sum is the reward).
REWARD_TERMS = ("progress", "time", "step", "goal", "collision", "fall")


class RewardWeights(NamedTuple):
    """The reward terms' weights (``configs/env.yaml``'s ``reward_*``; :data:`REWARD_TERMS`)."""

    progress: jax.Array
    time: jax.Array
    step: jax.Array
    goal: jax.Array
    collision: jax.Array
    fall: jax.Array


class EnvParams(NamedTuple):
    """Everything an episode needs, per tier cell (leaves lead with the cell axis ``C``; a reset draws one cell):
    the scene's params (:class:`~footstep_gym.jax.scenes.SceneParams`), the start ``(C, 2)`` [m], its heading
    [rad] and jitter [m], the goal ``(C, 2)`` [m] and its tolerance [m], the limits (``time_limit`` [s],
    ``max_steps``), the reward weights, and the walls: one set ``(W, ...)`` every cell shares, or each cell's
    ``(C, W, ...)`` (padded with walls of zero length :data:`PARKED` away), with the sweep's table of them and
    each cell's own count ``wall_counts`` ``(C,)``. Built by :meth:`FootstepJaxEnv.make_params`; any leaf may be
    changed (or batched with ``vmap``) as long as its shape stays."""

    scene: SceneParams
    start: jax.Array
    start_yaw: jax.Array
    start_jitter: jax.Array
    goal: jax.Array
    goal_tolerance: jax.Array
    time_limit: jax.Array
    max_steps: jax.Array
    rewards: RewardWeights
    walls: shapes.Walls
    wall_table: jax.Array
    wall_counts: jax.Array

    def cell(self, cell: jax.Array) -> "EnvParams":
        """Tier cell ``cell``'s params (an index): the cell axis gone (the walls too, where each cell has its own)."""
        walls, table = (self.walls, self.wall_table) if self.walls.r.ndim == 1 else (
            jax.tree.map(lambda x: x[cell], self.walls), self.wall_table[cell])
        per_cell = jax.tree.map(lambda x: x[cell], self._replace(walls=(), wall_table=()))
        return per_cell._replace(walls=walls, wall_table=table)


class State(NamedTuple):
    """One env's state. Feet ``(2, 3)``: row 0 the right foot, row 1 the left, ``(x, y, yaw)`` [m, rad];
    ``support``: +1 left, -1 right; CoM position [m] and velocity [m/s] in the world; ``previous``: the last
    command applied; ``goal_dist``: the robot centre's distance to the goal [m] now; ``rods``: the moving
    obstacles now; ``scene``: the episode's draws its scene moves them by (:mod:`footstep_gym.scenes`); ``cell``:
    the episode's tier cell (an index into the params' cells); ``key``: the episode's own stream (what an
    autoreset draws the next episode from)."""

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
    cell: jax.Array


def _unsupported(what: str) -> ConfigError:
    scenes = "; ".join(f"{name} (randomize of {', '.join(cls.randomizable)})" for name, cls in SCENES.items())
    return ConfigError(f"FootstepJaxEnv: {what} is not supported by the batched JAX backend yet (supported: "
                       f"{scenes}); use the reference env")


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

    The object holds what fixes the arrays' shapes and the spaces (the robot, the sweep's and the observation's
    settings, the sensing options, the scene's obstacle count); every per-episode setting is in the params
    (:class:`EnvParams`, :attr:`default_params`). ``block``: collision checks evaluated per iteration of the sweep
    (:mod:`footstep_gym.jax.shapes`; the answers do not depend on it). ``action_space`` and
    ``observation_space`` are the reference env's.
    """

    def __init__(self, scenario: str = "door", *, dtype: Any = "float32", tier: str | None = None,
                 tier_cell: str | None = None, block: int = shapes.DEFAULT_BLOCK, **env_kwargs: Any) -> None:
        if scenario not in SCENARIOS:
            raise ConfigError(f"FootstepJaxEnv: unknown scene {scenario!r}; known: {', '.join(SCENARIOS)}")
        if scenario not in SCENES:
            raise _unsupported(f"scene {scenario!r}")
        if "render_mode" in env_kwargs:
            raise _unsupported("render_mode")
        self.dtype = _dtype(dtype)
        if not (isinstance(block, int) and block >= 1):
            raise ConfigError(f"FootstepJaxEnv: block must be an integer >= 1, got {block!r}")
        self.block = block
        # The cells, as gymnasium.make resolves them (footstep_gym.tiers.make_env), each built and validated now.
        if tier is None:
            if tier_cell is not None:
                raise ConfigError(f"FootstepJaxEnv: tier_cell={tier_cell!r} needs tier= (the tier it is a cell of)")
            cells = {DEFAULT_CELL: env_kwargs}
        else:
            cells = tiers.env_kwargs(scenario, tier, tier_cell, env_kwargs)["cells"]
        robot, by_name = cell_configs(scenario, cells)
        configs = list(by_name.values())
        self.scenario, self.tier, self.cells = scenario, tier, list(by_name)
        self.robot = robot
        #: The env config of the first cell: the sweep's and the observation's settings (the cells' must agree).
        self.config = env_cfg = configs[0][1]
        #: The tier cells' (scenario config, env config).
        self.cell_configs: list[tuple[Any, Any]] = configs
        options = {Sensing.of(ecfg) if ecfg.sensing_limited else None for _, ecfg in configs}
        if len(options) > 1:
            raise _unsupported(f"tier {self.tier!r}: cells with different sensing options")
        #: The sensing options (noise, range, field of view; :mod:`footstep_gym.jax.sensing`), ``None`` when off.
        self.sensing: Sensing | None = options.pop()
        for cell, (cfg, ecfg) in zip(self.cells, configs):
            if ecfg.fixed_period:
                raise _unsupported("fixed_period")
        #: The scene's arrays and moves (:mod:`footstep_gym.jax.scenes`).
        self.scene: Scene = SCENES[scenario]([cfg for cfg, _ in configs], self.dtype)
        for cell, (cfg, _) in zip(self.cells, configs):
            what = self.scene.unsupported(cfg)
            if what:
                raise _unsupported(f"tier cell {cell!r}: {what}")
        # The action box, its float32-rounded limits, and the nominal command (the previous one after reset).
        limits = action_limits(robot)
        self.action_space = action_space(limits)
        self.observation_space = observation_space(limits.low, limits.high, robot.nominal_command,
                                                   env_cfg.sensing_range, env_cfg.observation_position_scale,
                                                   env_cfg.n_obstacles_observed)
        self.low, self.high = limits.low, limits.high
        self._limits = [pins.tolist() for pins in limits.pins]  # the values a float32 action is pinned at
        com_local, vel_local = lipm.steady_state(robot, robot.nominal_command, RIGHT)
        self._start_com = (com_local, vel_local)
        self.obs_size = int(self.observation_space.shape[0])
        #: The names of each cell's walls, in the order of ``info["obstacle"]``'s indices (walls first, then rods).
        self.wall_names = [[w.name for w in self.scene.module.walls(cfg)] for cfg, _ in configs]
        self._params = self.make_params(configs)

    # ------------------------------------------------------------------ settings
    def make_params(self, configs: list[tuple[Any, Any]]) -> EnvParams:
        """The params of cells given as ``(scenario config, env config)`` pairs (each its own cell, in order):
        the scene's, the start, goal and limits, the reward weights and the walls (the scene's ``walls``).
        Cells that share their walls (one ``static_key``) share one table; otherwise each cell has its own,
        padded to the most walls of any cell."""
        dt = self.dtype
        cls = SCENARIOS[self.scenario]

        def arr(x: Any) -> jax.Array:
            return jnp.asarray(np.asarray(x, np.float64), dt)

        def stack(rows: list[Any]) -> Any:
            return jax.tree.map(lambda *x: jnp.stack(x), *rows)

        scene = stack([self.scene.cell_params(cfg) for cfg, _ in configs])
        rewards = stack([RewardWeights(*(arr(getattr(ecfg, f"reward_{k}")) for k in REWARD_TERMS))
                         for _, ecfg in configs])
        by_key: dict[Any, shapes.Walls] = {}
        keys = []
        for cfg, _ in configs:
            key = cls.static_key(cfg)
            if key not in by_key:
                ws = self.scene.module.walls(cfg)
                by_key[key] = shapes.Walls(arr(np.reshape([w.a for w in ws], (-1, 2))),
                                           arr(np.reshape([w.b for w in ws], (-1, 2))),
                                           arr([0.5 * w.thickness for w in ws]))
            keys.append(key)
        counts = jnp.asarray([by_key[k].r.shape[0] for k in keys], jnp.int32)
        if len(by_key) == 1:
            walls = by_key[keys[0]]
            table = shapes.wall_table(walls)
        else:
            width = max(w.r.shape[0] for w in by_key.values())

            def pad(w: shapes.Walls) -> shapes.Walls:
                return shapes.Walls(pad_to(w.a, width, PARKED, dt), pad_to(w.b, width, PARKED, dt),
                                    pad_to(w.r, width, 0.0, dt))

            walls = stack([pad(by_key[k]) for k in keys])
            table = jax.vmap(shapes.wall_table)(walls)
        return EnvParams(scene, *(stack([arr(getattr(cfg, k)) for cfg, _ in configs]) for k in
                                  ("start", "start_yaw", "start_jitter", "goal", "goal_tolerance", "time_limit")),
                         jnp.asarray([cfg.max_steps for cfg, _ in configs], jnp.int32), rewards, walls, table, counts)

    @property
    def default_params(self) -> EnvParams:
        """Every tier cell's settings (:class:`EnvParams`; a reset draws one cell uniformly; one cell: no draw)."""
        return self._params

    @property
    def per_cell_walls(self) -> bool:
        """Whether the default params give each cell walls of its own (cells with different walls)."""
        return self._params.walls.r.ndim == 2

    # ------------------------------------------------------------------ reset
    def _draw_start(self, key: jax.Array, params: EnvParams) -> tuple:
        """An episode's draws from ``key``: ``(key, feet, rods, scene, cell)`` (``key``: the episode's stream)."""
        dt = self.dtype
        key, k_cell, k_scene, k_start = jax.random.split(key, 4)
        n_cells = params.max_steps.shape[0]
        cell = jax.random.randint(k_cell, (), 0, n_cells) if n_cells > 1 else jnp.zeros((), jnp.int32)
        p = params.cell(cell)
        rods, scene = self.scene.draw(k_scene, p.scene)
        jitter = p.start_jitter * jax.random.uniform(k_start, (2,), dt, -1.0, 1.0)
        centre = (p.start[0] + jitter[0], p.start[1] + jitter[1])
        half = 0.5 * self.robot.nominal_side_stride
        feet = jnp.stack([jnp.stack(footstep.foot_from_node(centre, p.start_yaw, side, half, xp=jnp))
                          for side in (RIGHT, -RIGHT)])
        return key, feet, rods, scene, cell

    def reset(self, key: jax.Array, params: EnvParams) -> tuple[State, jax.Array]:
        """A new episode from ``key``: ``(state, observation)``. The episode's draws (cell, randomize keys, the
        obstacles' placement, start jitter) come from ``key``; they are not the reference env's numpy draws for
        a seed."""
        state, k_obs = self.reset_state(key, params)
        return state, self.observation(state, params, k_obs)

    def reset_state(self, key: jax.Array, params: EnvParams) -> tuple[State, jax.Array | None]:
        """:meth:`reset`'s state, without its observation: ``(state, k_obs)``, ``k_obs`` the key the first
        observation's noise is drawn from (``None`` without sensing noise; :meth:`observation` takes it)."""
        key, feet, rods, scene, cell = self._draw_start(key, params)
        return self._start(key, feet, rods, scene, params, cell)

    def start_state(self, key: jax.Array, feet: jax.Array, rods: shapes.Rods, scene: Any,
                    params: EnvParams, cell: jax.Array) -> tuple[State, jax.Array]:
        """The state (and observation) of an episode of tier cell ``cell`` that starts with these feet, obstacles
        and scene draws: the robot on its right foot, its CoM in the steady gait of stepping in place
        (``FootstepEnv.reset``). ``key``: the episode's stream (the first observation's noise is drawn from it)."""
        state, k_obs = self._start(key, feet, rods, scene, params, cell)
        return state, self.observation(state, params, k_obs)

    def _start(self, key: jax.Array, feet: jax.Array, rods: shapes.Rods, scene: Any,
               params: EnvParams, cell: jax.Array) -> tuple[State, jax.Array | None]:
        """:meth:`start_state`'s state and the key of its first observation's noise (``None`` without noise)."""
        dt = self.dtype
        com_local, vel_local = self._start_com
        support = feet[0]
        c, s = jnp.cos(support[2]), jnp.sin(support[2])
        rot = c + 1j * s
        com = support[0] + 1j * support[1] + complex(com_local) * rot
        vel = complex(vel_local) * rot
        zero = jnp.zeros((), dt)
        p = params.cell(cell)
        state = State(key, feet.astype(dt), jnp.asarray(RIGHT, jnp.int32), jnp.stack([com.real, com.imag]).astype(dt),
                      jnp.stack([vel.real, vel.imag]).astype(dt), zero, jnp.zeros((), jnp.int32),
                      jnp.asarray(self.robot.nominal_command, dt), self._goal_distance(feet, p.goal), rods, scene,
                      jnp.asarray(cell, jnp.int32))
        k_obs = None
        if self.sensing is not None and self.sensing.noisy:
            key, k_obs = jax.random.split(key)
            state = state._replace(key=key)
        return state, k_obs

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

    def step(self, key: jax.Array, state: State, action: jax.Array, params: EnvParams
             ) -> tuple[State, jax.Array, jax.Array, jax.Array, jax.Array, dict[str, jax.Array]]:
        """One footstep: ``(state, obs, reward, terminated, truncated, info)`` (``FootstepEnv.step``). ``key``
        draws the step's randomness (the observation's sensing noise, where a tier senses with noise).

        ``info``: ``termination`` (0 none, 1 goal, 2 collision, 3 fall), ``is_success``, ``feasible``,
        ``collision``, ``clipped``, ``command``, ``time`` [s], ``period`` [s], ``steps``, ``zmp_offset``
        [m], ``zmp_margin`` [m], ``clearance`` [m] (NaN on a fall), ``checks``, ``obstacle`` (index of the
        shape hit: its index among the cell's walls, then the rods; -1 if none), ``rewards`` (the terms of
        :data:`REWARD_TERMS`), ``cell`` (the episode's tier cell, an index into :attr:`cells`), and with a sensing
        option on ``sensed_obstacles`` (:meth:`observe`'s count).
        """
        new_state, reward, terminated, truncated, info = self.transition(state, action, params)
        obs, n_sensed = self.observe(new_state, params, key)
        if n_sensed is not None:
            info["sensed_obstacles"] = n_sensed
        return new_state, obs, reward, terminated, truncated, info

    def transition(self, state: State, action: jax.Array, params: EnvParams
                   ) -> tuple[State, jax.Array, jax.Array, jax.Array, dict[str, jax.Array]]:
        """:meth:`step` without the observation: ``(state, reward, terminated, truncated, info)`` (``info`` without
        ``sensed_obstacles``, which is the observation's)."""
        robot, cfg, dt = self.robot, self.config, self.dtype
        p = params.cell(state.cell)
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
        rods, scene = self.scene.before_step(state.scene, state.rods, state.time, period)
        result = shapes.sweep(path, period, bound, p.wall_table, rods, robot.body_radius,
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
        rods, scene = jax.tree.map(lambda a, b: jnp.where(feasible, a, b), (result.rods, scene), (state.rods, state.scene))
        time = state.time + elapsed
        steps = state.steps + 1
        d_after = self._goal_distance(feet, p.goal)
        goal = ~collided & feasible & (d_after <= p.goal_tolerance)
        termination = jnp.where(~feasible, 3, jnp.where(collided, 2, jnp.where(goal, 1, 0))).astype(jnp.int32)
        terminated = termination > 0
        truncated = ~terminated & ((steps >= p.max_steps) | (time >= p.time_limit))
        zero = jnp.zeros((), dt)
        w = p.rewards
        rewards = {
            "progress": w.progress * (state.goal_dist - d_after),
            "time": w.time * elapsed,
            "step": w.step,
            "goal": jnp.where(termination == 1, w.goal, zero),
            "collision": jnp.where(termination == 2, w.collision, zero),
            "fall": jnp.where(termination == 3, w.fall, zero),
        }
        reward = rewards["progress"]
        for name in REWARD_TERMS[1:]:
            reward = reward + rewards[name]
        new_state = state._replace(feet=feet, support=new_side.astype(jnp.int32),
                                   com=jnp.stack([com_out.real, com_out.imag]).astype(dt),
                                   com_vel=jnp.stack([vel_out.real, vel_out.imag]).astype(dt), time=time,
                                   steps=steps, previous=cmd, goal_dist=d_after, rods=rods,
                                   scene=scene)
        info = {
            "termination": termination, "is_success": termination == 1, "feasible": feasible,
            "collision": collided, "clipped": clipped, "command": cmd, "time": time, "period": period,
            "steps": steps, "zmp_offset": jnp.stack([v.p.real, v.p.imag]), "zmp_margin": zmp_margin,
            "clearance": jnp.where(feasible, result.clearance, jnp.nan), "checks": result.checks,
            "obstacle": jnp.where(collided, self._cell_index(result.obstacle, p), -1),
            "rewards": rewards, "cell": state.cell,
        }
        return new_state, reward, terminated, truncated, info

    def transition_batch(self, state: State, actions: jax.Array, params: EnvParams, chunk: int = 64) -> tuple:
        """:meth:`transition` over a batch, chunked as :meth:`step_batch`."""
        return chunked_vmap(lambda st, a: self.transition(st, a, params), state, actions, chunk)

    def observe_batch(self, state: State, params: EnvParams, keys: jax.Array | None, chunk: int = 64
                      ) -> tuple[jax.Array, jax.Array | None]:
        """:meth:`observe` over a batch (``keys``: one per env, or ``None`` without sensing noise), chunked as
        :meth:`step_batch`."""
        if keys is None:
            return chunked_vmap(lambda st, _: self.observe(st, params, None), state, state.steps, chunk)
        return chunked_vmap(lambda st, k: self.observe(st, params, k), state, keys, chunk)

    def step_batch(self, keys: jax.Array, state: State, actions: jax.Array, params: EnvParams,
                   chunk: int = 64) -> tuple:
        """:meth:`step` over a batch (``keys``, ``state``'s leaves and ``actions`` lead with N; one ``params`` for
        all), as ``vmap`` over chunks of ``chunk`` envs run one after another (``lax.map``) when N is a multiple of
        ``chunk`` larger than it; plain ``vmap`` otherwise.

        The answers are ``vmap``'s (discrete ones exactly; XLA may round a float an ulp otherwise in the two
        layouts); the chunks are faster on a CPU: each chunk's sweep runs only as many iterations as its own
        slowest env needs, and its arrays stay in cache.
        """
        return chunked_vmap(lambda ks, a: self.step(ks[0], ks[1], a, params), (keys, state), actions, chunk)

    def _cell_index(self, shape: jax.Array, p: EnvParams) -> jax.Array:
        """A sweep's shape index (walls first, padding included) as the index among the cell's own walls and then
        the rods, the order of the reference world's obstacles (``p``: one cell's params)."""
        n_walls = p.walls.r.shape[0]
        return jnp.where(shape >= n_walls, shape - (n_walls - p.wall_counts), shape)

    # ------------------------------------------------------------------ observation
    def observation(self, state: State, params: EnvParams, key: jax.Array | None = None) -> jax.Array:
        """The observation ``(12 + 5K,)`` float32 (``FootstepEnv``'s layout): :func:`footstep_gym.observation.observations`
        on this env's state and its nearest shapes: those sensed (:attr:`sensing`; ``key`` draws the noise) when a
        sensing option is on."""
        return self.observe(state, params, key)[0]

    def observe(self, state: State, params: EnvParams, key: jax.Array | None = None
                ) -> tuple[jax.Array, jax.Array | None]:
        """:meth:`observation` and, with a sensing option on, how many moving obstacles were sensed (``info``'s
        ``sensed_obstacles``; a crowd's parked padding members are not obstacles; otherwise ``None``)."""
        cfg, dt = self.config, self.dtype
        p = params.cell(state.cell)
        support = state.feet[(state.support + 1) // 2]
        low = jnp.asarray(self.low, dt)
        span = jnp.asarray(self.high - self.low, dt)
        # An episode's first state holds the nominal command, whose unit value is a constant (as XLA folds it):
        # the same float wherever the state was made, however the runtime division rounds.
        nominal = command_to_unit(jnp.asarray(self.robot.nominal_command, dt), low, span)
        previous = jnp.where(state.steps == 0, nominal, command_to_unit(state.previous, low, span))
        rods, rods_sensed, n_sensed = state.rods, None, None
        if self.sensing is not None:
            if self.sensing.noisy and key is None:
                raise ValueError("FootstepJaxEnv.observation: the sensing noise needs a key")
            rods, rods_sensed = sense(rods, key if self.sensing.noisy else None, state.com[0], state.com[1],
                                      support[2], self.sensing)
            n_sensed = jnp.sum(rods_sensed & (jnp.abs(state.rods.position[:, 0]) < 0.5 * PARKED)).astype(jnp.int32)
        point, pvel, mask = shapes.nearest_shapes(state.com[0], state.com[1], p.walls, rods,
                                                  cfg.n_obstacles_observed, cfg.sensing_range, rods_sensed)
        return observations(support[None], state.support.astype(dt)[None], state.com[None], state.com_vel[None],
                            p.goal[None], previous[None], point[None], pvel[None], mask[None],
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
