"""``FootstepEnv``: one Gymnasium environment class, three scenarios (door, crossing, crowd)."""

from __future__ import annotations

import cmath
import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.envs.registration import EnvSpec

from footstep_gym import config, footstep, lipm, tiers
from footstep_gym.config import nonnegative, plain, positive
from footstep_gym.errors import ActionError, ConfigError
from footstep_gym.footstep import LEFT, RIGHT, SIDE_NAMES
from footstep_gym.robot import COMMAND_FIELDS, Robot
from footstep_gym.scenarios import SCENARIOS, Scenario
from footstep_gym.scenarios.base import RobotMotion
from footstep_gym.sensing import ObstacleView, Snapshot, nearest_views, sense
from footstep_gym.world import World

TERMINATIONS = ("goal", "collision", "fall")
#: A float field that may be ``.inf`` (``sensing_max_range``): ``config.build`` coerces ``float`` fields and
#: refuses non-finite ones, so a field of this name is passed as read and :meth:`EnvConfig.validate` checks it.
_RangeOrInf = float
_FLOAT_DTYPES = (np.dtype(np.float64), np.dtype(np.float32))


@dataclass(frozen=True)
class EnvConfig:
    """Settings shared by the three envs (``configs/env.yaml``)."""

    n_obstacles_observed: int = positive()
    sensing_range: float = positive()  # [m]
    observation_position_scale: float = positive()  # [m]
    observation_velocity_scale: float = positive()  # [m/s]
    observation_com_scale: float = positive()  # [m]
    collision_slop: float = positive()  # [m]
    max_check_interval: float = positive()  # [s]
    collision_motion_fraction: float = positive()
    compiled_sweep: bool = plain()  # the sweep's checks compiled (numba) or asked of pymunk one by one; same answers
    fixed_period: bool = plain()  # the action is [S, L, theta]; T_SS and T_DS are held at the robot's nominal ones
    max_sweep_checks: int = positive()  # collision checks per footstep at most (bounds a step's cost)
    reward_progress: float = plain()  # per m
    reward_time: float = plain()  # per s
    reward_step: float = plain()  # per footstep
    reward_goal: float = plain()
    reward_collision: float = plain()
    reward_fall: float = plain()
    render_pixels_per_metre: float = positive()
    render_size: tuple[float, float] = config.pair()  # [px] width, height
    video_fps: float = positive()  # [frames per simulated second] of render_mode="rgb_array_list"
    # What the robot senses of the moving obstacles (all off by default; see the class's "Sensing" paragraph).
    sensing_noise_position: float = nonnegative()  # [m] std of the noise on each axis of a moving body's position
    sensing_noise_velocity: float = nonnegative()  # [m/s] std of the noise on each axis of its velocity
    sensing_noise_angle: float = nonnegative()  # [rad] std of the noise on a moving rod's angle
    sensing_noise_angular_velocity: float = nonnegative()  # [rad/s] std of the noise on a moving rod's turn rate
    sensing_max_range: _RangeOrInf = plain()  # [m] moving obstacles farther than this are not sensed; .inf: no limit
    sensing_fov: float = plain()  # [deg] full field of view centred on the support foot's yaw; 360: all around

    def validate(self) -> None:
        if not all(v >= 1 and float(v).is_integer() for v in self.render_size):
            raise ConfigError(f"env.yaml.render_size must be two whole numbers of pixels >= 1, got {self.render_size}")
        max_range = self.sensing_max_range  # not coerced by config.build (which refuses .inf): checked here
        if isinstance(max_range, bool) or not isinstance(max_range, (int, float)) or not max_range > 0:
            raise ConfigError(f"env.yaml.sensing_max_range must be a number > 0 [m] (.inf: no limit), "
                              f"got {max_range!r}")
        object.__setattr__(self, "sensing_max_range", float(max_range))
        if not 0.0 < self.sensing_fov <= 360.0:
            raise ConfigError(f"env.yaml.sensing_fov must be in (0, 360] [deg] (360: all around), "
                              f"got {self.sensing_fov!r}")

    @property
    def sensing_noise(self) -> bool:
        """Whether any of the sensing noises is on."""
        return (self.sensing_noise_position > 0.0 or self.sensing_noise_velocity > 0.0
                or self.sensing_noise_angle > 0.0 or self.sensing_noise_angular_velocity > 0.0)

    @property
    def sensing_limited(self) -> bool:
        """Whether the robot senses anything other than the truth (noise, a range or a field of view)."""
        return self.sensing_noise or self.sensing_max_range < math.inf or self.sensing_fov < 360.0


def _world_to_local(origin: tuple[float, float, float], z: complex) -> complex:
    """Point ``z`` (complex, world) in the frame of pose ``origin``."""
    return (z - complex(origin[0], origin[1])) * cmath.exp(-1j * origin[2])


def _pair(z: complex) -> tuple[float, float]:
    return (z.real, z.imag)


def with_step_limit(spec: EnvSpec | None, max_steps: int) -> EnvSpec | None:
    """``spec`` (what ``gymnasium.make`` gives an env) reporting ``max_episode_steps=max_steps``, the step at
    which the env truncates by itself; a spec that states a limit already is kept as it is."""
    if spec is None or spec.max_episode_steps is not None:
        return spec
    return dataclasses.replace(spec, max_episode_steps=max_steps)


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
    support; touching an obstacle at any instant of the step is a collision.

    Three scenarios are registered: ``FootstepDoor-v0`` (a revolving door, paper §3.1),
    ``FootstepCrossing-v0`` (an obstacle crossing the path, §3.2) and ``FootstepCrowd-v0``
    (an encircling crowd, §3.3). Their numbers are in ``configs/scenarios/*.yaml``.

    ## Action Space
    ``Box(5,)`` float32, the footstep command in SI units (paper eq. 5), bounds from
    ``configs/robot.yaml``:

    | index | field | meaning | unit | range (``robot.yaml`` key) |
    |---|---|---|---|---|
    | 0 | S | forward stride of the new foot in the support foot's frame | m | ``stride_front`` |
    | 1 | L | side stride, outward from the support foot (> 0 for either foot) | m | ``stride_side`` |
    | 2 | θ | new foot's yaw relative to the support foot (counter-clockwise > 0) | rad | ± max(``turn_inner``, ``turn_outer``) |
    | 3 | T_SS | single-support time | s | ``t_ss`` |
    | 4 | T_DS | double-support time | s | ``t_ds`` |

    θ's limits depend on the swinging foot: turning away from the support foot is allowed
    up to ``turn_outer``, towards it up to ``turn_inner``. An action is read
    in its own dtype: a float32 action at a float32-rounded limit (the box's bounds, the
    turn limits) is that limit exactly, so what SB3 sends at the box's edge is the command
    it rounds from. A finite command outside the box is clipped (``info["clipped"]``);
    NaN/inf or a wrong shape raises :class:`~footstep_gym.errors.ActionError` (a ``ValueError``)
    naming the env and the bad field. A command outside the turn limits, with overlapping feet, or whose ZMP
    leaves the stable region ends the episode as a fall.

    ## Observation Space
    ``Box(12 + 5K,)`` float32 (K = ``n_obstacles_observed``), the same layout for the three
    envs. "Local" means in the support foot's frame (x forward, y left). Scales and ranges
    are keys of ``configs/env.yaml``; bounds are inclusive.

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
    ``sensing_range`` of the CoM, so a shape's closest point is at most that far from it:
    R = ``sensing_range`` / ``observation_position_scale``. (A CoM inside a shape, in practice
    only from a start placed in an obstacle, sees the closest point at most the shape's
    half-thickness away: within R too unless the shape is thicker than 2 ``sensing_range``.)
    Commands are clipped to the action box before they are mapped; the one after ``reset``
    is the nominal one, in the box unless ``robot.stride_front`` leaves out S = 0, and then
    slot 7's bound widens to hold it. The other slots have no bound by construction: the
    goal is any point of the floor and the robot may walk anywhere in ``max_steps``
    footsteps; the CoM's offset and velocity follow the LIPM from step to step, whose
    feasibility check limits the ZMP, not the CoM (and a collision stops the CoM mid-step);
    an obstacle's speed is limited only per scene, by the scenario's ``max_*`` keys, and one
    space serves the three scenes and every setting. Gymnasium's ``check_env`` warns about
    those infinite bounds.

    **Sensing** (keys of ``configs/env.yaml``, all off by default, when the slots hold the
    truth read off the bodies): ``sensing_noise_position`` [m] and ``sensing_noise_velocity``
    [m/s] are the stds of zero-mean Gaussian noise on each axis of every moving body's sensed
    position and velocity, ``sensing_noise_angle`` [rad] and ``sensing_noise_angular_velocity``
    [rad/s] on a moving rod's angle and angular velocity (a circle's are not sensed: its outline
    has none); a moving obstacle whose sensed closest point lies farther than
    ``sensing_max_range`` [m] from the CoM, or outside the field of view of ``sensing_fov`` [deg]
    (the full angle, centred on the support foot's yaw), is not sensed. Walls are always sensed
    exactly (the robot's map). The noise is drawn once per step and at reset, after the world's
    state is final, from the env's generator (so a seed replays it; only when some noise is
    on, so default episodes draw what they always did), and the observation's slots and
    :meth:`sensing` are built from the same sensed state: the slots hold the sensed shapes'
    closest points and their velocities (:func:`footstep_gym.sensing.nearest_views`), and
    ``info["sensed_obstacles"]`` counts the moving obstacles sensed (present only when an option is on).

    ## Rewards
    Each term is reported in ``info["rewards"]``; the reward is their sum. Weights are
    keys of ``configs/env.yaml``:

    * ``progress``: ``reward_progress`` × metres the robot centre (midpoint of the feet)
      got closer to the goal;
    * ``time``: ``reward_time`` × seconds simulated in the step;
    * ``step``: ``reward_step`` per footstep;
    * ``goal`` / ``collision`` / ``fall``: ``reward_goal``, ``reward_collision``,
      ``reward_fall`` on those terminations.

    ## Starting State
    The robot stands at the scenario's ``start`` (jittered by ``start_jitter``) facing
    ``start_yaw``, on its right foot, its CoM in the steady gait of stepping in place at the
    nominal period (so the nominal step is feasible). Obstacles are placed by the scenario
    with the per-episode draws of ``reset(seed=...)``'s generator.

    ## Episode End
    Terminated on ``"goal"`` (robot centre within ``goal_tolerance``), ``"collision"`` (the
    body circle touches an obstacle at any time of a step) or ``"fall"`` (infeasible step).
    Truncated after ``max_steps`` footsteps or ``time_limit`` simulated seconds (keys of the
    scenario's YAML, e.g. ``gymnasium.make(..., max_steps=500)``). The env truncates by
    itself, the one place that holds its step limit: ``env.spec.max_episode_steps`` reports
    ``max_steps`` (filled in when ``gymnasium.make`` gives the env its spec), while the
    registry's ``gymnasium.spec(id).max_episode_steps`` stays ``None`` so that
    ``gymnasium.make`` adds no ``TimeLimit`` wrapper: a second limit would cut a raised
    ``max_steps`` short and flag a termination on the last step as truncated too.
    ``gymnasium.make(id, max_episode_steps=N)`` still adds one (its spec then reports N):
    episodes end at the smaller of N and ``max_steps``, so raise the limit with
    ``max_steps``; ``gymnasium.make(env.spec)`` adds one at the env's own limit. ``step``
    after the episode ended (terminated or truncated) raises ``gymnasium.error.ResetNeeded``
    naming how and when it ended; call ``reset()`` first (vector envs and SB3 do).

    ## Info
    Every step: ``is_success``, ``termination`` (one of ``"goal"``, ``"collision"``,
    ``"fall"`` or ``None``), ``feasible``, ``collision``, ``clipped``, ``time`` (s),
    ``period`` (s), ``support_foot`` (``"left"``/``"right"`` after the step),
    ``foot_pose`` (x, y, yaw of the foot just placed), ``zmp`` (world x, y of the
    single-support ZMP), ``com``/``com_vel`` (world, end of the step), ``rewards``,
    ``command`` (the command applied, after clipping), ``zmp_offset`` (local, m),
    ``zmp_margin`` (m: the signed per-axis margin of the single-support ZMP in the stable
    region, ``min`` over the two axes of (half extent - |offset|): inside, the distance to the
    nearest edge; negative when the ZMP is outside, and outside in both axes it is minus the
    larger per-axis overshoot, not the Euclidean distance to the region), ``clearance`` (m:
    the smallest gap between the body circle and any obstacle at the step's collision checks,
    negative on a collision, ``inf`` where no obstacle came within reach in the step, ``None``
    on a fall),
    ``obstacle`` (name of the shape hit, or ``None``), ``steps``.
    ``reset`` returns ``com``, ``com_vel``, ``support_foot``, ``foot_pose`` and ``time``.

    ## Arguments
    ``gymnasium.make("FootstepDoor-v0", render_mode=None, **overrides)``: any key of the
    scenario's YAML (e.g. ``door_speed=14.0``, ``obstacle_speed``, ``crowd_size``,
    ``crowd_speed``, ``goal``, ``randomize={"door_speed": [8, 17]}``), any key of
    ``configs/env.yaml`` (e.g. ``reward_time=-0.2``), and ``robot={...}`` for keys of
    ``configs/robot.yaml``. Unknown keys raise ``ValueError`` naming them.
    ``fixed_period=True`` (a key of ``configs/env.yaml``) makes the action ``[S, L, θ]``
    (``Box(3,)``, the first three rows of the table above) and holds ``T_SS`` and ``T_DS`` at the
    robot's nominal ones (``robot.yaml``: 0.6 s and 0.2 s); the observation is unchanged.
    Speeds and scales the collision sweep's cost grows with have upper bounds, keys of the
    scenario's YAML: ``door_speed <= max_door_speed`` (deg/s), ``door_radius <=
    max_door_radius`` (m), ``obstacle_speed <= max_obstacle_speed`` (m/s),
    ``arrival_speed <= max_arrival_speed`` (m/s), ``crowd_speed <= max_crowd_speed``
    (m/s), ``2 pi breathing_amplitude / breathing_period[0] <= max_breathing_speed``
    (m/s); a value or ``randomize`` range above its bound raises ``ConfigError`` naming
    both keys. Whatever the settings, a footstep makes at most ``max_sweep_checks``
    (``configs/env.yaml``) collision checks.
    ``render_mode``: ``"rgb_array"`` (an ``(H, W, 3)`` uint8 frame of the present),
    ``"rgb_array_list"`` (every frame since the last ``render()``, drawn inside the steps at
    ``video_fps`` frames per simulated second, so a video at ``metadata["render_fps"]`` plays
    in real time; :class:`footstep_gym.wrappers.RecordVideo` records them all) or ``"human"``.

    ``tier``: a benchmark tier of ``configs/benchmark.yaml`` (:mod:`footstep_gym.tiers`): ``"paper"``
    (the default: the settings above, the paper's scenes, bit for bit what the env was before
    tiers), ``"train"`` (the distribution the shipped agents trained on), ``"shifted"`` (the same
    layouts beyond the training ranges) or ``"hard"`` (a second door, two-way traffic, a reactive
    crowd, sensing noise); an unknown name raises ``ConfigError`` naming the known tiers. Each
    tier holds, per scene, named cells, each a set of the keywords above (``randomize`` ranges
    included): a tier of several cells draws one per episode, uniformly, from the env's seeded
    generator, before the episode's other draws (``reset(seed=s)`` fixes both; a tier of one cell
    draws nothing); ``tier_cell="fast"`` takes that cell for every episode. ``env.unwrapped.tier``,
    ``tier_cells`` and ``tier_cell`` (the episode's) say which; outside the default tier, ``reset``'s
    info holds ``tier_cell``. Other keywords given with a tier apply on top of its cells, but one
    that a cell sets (as a value or as a ``randomize`` range) raises ``ConfigError`` naming it: a
    tier is a fixed distribution whose results stay comparable (use ``tier="paper"``, where every
    key is free, for your own settings).

    A planner reads :meth:`sensing`: a read-only snapshot of what a robot could sense now.
    ``sensing_noise_position`` [m], ``sensing_noise_velocity`` [m/s], ``sensing_noise_angle``
    [rad], ``sensing_noise_angular_velocity`` [rad/s] (stds, >= 0), ``sensing_max_range`` [m]
    (> 0, ``math.inf``: no limit) and ``sensing_fov`` [deg] (in (0, 360]) set what it and the
    observation sense of the moving obstacles (see "Observation Space"); a value outside its
    range raises ``ConfigError`` naming the key. ``sensing_range`` only limits the observation's
    slots.

    ## Version History
    * v0: initial release.
    """

    metadata = {"render_modes": ["human", "rgb_array", "rgb_array_list"], "render_fps": 4}
    _spec: EnvSpec | None = None

    def __init__(self, scenario: str = "door", render_mode: str | None = None, tier: str | None = tiers.DEFAULT_TIER,
                 tier_cell: str | None = None, **overrides: Any) -> None:
        if scenario not in SCENARIOS:
            raise ConfigError(f"unknown scenario {scenario!r}; choose one of {sorted(SCENARIOS)}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.scenario_name = scenario
        self._scenario_cls: type[Scenario] = SCENARIOS[scenario]
        # The tier's cells (configs/benchmark.yaml, footstep_gym.tiers; "Arguments" above), each with the overrides
        # on top, built here (a bad value fails now): one (scenario config, env config) per cell. The default tier
        # has one cell that sets nothing: the overrides alone, as without tiers.
        self.tier: str = tiers.DEFAULT_TIER if tier is None else tier
        #: The cells episodes are drawn from (one: no draw), and the one of the episode under way (:attr:`tier_cell`).
        self.tier_cells: list[tiers.TierCell] = tiers.cells(scenario, self.tier, tier_cell)
        self._cell_configs: list[tuple[Any, EnvConfig]] = []
        for cell in self.tier_cells:
            groups, leftover = config.split_overrides(
                tiers.merge(cell, overrides, f"FootstepEnv({scenario})"),
                ("robot", Robot), ("scenario", self._scenario_cls.Config), ("env", EnvConfig)
            )
            if leftover:
                known = [f for _, cls in (("s", self._scenario_cls.Config), ("e", EnvConfig))
                         for f in cls.__dataclass_fields__] + ["robot", "tier", "tier_cell"]
                raise ConfigError(config.unknown_keys_message(f"FootstepEnv({scenario})", list(leftover), known))
            if not self._cell_configs:  # cells set no robot key: one robot
                self.robot: Robot = config.load(Robot, "robot.yaml", groups["robot"])
            self._cell_configs.append((self._scenario_cls.load_config(groups["scenario"]),
                                       config.load(EnvConfig, "env.yaml", groups["env"])))
        self._use_cell(0)
        self.render_mode = render_mode
        if render_mode == "rgb_array_list":  # frames from inside the steps, evenly spaced in simulated time
            self.metadata = {**self.metadata, "render_fps": self.config.video_fps}
        self._frames: list[np.ndarray] = []
        #: Overrides :attr:`env_name` (an owner such as ``FootstepMixEnv`` names its scene envs).
        self.display_name: str | None = None

        #: Fields of the action: all five, or ``[S, L, theta]`` with the period fixed (``fixed_period``).
        self.action_fields = COMMAND_FIELDS[:3] if self.config.fixed_period else COMMAND_FIELDS
        n_act = len(self.action_fields)
        self.action_space = spaces.Box(
            self.robot.command_low[:n_act].astype(np.float32), self.robot.command_high[:n_act].astype(np.float32),
            dtype=np.float32
        )
        # What the fixed-period form appends to each action: the nominal T_SS, T_DS (float64, exact).
        self._fixed_tail = self.robot.nominal_command[n_act:].tolist()
        # The robot's limits exactly (float64); the float32 box's bounds round them.
        self._low64 = self.robot.command_low
        self._high64 = self.robot.command_high
        # Every value a field can be pinned at: box bounds and, for theta, the side-dependent turn limits.
        turns = (-self.robot.turn_outer, -self.robot.turn_inner, self.robot.turn_inner, self.robot.turn_outer)
        self._limits64 = [np.array(sorted({lo, hi, *(turns if i == 2 else ())}))
                          for i, (lo, hi) in enumerate(zip(self._low64, self._high64))]
        self._limits_rounded: dict[np.dtype, list[dict[float, float]]] = {}  # per action dtype, see _validate_action
        self._low_list, self._high_list = self._low64.tolist(), self._high64.tolist()
        self._span_list = (self._high64 - self._low64).tolist()
        # Bounds per slot (docstring, "Observation Space"): finite where the layout has them, inclusive. Each
        # is the float64 bound cast to float32 as _observation casts its values; float32 rounding is monotone,
        # so every value within its bound in float64 lies within it in float32.
        inf = math.inf
        # The previous command after reset, the nominal one, mapped as _set_previous_command maps it: it lies in
        # [-1, 1] unless robot.stride_front leaves out S = 0 (every command applied after it is clipped to the box).
        nominal = [2.0 * (c - lo) / span - 1.0
                   for c, lo, span in zip(self.robot.nominal_command.tolist(), self._low_list, self._span_list)]
        # A listed shape's closest point lies within sensing_range of the CoM (World.nearest); the relative slack
        # covers float64's rounding of that point (a few ulps of the world coordinates), not float32's.
        reach = self.config.sensing_range / self.config.observation_position_scale * (1.0 + 1e-9)
        low = [-inf, -inf, -1.0, -inf, -inf, -inf, -inf, *(min(-1.0, v) for v in nominal)]
        high = [inf, inf, 1.0, inf, inf, inf, inf, *(max(1.0, v) for v in nominal)]
        low += [-reach, -reach, -inf, -inf, 0.0] * self.config.n_obstacles_observed
        high += [reach, reach, inf, inf, 1.0] * self.config.n_obstacles_observed
        self.observation_space = spaces.Box(np.array(low, dtype=np.float32), np.array(high, dtype=np.float32),
                                            dtype=np.float32)

        self.world: World | None = None
        self._static_key = None  # what the world's walls were built for (Scenario.static_key)
        self.scenario: Scenario | None = None
        self.episode_config = self.scenario_config
        self._renderer = None
        self._reset_state()

    # ------------------------------------------------------------------ state
    def _use_cell(self, index: int) -> None:
        """Make tier cell ``index`` the current one: its scenario config and env config (sensing keys)."""
        self.tier_cell: str = self.tier_cells[index].name
        self.scenario_config, self.config = self._cell_configs[index]

    @property
    def step_limit(self) -> int:
        """The largest ``max_steps`` of the tier's cells: the most footsteps an episode can take."""
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
        support = self.feet[self.support_side]
        rot = cmath.exp(-1j * support[2])
        return _world_to_local(support, self.com), self.com_vel * rot

    def _centre(self) -> complex:
        a, b = self.feet[LEFT], self.feet[RIGHT]
        return complex(0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]))

    def _goal_distance(self) -> float:
        return abs(self._centre() - complex(*self.episode_config.goal))

    def _set_previous_command(self, command: list[float]) -> None:
        """The last command applied and, for the observation, it mapped to [-1, 1] field by field (what
        numpy's array expression gave, bit for bit)."""
        self._previous = command
        self._previous_scaled = [2.0 * (c - lo) / span - 1.0
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
        if len(self._cell_configs) > 1:  # a tier of several cells: this episode's, drawn first (one cell: no draw)
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
        if self.tier != tiers.DEFAULT_TIER:  # the default tier's reset info stays what it always was
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
        """The command (5 floats) an action stands for, and whether it lay outside the box.

        An action is read in its own precision: a float32 action equal to a limit rounded to
        float32 (``float32(0.6) = 0.6000000238``, what SB3 sends at the box's upper T_SS
        bound) is that limit, not a hair beyond it. Each field is then clipped to the box.
        Plain Python after the conversion: numpy's per-call cost on 5 numbers was a tenth
        of a step.
        """
        fields = self.action_fields
        if type(action) is np.ndarray and action.shape == (len(fields),) and action.dtype in _FLOAT_DTYPES:
            raw, values = action, action.tolist()  # float32 and float64 convert to Python floats exactly
        else:
            try:
                raw = np.asarray(action)
                a = raw.astype(np.float64)
            except (TypeError, ValueError) as exc:
                raise ActionError(f"{self.env_name}: action must be {len(fields)} numbers [{', '.join(fields)}], "
                                  f"got {action!r}") from exc
            if a.shape != (len(fields),):
                raise ActionError(f"{self.env_name}: action shape={a.shape} but expected ({len(fields)},) = "
                                  f"[{', '.join(fields)}]")
            values = a.tolist()
        if not all(map(math.isfinite, values)):
            bad = [f"{name}={v}" for name, v in zip(fields, values) if not math.isfinite(v)]
            raise ActionError(f"{self.env_name}: action has non-finite field(s): {', '.join(bad)}")
        dtype = raw.dtype
        if dtype.kind == "f" and dtype.itemsize < 8:
            # Each limit rounded to the action's dtype, back in float64 (exactly): equal to the
            # action's field (exact in float64 too) exactly when equal in that dtype.
            rounded = self._limits_rounded.get(dtype)
            if rounded is None:  # per field {limit rounded: limit}; of limits that round alike, the lowest
                rounded = []
                for limits in self._limits64:
                    table: dict[float, float] = {}
                    for r, exact in zip(limits.astype(dtype).astype(np.float64).tolist(), limits.tolist()):
                        table.setdefault(r, exact)
                    rounded.append(table)
                self._limits_rounded[dtype] = rounded
            values = [table.get(v, v) for table, v in zip(rounded, values)]
        if self._fixed_tail:
            values += self._fixed_tail
        command = [lo if v < lo else hi if v > hi else v for v, lo, hi in zip(values, self._low_list, self._high_list)]
        return command, command != values

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.world is None:
            raise gym.error.ResetNeeded(f"{self.env_name}: call reset() before step()")
        if self.ended is not None:
            raise gym.error.ResetNeeded(
                f"{self.env_name}: episode ended ({self.ended}) at step {self.steps}; call reset() before step()")
        command, clipped = self._validate_action(action)
        robot, env_cfg, cfg = self.robot, self.config, self.episode_config
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
        d_before = self._goal_dist
        rewards = {"progress": 0.0, "time": 0.0, "step": env_cfg.reward_step,
                   "goal": 0.0, "collision": 0.0, "fall": 0.0}
        termination = None
        collided, hit = False, None
        clearance = None  # not measured: on a fall the robot does not move
        feasible = kin_ok and zmp_ok
        zmp_hx, zmp_hy = robot.zmp_half_extent
        zmp_margin = min(zmp_hx - abs(p.real), zmp_hy - abs(p.imag))
        if not feasible:
            termination = "fall"
            rewards["fall"] = env_cfg.reward_fall
            elapsed = 0.0
        else:
            swing = -self.support_side
            q = complex(S, swing * L)
            traj = lipm.StepTrajectory(robot.omega, com_local, vel_local, p, q, t_ss, t_ds)
            chord = (origin + traj.state(period)[0] * rot - self.com) / period  # the CoM's mean velocity over the step
            self.scenario.before_step(self.world, self.time, period, RobotMotion(_pair(self.com), _pair(chord)))
            result = self.world.sweep(traj.world_path(origin, rot), period, traj.speed_bound())
            elapsed, clearance = result.time, result.clearance
            if self.render_mode == "rgb_array_list":
                self._frames.extend(self._step_frames(elapsed, origin, rot, traj))
            self.history["zmp"].append(_pair(zmp_world))
            if result.collided:
                collided, hit = True, result.obstacle
                termination = "collision"
                rewards["collision"] = env_cfg.reward_collision
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
        rewards["time"] = env_cfg.reward_time * elapsed
        d_after = self._goal_dist = self._goal_distance()
        rewards["progress"] = env_cfg.reward_progress * (d_before - d_after)
        if termination is None and d_after <= cfg.goal_tolerance:
            termination = "goal"
            rewards["goal"] = env_cfg.reward_goal
        terminated = termination is not None
        truncated = not terminated and (self.steps >= cfg.max_steps or self.time >= cfg.time_limit)
        self.terminated = terminated
        if terminated:
            self.ended = termination
        elif truncated:
            self.ended = (f"truncated: max_steps={cfg.max_steps} reached" if self.steps >= cfg.max_steps
                          else f"truncated: time_limit={cfg.time_limit} s reached")
        info = {
            "is_success": termination == "goal",
            "termination": termination,
            "feasible": feasible,
            "collision": collided,
            "obstacle": hit,
            "clipped": clipped,
            "command": tuple(command),
            "time": self.time,
            "period": period,
            "steps": self.steps,
            "support_foot": SIDE_NAMES[self.support_side],
            "foot_pose": new_foot,
            "zmp": _pair(zmp_world),
            "zmp_offset": _pair(p),
            "zmp_margin": zmp_margin,
            "clearance": clearance,
            "com": _pair(self.com),
            "com_vel": _pair(self.com_vel),
            "rewards": rewards,
        }
        if env_cfg.sensing_limited:
            info["sensed_obstacles"] = self._sense()
        if self.render_mode == "human":
            self.render()
        return self._observation(), float(sum(rewards.values())), terminated, truncated, info

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
        cfg = self.config
        ps, vs = cfg.observation_position_scale, cfg.observation_velocity_scale
        support = self.feet[self.support_side]
        rot = cmath.exp(-1j * support[2])  # world -> the support foot's frame (_world_to_local, computed once)
        origin = complex(support[0], support[1])
        com = self.com
        com_local, vel_local = (com - origin) * rot, self.com_vel * rot
        goal = (complex(*self.episode_config.goal) - origin) * rot / ps
        com_scale = cfg.observation_com_scale
        obs = [goal.real, goal.imag, float(self.support_side), com_local.real / com_scale, com_local.imag / com_scale,
               vel_local.real / vs, vel_local.imag / vs, *self._previous_scaled]
        k = cfg.n_obstacles_observed
        if self._sensed is None:  # the truth, read off the bodies
            near = self.world.nearest((com.real, com.imag), k, cfg.sensing_range)
        else:  # what _sense kept (noisy, within range and field of view)
            near = nearest_views(self._sensed, (com.real, com.imag), k, cfg.sensing_range)
        for _, (x, y), (vx, vy), _ in near:
            rel = (complex(x, y) - com) * rot / ps
            v = complex(vx, vy) * rot / vs
            obs += (rel.real, rel.imag, v.real, v.imag, 1.0)
        if len(near) < k:
            obs += [0.0] * (5 * (k - len(near)))
        return np.array(obs, dtype=np.float32)

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
