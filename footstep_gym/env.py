"""``FootstepEnv``: one Gymnasium environment class, one env per scenario (door, crossing, crowd, ...)."""

from __future__ import annotations

import cmath
import dataclasses
import math
from typing import Any, Mapping, NamedTuple

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import EnvSpec

from footstep_gym import config, footstep, lipm
from footstep_gym.action import ActionReader, action_limits, action_space
from footstep_gym.env_config import EnvConfig
from footstep_gym.errors import ConfigError
from footstep_gym.footstep import LEFT, RIGHT, SIDE_NAMES
from footstep_gym.observation import ObservationScales, command_to_unit, observation, observation_space
from footstep_gym.robot import Robot
from footstep_gym.scenarios import SCENARIOS, Scenario
from footstep_gym.scenarios.base import RobotMotion
from footstep_gym.sensing import ObstacleView, Snapshot, nearest_views, sense
from footstep_gym.world import World

__all__ = ["FootstepEnv", "EnvConfig", "TERMINATIONS", "FALL_REASONS", "DEFAULT_CELL", "cell_configs", "with_step_limit"]

TERMINATIONS = ("goal", "collision", "fall")
#: Why a step is a fall (``info["fall"]``), in the order they are checked: outside the command box (never from
#: the env, which clips to it), T_SS too short for the swing (a robot with swing limits), outside the swinging
#: side's turn limits, feet overlapping, ZMP outside the region.
FALL_REASONS = footstep.KINEMATIC_VIOLATIONS + ("zmp",)


#: The one cell of an env made without ``cells``: the keyword overrides alone.
DEFAULT_CELL = "default"


def cell_configs(scenario: str, cells: Mapping[str, Mapping[str, Any]]
                 ) -> tuple[Robot, dict[str, tuple[Any, EnvConfig]]]:
    """The robot and, per cell, ``(scenario config, env config)`` built from the cell's env keywords (any key of the
    scene's YAML, of ``configs/env.yaml``, and ``robot``); every cell is built now, so a bad key or value raises
    :class:`ConfigError` here. The cells share one robot, the first cell's."""
    if scenario not in SCENARIOS:
        raise ConfigError(f"unknown scenario {scenario!r}; choose one of {sorted(SCENARIOS)}")
    if not isinstance(cells, Mapping) or not cells:
        raise ConfigError(f"FootstepEnv({scenario}): cells must be a non-empty mapping {{name: {{keywords}}}}, "
                          f"got {cells!r}")
    cls = SCENARIOS[scenario]
    robot = None
    out: dict[str, tuple[Any, EnvConfig]] = {}
    for name, kwargs in cells.items():
        where = f"FootstepEnv({scenario})" + ("" if len(cells) == 1 else f" cell {name!r}")
        if not isinstance(name, str) or not isinstance(kwargs, Mapping):
            raise ConfigError(f"{where}: a cell is a name and a mapping of env keywords, got {name!r}: {kwargs!r}")
        groups, leftover = config.split_overrides(kwargs, ("robot", Robot), ("scenario", cls.Config),
                                                  ("env", EnvConfig))
        if leftover:
            known = [f.name for c in (cls.Config, EnvConfig) for f in dataclasses.fields(c)]
            raise ConfigError(config.unknown_keys_message(where, list(leftover), known + ["robot"]))
        if robot is None:
            robot = config.load(Robot, "robot.yaml", groups["robot"])
        out[name] = (cls.load_config(groups["scenario"]), config.load(EnvConfig, "env.yaml", groups["env"]))
    assert robot is not None
    return robot, out


def _pair(z: complex) -> tuple[float, float]:
    return (z.real, z.imag)


def with_step_limit(spec: EnvSpec | None, max_steps: int) -> EnvSpec | None:
    """``spec`` (what ``gymnasium.make`` gives an env) reporting ``max_episode_steps=max_steps``, the step at
    which the env truncates by itself; a spec that states a limit already is kept as it is."""
    if spec is None or spec.max_episode_steps is not None:
        return spec
    return dataclasses.replace(spec, max_episode_steps=max_steps)


class StepOutcome(NamedTuple):
    """What :meth:`FootstepEnv._simulate` made of one command (world frame, SI units)."""

    command: list[float]  # [S, L, θ, T_SS, T_DS] applied, after clipping
    clipped: bool  # the action lay outside the box
    fall: str | None  # why the step is infeasible (FALL_REASONS), None when feasible
    zmp_offset: complex  # [m] single-support ZMP in the support foot's frame
    zmp: complex  # [m] the same, world
    zmp_margin: float  # [m] signed per-axis margin of the ZMP in the stable region
    foot: tuple[float, float, float]  # the pose the command places the swing foot at
    elapsed: float  # [s] simulated (0 on a fall; the time of contact on a collision)
    clearance: float | None  # [m] smallest gap to an obstacle at the step's checks; None on a fall
    collided: bool  # the body circle touched an obstacle
    obstacle: str | None  # the shape hit, None without a collision
    progress: float  # [m] how much closer the robot centre got to the goal


class FootstepEnv(gym.Env):
    r"""Humanoid footstep planning among moving obstacles, with the walking period in the action.

    ## Description
    A DARwIn-OP-sized humanoid walks to a goal on a 2D floor simulated with pymunk, among
    obstacles that move on their own (Lee et al., "footstep planning considering the
    walking period"). Each ``step`` is one footstep: the swing foot is placed by the
    command and a whole walking period ``T = T_SS + T_DS`` is simulated. The centre of mass
    (CoM) follows the linear inverted pendulum (LIPM) and its state is carried from step to
    step, so an abrupt change of period or stride can be infeasible because of the CoM's
    momentum. The robot's body is a circle that follows the CoM through single and double
    support; touching an obstacle at any instant of the step is a collision. docs/model.md
    is the reference (§2 the command, §3 the LIPM, §4 the world and scenes, §7 this interface).

    One env per scenario of ``footstep_gym.scenarios.SCENARIOS``: ``FootstepDoor-v0`` (a
    revolving door, paper §3.1), ``FootstepCrossing-v0`` (an obstacle crossing the path, §3.2)
    and ``FootstepCrowd-v0`` (an encircling crowd, §3.3). Their numbers are in
    ``configs/scenarios/*.yaml``.

    ## Action Space
    ``Box(5,)`` float32, the footstep command in SI units (paper eq. 5), bounds from
    ``configs/robot.yaml`` (:mod:`footstep_gym.action`):

    | index | field | meaning | unit | range (``robot.yaml`` key) |
    |---|---|---|---|---|
    | 0 | S | forward stride of the new foot in the support foot's frame | m | ``stride_front`` |
    | 1 | L | side stride, outward from the support foot (> 0 for either foot) | m | ``stride_side`` |
    | 2 | θ | new foot's yaw relative to the support foot (counter-clockwise > 0) | rad | ± max(``turn_inner``, ``turn_outer``) |
    | 3 | T_SS | single-support time | s | ``t_ss`` |
    | 4 | T_DS | double-support time | s | ``t_ds`` |

    θ's limits depend on the swinging foot: turning away from the support foot is allowed
    up to ``turn_outer``, towards it up to ``turn_inner``. An action is read in its own dtype:
    a float32 action at a float32-rounded limit (the box's bounds, the turn limits) is that
    limit exactly. A finite command outside the box is clipped (``info["clipped"]``); NaN/inf
    or a wrong shape raises :class:`~footstep_gym.errors.ActionError` (a ``ValueError``) naming
    the env and the bad field. A command outside the turn limits, with overlapping feet, or
    whose ZMP leaves the stable region ends the episode as a fall (``info["fall"]`` says which).
    With ``fixed_period=True`` the action is ``Box(3,)``, the first three rows.

    ## Observation Space
    ``Box(12 + 5K,)`` float32 (K = ``n_obstacles_observed``), the same layout for every scene
    (:mod:`footstep_gym.observation`). "Local" means in the support foot's frame (x forward,
    y left). Scales and ranges are keys of ``configs/env.yaml``; bounds are inclusive.

    | index | meaning | unit / scaling | bounds |
    |---|---|---|---|
    | 0-1 | goal position, local, relative to the support foot | m / ``observation_position_scale`` | ±inf |
    | 2 | support side: +1 left foot, -1 right foot | - | [-1, 1] |
    | 3-4 | CoM position relative to the support foot, local | m / ``observation_com_scale`` | ±inf |
    | 5-6 | CoM velocity, local | m/s / ``observation_velocity_scale`` | ±inf |
    | 7-11 | previous command, mapped from the action box to [-1, 1] | - | [-1, 1] |
    | 12 + 5k + 0..1 | closest point of the k-th nearest obstacle shape, local, relative to the CoM | m / ``observation_position_scale`` | ±R |
    | 12 + 5k + 2..3 | velocity of that point, local | m/s / ``observation_velocity_scale`` | ±inf |
    | 12 + 5k + 4 | 1 if this slot holds a shape, 0 if padding (then the slot is all zeros) | - | [0, 1] |

    Shapes (walls included) are sorted nearest first and limited to those within
    ``sensing_range`` of the CoM: R = ``sensing_range`` / ``observation_position_scale``.
    After ``reset`` the previous command is the nominal one (slot 7's bound widens to hold
    it if ``robot.stride_front`` leaves out S = 0). The other slots have no bound by
    construction (docs/model.md §7), so Gymnasium's ``check_env`` warns about them. By
    default the slots hold the truth; the ``sensing_*`` keys add noise, a range and a field
    of view (docs/model.md §4.6).

    ## Rewards
    The sum of these terms, each reported in ``info["rewards"]`` (weights: keys of ``configs/env.yaml``):

    | term | value |
    |---|---|
    | ``progress`` | ``reward_progress`` × metres the robot centre (midpoint of the feet) got closer to the goal |
    | ``time`` | ``reward_time`` × seconds simulated in the step |
    | ``step`` | ``reward_step`` per footstep |
    | ``goal`` / ``collision`` / ``fall`` | ``reward_goal`` / ``reward_collision`` / ``reward_fall`` on those terminations |

    ## Starting State
    The robot stands at the scenario's ``start`` (jittered by ``start_jitter``) facing
    ``start_yaw``, on its right foot, its CoM in the steady gait of stepping in place at the
    nominal period (so the nominal step is feasible). Obstacles are placed by the scenario
    with the per-episode draws of ``reset(seed=...)``'s generator.

    ## Episode End
    | ends | when | ``info`` |
    |---|---|---|
    | terminated, ``"goal"`` | the robot centre is within ``goal_tolerance`` of the goal | ``is_success`` |
    | terminated, ``"collision"`` | the body circle touches an obstacle at any instant of the step | ``obstacle`` |
    | terminated, ``"fall"`` | the step is infeasible; the robot does not move and no time passes | ``fall`` |
    | truncated | after ``max_steps`` footsteps or ``time_limit`` simulated seconds (scenario keys) | |

    The env truncates by itself: ``env.spec.max_episode_steps`` reports ``max_steps`` and
    ``gymnasium.make`` adds no ``TimeLimit`` (docs/model.md §7 says why, and what
    ``max_episode_steps=`` does). ``step`` after the episode ended raises
    ``gymnasium.error.ResetNeeded`` naming how and when it ended.

    ## Info
    Every step:

    | key | meaning |
    |---|---|
    | ``termination`` | ``"goal"``, ``"collision"``, ``"fall"`` or ``None`` |
    | ``fall`` | on a fall, why (the first that fails): ``"swing"`` (T_SS below the stride's floor, :func:`footstep.swing_time_floor`; only a robot with ``swing_speed`` or ``swing_acceleration`` has one), ``"turn_limit"`` (θ outside the swinging side's turn limits), ``"overlap"`` (the feet, grown by ``foot_clearance``, overlap) or ``"zmp"`` (the ZMP leaves the stable region); ``None`` otherwise |
    | ``is_success``, ``feasible``, ``collision``, ``clipped`` | bools |
    | ``command`` | the command applied, after clipping |
    | ``time``, ``period`` | s: simulated time since reset, this step's ``T_SS + T_DS`` |
    | ``steps`` | footsteps since reset |
    | ``support_foot``, ``foot_pose`` | ``"left"``/``"right"`` after the step; x, y, yaw of the foot the command places |
    | ``zmp``, ``zmp_offset`` | m: the single-support ZMP, world; the same in the support foot's frame |
    | ``zmp_margin`` | m: ``min`` over the two axes of (half extent - abs(offset)): the distance to the nearest edge inside the region, negative outside (then minus the larger per-axis overshoot); a kinematic fall may have a margin >= 0 |
    | ``clearance`` | m: the smallest gap between the body circle and any obstacle at the step's collision checks; negative on a collision, ``inf`` where nothing came within reach, ``None`` on a fall |
    | ``obstacle`` | the name of the shape hit, or ``None`` |
    | ``com``, ``com_vel`` | world, end of the step |
    | ``rewards`` | the reward's terms |
    | ``sensed_obstacles`` | moving obstacles sensed (only with a ``sensing_*`` option on) |

    ``reset`` returns ``com``, ``com_vel``, ``support_foot``, ``foot_pose``, ``time`` (and
    ``tier_cell``, the episode's cell, in an env made with a ``tier``; ``sensed_obstacles`` as above).

    ## Arguments
    ``gymnasium.make("FootstepDoor-v0", render_mode=None, tier=None, tier_cell=None, **overrides)``:

    | argument | meaning |
    |---|---|
    | any key of the scenario's YAML | ``door_speed=14.0``, ``goal``, ``max_steps``, ``randomize={"door_speed": [8, 17]}`` (per-episode draws); speeds and scales have upper bounds, the ``max_*`` keys |
    | any key of ``configs/env.yaml`` | ``reward_time=-0.2``, ``fixed_period=True`` (the action is ``[S, L, θ]``, T_SS and T_DS held at the robot's nominal ones), the ``sensing_*`` keys |
    | ``robot`` | keys of ``configs/robot.yaml`` as a mapping, or a profile's name (``"darwin-op"``) |
    | ``render_mode`` | ``"rgb_array"`` (the present), ``"rgb_array_list"`` (frames inside the steps at ``video_fps`` per simulated second) or ``"human"`` |
    | ``tier``, ``tier_cell`` | ``gymnasium.make`` only: a benchmark tier of ``configs/benchmark.yaml`` (``"paper"``, ``"train"``, ``"shifted"``, ``"structure"``, ``"noise"``), one cell drawn per episode, or one cell for all (docs/model.md §4.7); :mod:`footstep_gym.tiers` turns them into ``cells`` and ``tier`` before the env is built, and without them the file is not read |
    | ``cells``, ``tier`` | the class itself: ``{name: {keywords}}``, one cell drawn per episode from the reset's generator (one cell: no draw), exclusive with ``overrides``; ``tier`` names where they came from (reported as ``info["tier_cell"]``) |

    Unknown keys and bad values raise :class:`~footstep_gym.errors.ConfigError` (a ``ValueError``)
    naming them. A planner reads :meth:`sensing`: a read-only snapshot of what a robot could sense now.

    ## Version History
    * v0: initial release.
    """

    metadata = {"render_modes": ["human", "rgb_array", "rgb_array_list"], "render_fps": 4}
    _spec: EnvSpec | None = None

    def __init__(self, scenario: str = "door", render_mode: str | None = None, *,
                 cells: Mapping[str, Mapping[str, Any]] | None = None, tier: str | None = None,
                 **overrides: Any) -> None:
        if scenario not in SCENARIOS:
            raise ConfigError(f"unknown scenario {scenario!r}; choose one of {sorted(SCENARIOS)}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        if cells is not None and overrides:
            raise ConfigError(f"FootstepEnv({scenario}): give the keywords {', '.join(map(repr, overrides))} inside "
                              "each of the cells, not beside them")
        if tier is not None and cells is None:
            raise ConfigError(f"FootstepEnv({scenario}): tier={tier!r} names the cells given with it; for a benchmark "
                              "tier's env use gymnasium.make(env_id, tier=...) or footstep_gym.tiers.env_kwargs")
        self.scenario_name = scenario
        self._scenario_cls: type[Scenario] = SCENARIOS[scenario]
        #: Where the cells came from (a benchmark tier's name, given by :mod:`footstep_gym.tiers`), or None.
        self.tier: str | None = tier
        #: The env keywords of each cell episodes are drawn from (one: no draw); the episode's is :attr:`tier_cell`.
        self.cells: dict[str, dict[str, Any]] = {DEFAULT_CELL: dict(overrides)} if cells is None else \
            {name: dict(kwargs) for name, kwargs in cells.items()}
        self.robot: Robot
        self.robot, configs = cell_configs(scenario, self.cells)
        self._cell_names = list(configs)
        self._cell_configs: list[tuple[Any, EnvConfig]] = list(configs.values())
        self._use_cell(0)
        self.render_mode = render_mode
        if render_mode == "rgb_array_list":  # frames from inside the steps, evenly spaced in simulated time
            self.metadata = {**self.metadata, "render_fps": self.config.video_fps}
        self._frames: list[np.ndarray] = []
        #: Overrides :attr:`env_name` (an owner such as ``FootstepMixEnv`` names its scene envs).
        self.display_name: str | None = None

        limits = action_limits(self.robot, self.config.fixed_period)
        #: Fields of the action: all five, or ``[S, L, theta]`` with the period fixed (``fixed_period``).
        self.action_fields = limits.fields
        self.action_space = action_space(limits)
        self._read_action = ActionReader(limits)
        self._low_list = limits.low.tolist()
        self._span_list = (limits.high - limits.low).tolist()
        self.observation_space = observation_space(limits.low, limits.high, self.robot.nominal_command,
                                                   self.config.sensing_range, self.config.observation_position_scale,
                                                   self.config.n_obstacles_observed)
        self.world: World | None = None
        self._static_key = None  # what the world's walls were built for (Scenario.static_key)
        self.scenario: Scenario | None = None
        self.episode_config = self.scenario_config
        self._renderer = None
        self._reset_state()

    # ------------------------------------------------------------------ state
    def _use_cell(self, index: int) -> None:
        """Make cell ``index`` the current one: its scenario config and env config (sensing keys)."""
        self.tier_cell: str = self._cell_names[index]
        self.scenario_config, self.config = self._cell_configs[index]
        self._scales = ObservationScales.of(self.config)

    @property
    def step_limit(self) -> int:
        """The largest ``max_steps`` of the cells: the most footsteps an episode can take."""
        return max(cfg.max_steps for cfg, _ in self._cell_configs)

    def _reset_state(self) -> None:
        self.time = 0.0
        self.steps = 0
        self.support_side = RIGHT
        self.feet: dict[int, tuple[float, float, float]] = {}
        self.com = 0j
        self.com_vel = 0j
        self._set_previous_command(self.robot.nominal_command.tolist())
        self.terminated = False
        self.ended: str | None = None  # why the episode ended ("fall", "truncated: max_steps=200"), None while under way
        self.history: dict[str, list] = {"footprints": [], "com": [], "zmp": []}

    @property
    def spec(self) -> EnvSpec | None:
        """The spec ``gymnasium.make`` gave this env (``None`` if built directly), its
        ``max_episode_steps`` the scenario's ``max_steps`` (see "Episode End")."""
        return self._spec

    @spec.setter
    def spec(self, spec: EnvSpec | None) -> None:
        self._spec = with_step_limit(spec, self.step_limit)

    @property
    def env_name(self) -> str:
        """How this env names itself in error messages: ``display_name``, its registered id, or its scenario."""
        if self.display_name is not None:
            return self.display_name
        spec = self.spec
        return spec.id if spec is not None else f"FootstepEnv(scenario={self.scenario_name!r})"

    def _local_com(self) -> tuple[complex, complex]:
        """The CoM's position and velocity relative to the support foot, in its frame (complex)."""
        support = self.feet[self.support_side]
        rot = cmath.exp(-1j * support[2])
        return (self.com - complex(support[0], support[1])) * rot, self.com_vel * rot

    def _goal_distance(self) -> float:
        """[m] from the robot centre (the feet's midpoint) to the goal."""
        a, b = self.feet[LEFT], self.feet[RIGHT]
        centre = complex(0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]))
        return abs(centre - complex(*self.episode_config.goal))

    def _set_previous_command(self, command: list[float]) -> None:
        """The last command applied and, for the observation, it mapped to [-1, 1] field by field."""
        self._previous = command
        self._previous_scaled = [command_to_unit(c, lo, span)
                                 for c, lo, span in zip(command, self._low_list, self._span_list)]

    @property
    def previous_command(self) -> np.ndarray:
        """The last command applied ``[S, L, theta, T_SS, T_DS]`` (after clipping; the nominal one after reset)."""
        return np.array(self._previous)

    # ------------------------------------------------------------------ API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        rng = self.np_random
        if len(self._cell_configs) > 1:  # several cells: this episode's, drawn first (one cell: no draw)
            self._use_cell(int(rng.integers(len(self._cell_configs))))
        cfg = self.scenario_config.draw(rng)
        self.episode_config = cfg
        self._reset_state()
        env_cfg = self.config
        self.scenario = self._scenario_cls(cfg, rng)
        static_key = self._scenario_cls.static_key(cfg)
        if self.world is not None and static_key == self._static_key:
            self.world.clear_moving()  # the walls of the last episode are this one's
        else:
            self.world = World(self.robot.body_radius, env_cfg.collision_slop, env_cfg.max_check_interval,
                               env_cfg.collision_motion_fraction, env_cfg.max_sweep_checks,
                               compiled=env_cfg.compiled_sweep)
            self.scenario.build_static(self.world)
            self._static_key = static_key
        self.scenario.build(self.world)

        jitter = cfg.start_jitter * rng.uniform(-1.0, 1.0, 2)
        centre = (cfg.start[0] + jitter[0], cfg.start[1] + jitter[1])
        half = 0.5 * self.robot.nominal_side_stride
        for side in (LEFT, RIGHT):
            self.feet[side] = tuple(float(v) for v in footstep.foot_from_node(centre, cfg.start_yaw, side, half))
        self.support_side = RIGHT
        com_local, vel_local = lipm.steady_state(self.robot, self.robot.nominal_command, self.support_side)
        support = self.feet[self.support_side]
        rot = cmath.exp(1j * support[2])
        self.com = complex(support[0], support[1]) + com_local * rot
        self.com_vel = vel_local * rot
        self.world.robot_body.position = _pair(self.com)
        for side in (RIGHT, LEFT):
            self.history["footprints"].append((self.feet[side], side))
        self.history["com"].append(_pair(self.com))
        self._goal_dist = self._goal_distance()  # the next step's distance before it moves

        info = {
            "com": _pair(self.com), "com_vel": _pair(self.com_vel), "time": 0.0,
            "support_foot": SIDE_NAMES[self.support_side], "foot_pose": self.feet[self.support_side],
        }
        if self.tier is not None:
            info["tier_cell"] = self.tier_cell
        self._sensed = None
        if env_cfg.sensing_limited:
            info["sensed_obstacles"] = self._sense()
        if self.render_mode == "human":
            self.render()
        elif self.render_mode == "rgb_array_list":
            self._frames = [self._draw()]
        return self._observation(), info

    def _validate_action(self, action: Any) -> tuple[list[float], bool]:
        """The command (5 floats) an action stands for, and whether it lay outside the box
        (:mod:`footstep_gym.action`'s rules; :class:`~footstep_gym.errors.ActionError` on a bad action)."""
        return self._read_action(action, self.env_name)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self._check_running()
        command, clipped = self._validate_action(action)
        outcome = self._simulate(command, clipped)
        sensed = self._sense() if self.config.sensing_limited else None
        obs = self._observation()
        termination = self._termination(outcome)
        rewards = self._rewards(outcome, termination)
        terminated = termination is not None
        truncated = not terminated and self._truncated()
        self._end_episode(termination, truncated)
        info = self._info(outcome, termination, rewards)
        if sensed is not None:
            info["sensed_obstacles"] = sensed
        if self.render_mode == "human":
            self.render()
        return obs, float(sum(rewards.values())), terminated, truncated, info

    def _check_running(self) -> None:
        """Raise ``ResetNeeded`` before the first ``reset`` and after the episode ended (saying how and when)."""
        if self.world is None:
            raise gym.error.ResetNeeded(f"{self.env_name}: call reset() before step()")
        if self.ended is not None:
            raise gym.error.ResetNeeded(
                f"{self.env_name}: episode ended ({self.ended}) at step {self.steps}; call reset() before step()")

    # ------------------------------------------------------------------ one footstep
    def _simulate(self, command: list[float], clipped: bool) -> StepOutcome:
        """Walk one footstep of ``command``: the LIPM's verdict, then (if feasible) the collision sweep of the step
        with the obstacles moving; the robot's state, the clock and the history advance."""
        robot = self.robot
        S, L, theta, t_ss, t_ds = command
        period = t_ss + t_ds
        support = self.feet[self.support_side]
        com_local, vel_local = self._local_com()
        kin_ok, zmp_ok, p, end_com, end_vel = lipm.check_step(robot, com_local, vel_local,
                                                              (S, L, theta, t_ss, t_ds), self.support_side)
        rot = cmath.exp(1j * support[2])
        origin = complex(support[0], support[1])
        zmp_world = origin + p * rot
        new_foot = footstep.place_foot_scalar(support, self.support_side, S, L, theta)
        zmp_hx, zmp_hy = robot.zmp_half_extent
        zmp_margin = min(zmp_hx - abs(p.real), zmp_hy - abs(p.imag))
        d_before = self._goal_dist
        fall = None if kin_ok and zmp_ok else self._fall_reason(command, kin_ok)
        elapsed, clearance, collided, hit = 0.0, None, False, None  # on a fall the robot does not move
        if fall is None:
            swing = -self.support_side
            traj = lipm.StepTrajectory(robot.omega, com_local, vel_local, p, complex(S, swing * L), t_ss, t_ds)
            chord = (origin + traj.state(period)[0] * rot - self.com) / period  # the CoM's mean velocity over the step
            self.scenario.before_step(self.world, self.time, period, RobotMotion(_pair(self.com), _pair(chord)))
            result = self.world.sweep(traj.world_path(origin, rot), period, traj.speed_bound())
            elapsed, clearance = result.time, result.clearance
            if self.render_mode == "rgb_array_list":
                self._frames.extend(self._step_frames(elapsed, origin, rot, traj))
            self.history["zmp"].append(_pair(zmp_world))
            if result.collided:
                collided, hit = True, result.obstacle
                c, v = traj.state(elapsed)
                self.com, self.com_vel = origin + c * rot, v * rot
            else:
                new_rot = cmath.exp(1j * new_foot[2])
                self.feet[swing] = new_foot
                self.support_side = swing
                self.com = complex(new_foot[0], new_foot[1]) + end_com * new_rot
                self.com_vel = end_vel * new_rot
                self.history["footprints"].append((new_foot, swing))
            self.history["com"].append(_pair(self.com))
        self.time += elapsed
        self.steps += 1
        self._set_previous_command(command)
        d_after = self._goal_dist = self._goal_distance()
        return StepOutcome(command, clipped, fall, p, zmp_world, zmp_margin, new_foot, elapsed, clearance,
                           collided, hit, d_before - d_after)

    def _fall_reason(self, command: list[float], kinematic_ok: bool) -> str:
        """Why an infeasible ``command`` falls: the kinematic limit it fails first, else ``"zmp"``."""
        reason = None if kinematic_ok else footstep.kinematic_violation(self.robot, *command, self.support_side)
        return reason or "zmp"

    def _termination(self, outcome: StepOutcome) -> str | None:
        """``"fall"``, ``"collision"``, ``"goal"`` (the robot centre within ``goal_tolerance``) or ``None``."""
        if outcome.fall is not None:
            return "fall"
        if outcome.collided:
            return "collision"
        if self._goal_dist <= self.episode_config.goal_tolerance:
            return "goal"
        return None

    def _rewards(self, outcome: StepOutcome, termination: str | None) -> dict[str, float]:
        """The reward's terms (docstring, "Rewards"), in the order they are summed."""
        cfg = self.config
        return {"progress": cfg.reward_progress * outcome.progress, "time": cfg.reward_time * outcome.elapsed,
                "step": cfg.reward_step, "goal": cfg.reward_goal if termination == "goal" else 0.0,
                "collision": cfg.reward_collision if termination == "collision" else 0.0,
                "fall": cfg.reward_fall if termination == "fall" else 0.0}

    def _truncated(self) -> bool:
        """Whether the episode ran out of footsteps (``max_steps``) or simulated time (``time_limit``)."""
        cfg = self.episode_config
        return self.steps >= cfg.max_steps or self.time >= cfg.time_limit

    def _end_episode(self, termination: str | None, truncated: bool) -> None:
        """Record how the episode ended, if it did (``step`` then raises ``ResetNeeded`` saying so)."""
        cfg = self.episode_config
        self.terminated = termination is not None
        if termination is not None:
            self.ended = termination
        elif truncated:
            self.ended = (f"truncated: max_steps={cfg.max_steps} reached" if self.steps >= cfg.max_steps
                          else f"truncated: time_limit={cfg.time_limit} s reached")

    def _info(self, outcome: StepOutcome, termination: str | None, rewards: dict[str, float]) -> dict[str, Any]:
        """The step's ``info`` (docstring, "Info")."""
        return {
            "is_success": termination == "goal",
            "termination": termination,
            "fall": outcome.fall,
            "feasible": outcome.fall is None,
            "collision": outcome.collided,
            "obstacle": outcome.obstacle,
            "clipped": outcome.clipped,
            "command": tuple(outcome.command),
            "time": self.time,
            "period": outcome.command[3] + outcome.command[4],
            "steps": self.steps,
            "support_foot": SIDE_NAMES[self.support_side],
            "foot_pose": outcome.foot,
            "zmp": _pair(outcome.zmp),
            "zmp_offset": _pair(outcome.zmp_offset),
            "zmp_margin": outcome.zmp_margin,
            "clearance": outcome.clearance,
            "com": _pair(self.com),
            "com_vel": _pair(self.com_vel),
            "rewards": rewards,
        }

    # ------------------------------------------------------------------ observation
    def _sense(self) -> int:
        """Sense the world as it is now (the step's or reset's final state) with the sensing options on: draw
        the noise (only if some is on; one ``(n_moving, 6)`` array of standard normals from
        :attr:`np_random`), keep what is sensed in :attr:`_sensed` for the observation and :meth:`sensing`,
        and return how many moving obstacles are sensed."""
        cfg = self.config
        world = self.world
        # Walls never move: their views are read once, kept as {id(wall): (wall, view)} (checked by identity,
        # so a copied env, whose walls are other objects, reads them again).
        walls = getattr(self, "_wall_views", None) or {}
        views = []
        n_moving = 0
        for o in world.obstacles:
            if o.static:
                entry = walls.get(id(o))
                if entry is None or entry[0] is not o:
                    walls = self._wall_views = {id(w): (w, v) for w, v in zip(world.obstacles, world.views())
                                                if w.static}
                    entry = walls[id(o)]
                views.append(entry[1])
            else:
                body = o.body
                (x, y), (vx, vy) = body.position, body.velocity
                views.append(ObstacleView(o.name, o.kind, False, (x, y), body.angle, (vx, vy), body.angular_velocity,
                                          o.radius, o.local_a, o.local_b))
                n_moving += 1
        noise = None
        if cfg.sensing_noise:
            noise = self.np_random.standard_normal((n_moving, 6)).tolist()
        self._sensed = sense(views, _pair(self.com), self.feet[self.support_side][2], cfg.sensing_max_range,
                             cfg.sensing_fov, noise, (cfg.sensing_noise_position, cfg.sensing_noise_velocity,
                                                      cfg.sensing_noise_angle, cfg.sensing_noise_angular_velocity))
        return sum(1 for v in self._sensed if not v.static)

    def _observation(self) -> np.ndarray:
        """The observation of the state now (:func:`footstep_gym.observation.observation`): the truth read off the
        bodies, or what :meth:`_sense` kept when a sensing option is on."""
        cfg = self.config
        com = self.com
        k = cfg.n_obstacles_observed
        if self._sensed is None:
            near = self.world.nearest((com.real, com.imag), k, cfg.sensing_range)
        else:
            near = nearest_views(self._sensed, (com.real, com.imag), k, cfg.sensing_range)
        return observation(self.feet[self.support_side], self.support_side, com, self.com_vel,
                           self.episode_config.goal, self._previous_scaled, near, k, self._scales)

    def sensing(self) -> Snapshot:
        """What a robot could sense now (read-only): feet, CoM, goal, obstacles' shapes and velocities."""
        if self.world is None:
            raise gym.error.ResetNeeded(f"{self.env_name}: call reset() before sensing()")
        com_local, vel_local = self._local_com()
        cfg = self.episode_config
        return Snapshot(
            time=self.time,
            robot=self.robot,
            support_side=self.support_side,
            support_foot=self.feet[self.support_side],
            swing_foot=self.feet[-self.support_side],
            com=_pair(self.com),
            com_vel=_pair(self.com_vel),
            com_local=_pair(com_local),
            vel_local=_pair(vel_local),
            goal=(float(cfg.goal[0]), float(cfg.goal[1])),
            goal_tolerance=cfg.goal_tolerance,
            previous_command=tuple(self._previous),
            obstacles=self.world.views() if self._sensed is None else self._sensed,
        )

    # ------------------------------------------------------------------ rendering
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        if self.world is None:
            raise gym.error.ResetNeeded(f"{self.env_name}: call reset() before render()")
        if self.render_mode == "rgb_array_list":
            frames, self._frames = self._frames, []
            return frames
        return self._draw()

    def _draw(self, **state: Any) -> np.ndarray | None:
        if self._renderer is None:
            from footstep_gym.render import Renderer

            self._renderer = Renderer(self, self.render_mode)
        return self._renderer.draw(**state)

    def _step_frames(self, elapsed: float, origin: complex, rot: complex, traj: lipm.StepTrajectory
                     ) -> list[np.ndarray]:
        """Frames at the multiples of ``1 / video_fps`` of simulated time inside the step just swept.

        The world is at the step's end (``elapsed`` [s] after its start); obstacles kept one
        velocity through the step, so each frame draws them moved back by the time left.
        """
        dt = 1.0 / self.config.video_fps
        frames = []
        k = math.floor(self.time / dt + 1e-9) + 1
        while k * dt <= self.time + elapsed + 1e-9:
            t = k * dt - self.time
            com = origin + traj.state(min(t, elapsed))[0] * rot
            frames.append(self._draw(com=com, back=elapsed - t, time=self.time + t))
            k += 1
        return frames

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
