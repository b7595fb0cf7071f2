"""Parameters of the reference planners (``configs/planner.yaml``), validated dataclasses.

The YAML has one section per stage; each section is built with
:func:`footstep_gym.config.build`, so unknown or missing keys and bad values raise
:class:`~footstep_gym.errors.ConfigError` naming them. Overrides (keyword arguments of
:func:`footstep_gym.make_policy`) are given per section, either as a mapping
(``rrt={"iterations": 200}``) or flat as ``<section>_<key>`` (``rrt_iterations=200``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

from footstep_gym import config
from footstep_gym.config import interval, nonnegative, plain, positive
from footstep_gym.errors import ConfigError


@dataclass(frozen=True)
class AdditionsParams:
    """Named switches of what our planners add to the paper's (docs/model.md §5); all off = the paper's planner.

    Each switch is read by the stage it changes; the ablation (:mod:`.ablation`) turns them
    off one at a time.
    """

    waiting_walks: bool = plain(True)  # stage 1: a second tier of slower / waiting walks when no period is free
    centred_period: bool = plain(True)  # stage 1: the middle of the window of free periods (a scan), not its longest end
    long_lookahead: bool = plain(True)  # stage 1: goal-directed rollouts over the horizon; off: one-step fan (Fig. 2)
    unsteady_horizons: bool = plain(True)  # shapes whose velocity changed are predicted only unsteady_horizon_s
    acceleration: bool = plain(True)  # shapes whose velocity changed: p + v t + a t^2 / 2 with a sensed a (up to a cap)
    lipm_windows: bool = plain(True)  # T0 = shortest period reachable now; first stride inside the LIPM's window
    search_margin: bool = plain(True)  # stage 1 checks with period_search.extra_margin_m more clearance
    com_sway: bool = plain(True)  # the body circle follows the LIPM's lateral sway (off: robot radius only)
    time_aware_rrt: bool = plain(True)  # stage 2: node d checked at [(d-1)T, dT]; off: all against obstacles at T
    rrt_seeds: bool = plain(True)  # stage 2: stage 1's free walks are the tree's first branches
    fallback: bool = plain(True)  # stage 2 without a goal path: the spot that stays free longest (off: nearest goal)
    feasibility_rescue: bool = plain(True)  # stage 3: if Table 1's increments find nothing feasible, the whole box
    tracking: bool = plain(True)  # a Kalman filter per sensed obstacle between sensing() and the prediction (.tracking)


@dataclass(frozen=True)
class PredictionParams:
    """How far ahead obstacles are predicted and how much room the robot keeps."""

    horizon_s: float = positive(30.0)  # [s] moving obstacles predicted this far; beyond, only static shapes
    unsteady_horizon_s: float = positive(2.0)  # [s] ... but only this far for shapes whose velocity changed since the last step
    unsteady_speed_mps: float = nonnegative(0.01)  # [m/s] a velocity change above this makes a shape unsteady
    unsteady_turn_rad_s: float = nonnegative(0.01)  # [rad/s] likewise for the angular velocity
    acceleration_steps: int = positive(1)  # additions.acceleration: the sensed velocities this many steps apart
    acceleration_horizon_s: float = nonnegative(1.0)  # [s] ... give an acceleration held this long, then the speed reached
    acceleration_pooled: bool = plain(True)  # the shapes whose velocity changed share the mean of their accelerations
    safety_margin_m: float = nonnegative(0.01)  # [m] added to robot.body_radius in every collision check
    edge_samples: int = positive(3)  # points checked along each body-path segment (>= 2)
    check: str = plain("path")  # "path": the body's path to the midpoint of two nodes; "node": the node itself (the paper)

    #: The values of ``check``.
    CHECKS = ("path", "node")

    def validate(self) -> None:
        if self.edge_samples < 2:
            raise ConfigError(f"prediction.edge_samples must be >= 2, got {self.edge_samples}")
        if self.check not in self.CHECKS:
            raise ConfigError(f"prediction.check must be one of {', '.join(self.CHECKS)}, got {self.check!r}")


@dataclass(frozen=True)
class TrackingParams:
    """The tracker of ``additions.tracking`` (:mod:`.tracking`): the sensor's noise profile, its filters' settings."""

    measurement_noise: tuple[float, ...] = plain((0.02, 0.05, 0.01, 0.01))  # [m, m/s, rad, rad/s] the sensor's reading stds (its profile)
    estimate_noise: bool = plain(False)  # the reading stds estimated from the readings instead (measurement_noise unused)
    noise_floor_m: float = positive(1e-06)  # [m] readings count as exact while their consistency residual's std is below it
    noise_floor_rad: float = positive(1e-06)  # [rad] likewise for a rod's angle
    process_noise_linear: float = positive(1e-05)  # [m^2/s^3] least variance per second of a velocity's steps
    process_noise_angular: float = positive(1e-07)  # [rad^2/s^3] likewise for a rod's turn rate
    gate: float = positive(30.0)  # normalised innovation squared (2 degrees of freedom) beyond which a track restarts
    still_prior: float = nonnegative(3.0)  # log-odds for "still" over "moving" before any reading
    model_memory: float = nonnegative(0.8)  # per footstep, the weight of the earlier evidence for "still" over "moving"
    window: int = positive(600)  # residuals of each kind kept for the noise estimate (the latest)
    outlier: float = positive(25.0)  # a residual beyond this times its kind's median square is left out of the estimate
    shared_velocity_gate: float = nonnegative(6.0)  # tracks whose velocities agree within this (chi-square, 2 dof) share them
    steady_stds: float = nonnegative(0.0)  # a velocity's change counts as unsteady beyond this many stds of the noise's

    def validate(self) -> None:
        noise = self.measurement_noise
        if len(noise) != 4 or any(v < 0 for v in noise):
            raise ConfigError(f"tracking.measurement_noise must be four stds >= 0 [position m, velocity m/s, "
                              f"angle rad, angular velocity rad/s], got {list(noise)!r}")
        if self.outlier <= 1:
            raise ConfigError(f"tracking.outlier must be > 1 (a multiple of the median square), got {self.outlier}")
        if not self.model_memory < 1:
            raise ConfigError(f"tracking.model_memory must be in [0, 1), got {self.model_memory}")
        if self.window < 3:
            raise ConfigError(f"tracking.window must be >= 3, got {self.window}")


@dataclass(frozen=True)
class PeriodSearchParams:
    """Stage 1, Algorithm 1 and its collision predicate (:class:`GoalRollouts`)."""

    t0_s: float = positive(0.3)  # [s] shortest period T0 the search may return (and where the reachable T0 is sought)
    t0_reachable: bool = plain(True)  # T0 = the shortest period reachable in one step from the CoM state (the paper's text)
    iterations: int = positive(4)  # N: resolution (T_n - T0) / 2**N
    scan_periods: int = positive(9)  # periods the centred scan tries between T0 and T_n (additions.centred_period)
    floor_grid: int = positive(11)  # periods tried for the shortest period reachable in one step
    stride_grid: int = positive(11)  # strides tried for the first step's feasible stride window
    rollout_lane_offsets_m: list = plain([-0.13, -0.065, 0.0, 0.065, 0.13])  # [m] rollout lanes beside the straight line to the goal
    rollout_stride_fractions: list = plain([0.7, 1.0])  # rollout strides as fractions of rrt.step_size_m
    rollout_lookahead_m: float = positive(0.3)  # [m] pure-pursuit lookahead along a lane
    rollout_wait_steps: list = plain([0, 3, 6])  # steps in place before a rollout sets off (0: at once)
    rollout_depth_slack: float = positive(1.2)  # rollouts span ceil(distance / shortest stride x this) steps ...
    rollout_extra_steps: int = nonnegative(2)  # ... + the longest wait + this many
    fan_directions: int = positive(9)  # one-step check (long_lookahead off): headings across the angle limits
    extra_margin_m: float = nonnegative(0.01)  # [m] more clearance in the search than in the RRT: slack in the timing

    def validate(self) -> None:
        for name in ("rollout_lane_offsets_m", "rollout_stride_fractions", "rollout_wait_steps"):
            value = getattr(self, name)
            if not value or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in value):
                raise ConfigError(f"period_search.{name} must be a non-empty list of numbers, got {value!r}")
        if not all(0 < f <= 1 for f in self.rollout_stride_fractions):
            raise ConfigError(f"period_search.rollout_stride_fractions must lie in (0, 1], "
                              f"got {self.rollout_stride_fractions}")
        if not all(float(w).is_integer() and w >= 0 for w in self.rollout_wait_steps):
            raise ConfigError(f"period_search.rollout_wait_steps must be whole numbers >= 0, "
                              f"got {self.rollout_wait_steps}")
        if self.rollout_depth_slack < 1:
            raise ConfigError(f"period_search.rollout_depth_slack must be >= 1, got {self.rollout_depth_slack}")
        for name in ("scan_periods", "floor_grid", "stride_grid", "fan_directions"):
            if getattr(self, name) < 2:
                raise ConfigError(f"period_search.{name} must be >= 2, got {getattr(self, name)}")


@dataclass(frozen=True)
class RRTParams:
    """Stage 2, Algorithm 2."""

    iterations: int = positive(400)  # samples in all (Max_iteration)
    batch_size: int = positive(10)  # samples extended per vectorised batch (1 = one by one)
    step_size_m: float = positive(0.1)  # [m] Max_step_size between nodes (<= robot.stride_front max)
    goal_sample_rate: float = nonnegative(0.2)  # probability that a sample is the goal
    n_paths: int = positive(3)  # goal-reaching paths collected before the least-cost one is taken
    sample_margin_m: float = nonnegative(0.5)  # [m] the sampling box extends this far beyond start and goal
    seed_paths: int = nonnegative(3)  # free rollouts of the period search inserted as first branches
    fallback_clearance_weight: float = nonnegative(5.0)  # no path to the goal: metres of progress worth 1 m of clearance
    fallback_clearance_cap_m: float = nonnegative(0.15)  # [m] clearance beyond this earns nothing more

    def validate(self) -> None:
        if not self.goal_sample_rate < 1:
            raise ConfigError(f"rrt.goal_sample_rate must be < 1, got {self.goal_sample_rate}")


@dataclass(frozen=True)
class PSOParams:
    """Stage 3: PSO over ΔFC (eq. 6-8), ranges of Table 1."""

    particles: int = positive(30)
    iterations: int = positive(40)
    inertia: float = nonnegative(0.7)
    c1: float = nonnegative(1.5)  # cognitive coefficient
    c2: float = nonnegative(1.5)  # social coefficient
    patience: int = positive(8)  # stop after this many iterations without improvement > tolerance
    tolerance: float = nonnegative(1e-09)  # improvement of the objective that counts
    max_velocity: float = positive(0.5)  # |velocity| per dimension <= this x the box size
    d_front_stride_m: tuple[float, float] = interval((-0.01, 0.01))  # ΔS [m]
    d_side_stride_m: tuple[float, float] = interval((-0.01, 0.01))  # ΔL [m]
    d_turn_deg: tuple[float, float] = interval((-5.0, 5.0))  # Δθ [deg]
    d_t_ss_s: tuple[float, float] = interval((-0.4, 0.0))  # ΔT_SS [s]
    d_t_ds_s: tuple[float, float] = interval((-0.1, 0.1))  # ΔT_DS [s]
    deviation_weight: float = positive(100.0)  # the 100 of eq. (7)
    infeasible_penalty: float = positive(1000.0)  # P_0 of eq. (7); must beat any feasible deviation
    violation_weight: float = nonnegative(10000.0)  # per metre of ZMP outside the stable region

    def delta_bounds(self, vary_period: bool = True) -> tuple[list[float], list[float]]:
        """``(low, high)`` of ΔFC in SI units; with ``vary_period=False`` ΔT_SS = ΔT_DS = 0."""
        t_ss = self.d_t_ss_s if vary_period else (0.0, 0.0)
        t_ds = self.d_t_ds_s if vary_period else (0.0, 0.0)
        lo = [self.d_front_stride_m[0], self.d_side_stride_m[0], math.radians(self.d_turn_deg[0]), t_ss[0], t_ds[0]]
        hi = [self.d_front_stride_m[1], self.d_side_stride_m[1], math.radians(self.d_turn_deg[1]), t_ss[1], t_ds[1]]
        return lo, hi

    def validate(self) -> None:
        lo, hi = self.delta_bounds()
        worst = self.deviation_weight * math.sqrt(sum(max(abs(a), abs(b)) ** 2 for a, b in zip(lo, hi)))
        if self.infeasible_penalty <= worst:
            raise ConfigError(
                f"pso.infeasible_penalty={self.infeasible_penalty} must exceed deviation_weight x the largest "
                f"increment ({worst:.3g}), or an infeasible command could beat a feasible one")


@dataclass(frozen=True)
class PSOOnlyParams:
    """The ``pso-only`` baseline: PSO over the full command box, no stages 1-2."""

    particles: int = positive(60)
    iterations: int = positive(100)
    inertia: float = nonnegative(0.7)
    c1: float = nonnegative(1.5)
    c2: float = nonnegative(1.5)
    patience: int = positive(20)
    tolerance: float = nonnegative(0.001)
    max_velocity: float = positive(0.5)  # |velocity| per dimension <= this x the box size
    goal_weight: float = positive(10.0)  # per metre from the robot centre after the step to the goal
    collision_penalty: float = positive(100.0)  # if any predicted body point is closer than the safe distance
    intrusion_weight: float = nonnegative(1000.0)  # per metre of the deepest intrusion into the safe distance
    infeasible_penalty: float = positive(1000.0)  # if the LIPM or the kinematic limits reject the command
    violation_weight: float = nonnegative(10000.0)  # per metre of ZMP outside the stable region
    dwell_periods: int = nonnegative(2)  # after the step, the new centre is also checked this many T_n ahead


@dataclass(frozen=True)
class LatticeParams:
    """The ``lattice`` planner: A* over strides x side strides x turns x periods (:mod:`.lattice`)."""

    strides: tuple[float, ...] = plain((-0.02, 0.0, 0.03, 0.06, 0.09))  # S values [m]
    side_strides: tuple[float, ...] = plain((0.08,))  # L values [m]
    turns: tuple[float, ...] = plain((-0.15, 0.0, 0.15))  # theta values [rad]; a side skips those outside its turn limits
    periods: tuple[float, ...] = plain((0.4, 0.6, 0.8))  # T = T_SS + T_DS values [s]; T_DS nominal
    heuristic_weight: float = positive(1.0)  # f = g + w h; 1: A* (optimal in time up to the duplicate grid)
    max_expansions: int = positive(300)  # nodes expanded per footstep at most
    max_depth: int = positive(6)  # footsteps planned ahead at most
    xy_resolution_m: float = positive(0.02)  # [m] stances closer than this (and as below) are one state
    yaw_resolution_rad: float = positive(0.05)  # [rad]
    time_resolution_s: float = positive(0.1)  # [s]

    def __post_init__(self) -> None:
        for name in ("strides", "side_strides", "turns", "periods"):
            value = getattr(self, name)
            if not isinstance(value, (list, tuple)) or not value:
                raise ConfigError(f"planner.yaml:lattice.{name} must be a non-empty list of numbers, got {value!r}")
            object.__setattr__(self, name, tuple(config.number(f"planner.yaml:lattice.{name}", v) for v in value))

    def validate(self) -> None:
        if self.heuristic_weight < 1:
            raise ConfigError(f"planner.yaml:lattice.heuristic_weight must be >= 1, got {self.heuristic_weight!r}")
        if min(self.periods) <= 0:
            raise ConfigError(f"planner.yaml:lattice.periods must be > 0, got {list(self.periods)}")


@dataclass(frozen=True)
class LookaheadParams:
    """The ``lookahead`` planner: cross-entropy optimisation of K footsteps with their periods (:mod:`.lookahead`)."""

    horizon_steps: int = positive(4)  # K footsteps optimised per call
    samples: int = positive(64)  # sequences per iteration
    elites: int = positive(8)  # the best this many refit the sampling distribution
    iterations: int = positive(4)  # cross-entropy iterations per call
    initial_std: float = positive(0.3)  # first standard deviation per dimension, as a fraction of the command box
    min_std: float = nonnegative(0.03)  # the standard deviation never shrinks below this fraction of the box
    collision_penalty: float = positive(100.0)  # [s] added for a predicted collision (x (K - k) / K at step k)
    infeasible_penalty: float = positive(1000.0)  # [s] added for a step the LIPM rejects (x (K - k) / K at step k)
    soft_margin_m: float = nonnegative(0.03)  # [m] clearance beyond the safe distance below which ...
    soft_weight: float = nonnegative(20.0)  # [s/m] ... each metre short is charged this much
    dwell_s: float = nonnegative(1.6)  # [s] the last stance must stay clear this long after the sequence
    dwell_samples: int = positive(5)  # instants checked over dwell_s
    greedy_seed: bool = plain(True)  # the period-aware planner's command, repeated, is one sequence of every first population

    def validate(self) -> None:
        if self.elites > self.samples:
            raise ConfigError(f"planner.yaml:lookahead.elites ({self.elites}) must be <= samples ({self.samples})")
        if self.samples < 8:
            raise ConfigError(f"planner.yaml:lookahead.samples must be >= 8 (the fixed seeds and a population), "
                              f"got {self.samples}")


@dataclass(frozen=True)
class KernelsParams:
    """Which of the planners' twin implementations runs: the same answers either way, at another cost."""

    compiled: bool = plain(True)  # the walks' and the RRT's loops in numba (.kernels); false: the numpy reference, no numba


@dataclass(frozen=True)
class PlannerConfig:
    """All sections of ``configs/planner.yaml`` (each section's defaults in its class; ``PlannerConfig()`` reads no
    file)."""

    additions: AdditionsParams = dataclasses.field(default_factory=AdditionsParams)
    prediction: PredictionParams = dataclasses.field(default_factory=PredictionParams)
    period_search: PeriodSearchParams = dataclasses.field(default_factory=PeriodSearchParams)
    rrt: RRTParams = dataclasses.field(default_factory=RRTParams)
    pso: PSOParams = dataclasses.field(default_factory=PSOParams)
    pso_only: PSOOnlyParams = dataclasses.field(default_factory=PSOOnlyParams)
    lattice: LatticeParams = dataclasses.field(default_factory=LatticeParams)
    lookahead: LookaheadParams = dataclasses.field(default_factory=LookaheadParams)
    kernels: KernelsParams = dataclasses.field(default_factory=KernelsParams)
    tracking: TrackingParams = dataclasses.field(default_factory=TrackingParams)


_SECTION_TYPES = {
    "additions": AdditionsParams,
    "prediction": PredictionParams,
    "period_search": PeriodSearchParams,
    "rrt": RRTParams,
    "pso": PSOParams,
    "pso_only": PSOOnlyParams,
    "lattice": LatticeParams,
    "lookahead": LookaheadParams,
    "kernels": KernelsParams,
    "tracking": TrackingParams,
}


def _nest_overrides(overrides: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    nested: dict[str, dict[str, Any]] = {name: {} for name in _SECTION_TYPES}
    for key, value in overrides.items():
        if key in nested:
            if not isinstance(value, Mapping):
                raise ConfigError(f"planner override {key!r} must be a mapping, got {value!r}")
            nested[key].update(value)
            continue
        for name in sorted(_SECTION_TYPES, key=len, reverse=True):  # "pso_only_x" before "pso_x"
            prefix = name + "_"
            fields = {f.name for f in dataclasses.fields(_SECTION_TYPES[name])}
            if key.startswith(prefix) and key[len(prefix):] in fields:
                nested[name][key[len(prefix):]] = value
                break
        else:
            known = [f"{n}_{f.name}" for n, cls in _SECTION_TYPES.items() for f in dataclasses.fields(cls)]
            raise ConfigError(config.unknown_keys_message("planner overrides", [key], known + list(_SECTION_TYPES)))
    return nested


def load_planner_config(overrides: Mapping[str, Any] | None = None,
                        defaults: Mapping[str, Mapping[str, Any]] | None = None) -> PlannerConfig:
    """``configs/planner.yaml`` with ``defaults`` (``{section: {key: value}}``, e.g. a policy's own
    switches) and then ``overrides`` applied (see module doc)."""
    data = config.read_yaml("planner.yaml")
    unknown = [k for k in data if k not in _SECTION_TYPES]
    if unknown:
        raise ConfigError(config.unknown_keys_message("planner.yaml", unknown, list(_SECTION_TYPES)))
    nested = _nest_overrides(overrides or {})
    sections = {}
    for name, cls in _SECTION_TYPES.items():
        section = data.get(name, {})  # a section the file leaves out: the code's defaults
        if not isinstance(section, Mapping):
            raise ConfigError(f"planner.yaml: section {name!r} must be a mapping, got {section!r}")
        section = {**section, **(defaults or {}).get(name, {}), **nested[name]}
        sections[name] = config.build(cls, section, f"planner.yaml:{name}")
    return PlannerConfig(**sections)
