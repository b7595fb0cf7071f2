"""Reference policies: the paper's planner and its two comparisons, behind one interface.

Every policy, scripted or learned, is driven the same way by the evaluation::

    policy = make_policy("period-aware", robot, seed=0)
    policy.reset(seed=0)
    obs, info = env.reset(seed=0)
    while True:
        action = policy.act(obs, env.unwrapped.sensing())   # [S, L, θ, T_SS, T_DS], SI units
        obs, reward, terminated, truncated, info = env.step(action)
        ...  policy.last_info  # what the policy did this step (planning time, pre-PSO command, ...)

The three planners here read only the :class:`~footstep_gym.sensing.Snapshot` (what a
robot could sense now; the future only through its constant-velocity prediction) and
ignore ``observation``; a learned agent reads ``observation`` and ignores the snapshot.

``period-aware`` — the paper's planner, greedy (one footstep per call, replanned every
step), DESIGN §5:

1. walking period ``T`` by binary search (:mod:`.period_search`) between the shortest
   period reachable in one step and ``T_n``, collision predicate :class:`GoalRollouts`
   (walks at full stride; only if no period is free, again with walks that slow down or
   first step in place). The previous step's plan, while still free, is one of the walks
   and bounds the search from below;
2. modified RRT (:mod:`.rrt`) at that period, time-aware; its first node, via the
   footstep convention (:func:`footstep.foot_from_node` then
   :func:`footstep.command_between`), gives ``(S, L, θ)``; ``T_SS = T - nominal T_DS``,
   ``T_DS`` nominal (the paper's Tables 2 and 4 keep T_DS at 0.20 s and vary T_SS);
3. PSO over Table 1's increments (:mod:`.pso`), only if that command is infeasible.

``fixed-period`` — the same planner "without considering the walking period" (the
paper's comparison, Fig. 8 A-C): the period is not a decision variable *anywhere*. The
binary search is skipped (``T = T_n``), the RRT predicts obstacles at ``T_n`` per step,
and the PSO may change only ``S, L, θ`` (``ΔT_SS = ΔT_DS = 0``). Letting the PSO shorten
``T`` would reintroduce the period through the back door and blur the comparison; since
changing the stride at a constant period is always cheap for the LIPM (DESIGN §3),
this planner practically never needs more than that.

``pso-only`` — no binary search, no RRT: one PSO over the whole command box (S, L, θ
within the side's turn limits, T_SS, T_DS) minimising the distance of the robot centre
after the step to the goal, plus penalties for predicted collisions of the body path
(and of the reached centre for ``dwell_periods`` nominal periods after the step) and for
infeasibility. It shows what the first two stages save (paper §2.4: they "limit the
search space of the PSO").
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from typing import Any, Callable

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.planners import pso
from footstep_gym.planners.distance_field import StaticDistanceField
from footstep_gym.planners.params import PlannerConfig, load_planner_config
from footstep_gym.planners.period_search import (
    GoalRollouts,
    longest_free_period,
    shortest_feasible_period,
    stride_window,
    walk_start,
)
from footstep_gym.planners.prediction import (
    BodyModel,
    ObstaclePredictor,
    body_path_points,
    steady_motion_horizons,
)
from footstep_gym.planners.rrt import ModifiedRRT
from footstep_gym.robot import Robot, load_robot
from footstep_gym.sensing import Snapshot


class Policy(ABC):
    """What the evaluation drives: ``reset`` per episode, ``act`` per footstep.

    ``act`` returns the footstep command ``[S, L, θ, T_SS, T_DS]`` (float, SI units, shape
    ``(5,)``) and leaves a dict ``last_info`` describing the step.
    """

    name: str = ""

    def __init__(self) -> None:
        self.last_info: dict[str, Any] = {}

    @abstractmethod
    def reset(self, seed: int | None = None) -> None:
        """Start an episode; ``seed`` re-seeds the policy's own generator (``None``: keep it)."""

    @abstractmethod
    def act(self, observation: Any, snapshot: Snapshot | None) -> np.ndarray:
        """The next footstep command ``(5,)`` from the env's observation and/or sensing snapshot."""


class _Planner(Policy):
    """Shared by the scripted planners: robot, config, generator, timing of ``act``."""

    def __init__(self, robot: Robot, config: PlannerConfig, seed: int | None = None) -> None:
        super().__init__()
        self.robot = robot
        self.config = config
        self._seed = seed
        self.rng = np.random.default_rng(seed)
        self._field: StaticDistanceField | None = None  # static shapes' distances, kept across steps

    def reset(self, seed: int | None = None) -> None:
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.last_info = {}
        self._field: StaticDistanceField | None = None

    def static_field(self, snapshot: Snapshot, region: tuple[np.ndarray, np.ndarray]) -> StaticDistanceField | None:
        """The distance field of the snapshot's static shapes over ``region``: built once, reused while it
        covers the region and the static shapes are unchanged (``None`` if the resolution is 0)."""
        res = self.config.prediction.static_field_resolution_m
        if res <= 0:
            return None
        field = self._field
        if (field is None or field.key != StaticDistanceField.geometry_key(snapshot.obstacles)
                or not field.covers(region)):
            pad = self.config.prediction.static_field_padding_m
            field = StaticDistanceField(snapshot.obstacles, (region[0] - pad, region[1] + pad), res)
            self._field = field
        return field

    def region(self, node: np.ndarray, goal: Any) -> tuple[np.ndarray, np.ndarray]:
        """A box [m] that holds every body point the planner checks: the RRT's sampling box grown
        by a step (angle-limit re-draws), the body's radius, the margins and the CoM sway."""
        c = self.config
        pad = (c.rrt.sample_margin_m + c.rrt.step_size_m + self.robot.body_radius + c.prediction.safety_margin_m
               + c.period_search.extra_margin_m + 0.5 * self.robot.stride_side[1])
        goal = np.asarray(goal, dtype=float)
        return np.minimum(node, goal) - pad, np.maximum(node, goal) + pad

    def act(self, observation: Any, snapshot: Snapshot | None) -> np.ndarray:
        if snapshot is None:
            raise ValueError(f"{self.name} plans from the sensing snapshot: pass env.unwrapped.sensing()")
        start = time.perf_counter()
        command, info = self._plan(snapshot)
        info["plan_time_ms"] = 1e3 * (time.perf_counter() - start)
        info["policy"] = self.name
        info["command"] = command
        self.last_info = info
        return command

    @abstractmethod
    def _plan(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        ...

    @property
    def safe_distance(self) -> float:
        """Clearance [m] every predicted body point needs: robot radius + safety margin."""
        return self.robot.body_radius + self.config.prediction.safety_margin_m

    def _feasible(self, snapshot: Snapshot, commands: np.ndarray) -> np.ndarray:
        return lipm.check_steps(self.robot, snapshot.com_local, snapshot.vel_local, commands,
                                snapshot.support_side).feasible


class PeriodAwarePlanner(_Planner):
    """The paper's three-stage planner (binary search + modified RRT + PSO); see the module doc."""

    name = "period-aware"
    vary_period = True

    def __init__(self, robot: Robot, config: PlannerConfig, seed: int | None = None) -> None:
        super().__init__(robot, config, seed)
        c = config
        self.rrt = ModifiedRRT(
            robot, iterations=c.rrt.iterations, batch_size=c.rrt.batch_size, step_size=c.rrt.step_size_m,
            goal_sample_rate=c.rrt.goal_sample_rate, n_paths=c.rrt.n_paths,
            sample_margin=c.rrt.sample_margin_m, edge_samples=c.prediction.edge_samples,
            step_cost=c.rrt.step_cost_m, clearance_weight=c.rrt.fallback_clearance_weight,
            clearance_cap=c.rrt.fallback_clearance_cap_m)
        self.half_width = 0.5 * robot.nominal_side_stride
        self.delta_low, self.delta_high = c.pso.delta_bounds(vary_period=self.vary_period)
        self._last_path: tuple[np.ndarray, np.ndarray, float] | None = None  # rest of the last goal path, its period
        self._previous_snapshot: Snapshot | None = None  # what was sensed one step ago

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self._last_path = None
        self._previous_snapshot = None

    # -------------------------------------------------------------- the three stages
    def _plan(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        info: dict[str, Any] = {}
        cfg = self.config
        horizon = cfg.prediction.horizon_s
        start = walk_start(snapshot, self.half_width)
        pp = cfg.prediction
        unsteady = steady_motion_horizons(self._previous_snapshot, snapshot, pp.unsteady_horizon_s,
                                          pp.unsteady_speed_mps, pp.unsteady_turn_rad_s)
        self._previous_snapshot = snapshot
        info["unsteady_shapes"] = len(unsteady)
        region = self.region(start.node, snapshot.goal)
        predictor = ObstaclePredictor(snapshot, horizon=horizon, region=region, horizons=unsteady,
                                      static_field=self.static_field(snapshot, region))
        body = BodyModel(predictor, self.robot, cfg.prediction.safety_margin_m)
        search_body = BodyModel(predictor, self.robot,
                                cfg.prediction.safety_margin_m + cfg.period_search.extra_margin_m)

        t = time.perf_counter()
        committed, committed_period = self._committed(start)
        # Algorithm 1 asks whether the robot can go on now at full stride (Fig. 2: the next node at
        # Max_step_size); only if no period in [T0, T_n] lets it is the same search repeated with
        # walks that slow down or first step in place (let the obstacle pass).
        rollouts = self._rollouts(snapshot, start, search_body, committed, wait_steps=(0,), fractions=(1.0,),
                                  committed_body=body)
        period, found = self.choose_period(snapshot, rollouts, info, committed_period)
        ps = cfg.period_search
        waits = tuple(int(w) for w in ps.rollout_wait_steps if w > 0)
        info["waiting_walks"] = False
        if not found and (waits or any(f < 1.0 for f in ps.rollout_stride_fractions)):
            later = self._rollouts(snapshot, start, search_body, committed, wait_steps=(0, *waits),
                                   fractions=tuple(ps.rollout_stride_fractions), committed_body=body)
            later_period, later_found = self.choose_period(snapshot, later, {}, committed_period)
            if later_found:
                period, rollouts = later_period, later
                info.update(waiting_walks=True, period_search=later_period)
        window = self._stride_window(snapshot, period)
        info["time_period_search_ms"] = 1e3 * (time.perf_counter() - t)

        t = time.perf_counter()
        seeds = rollouts.free_walks(period, cfg.rrt.seed_paths) if cfg.rrt.seed_paths else []
        path = self.rrt.plan(start, snapshot.goal, snapshot.goal_tolerance, body, period, self.rng,
                             seeds=seeds, first_stride=window)
        info["rrt_reached_goal"] = path is not None
        if path is None:
            path = self.rrt.best_partial_path(stay_until=horizon)
        info.update(rrt_nodes=self.rrt.tree.n, rrt_seeds=len(seeds), path=path.nodes, stride_window=window)
        self._last_path = (path.nodes[1:], path.headings[1:], period) if path.reached_goal and path.n_steps else None
        reference = self.command_from_path(snapshot, path, period, window)
        info["time_rrt_ms"] = 1e3 * (time.perf_counter() - t)

        t = time.perf_counter()
        command = self.make_feasible(snapshot, reference, info)
        info["time_pso_ms"] = 1e3 * (time.perf_counter() - t)
        info["command_pre_pso"] = reference
        info["period"] = float(command[3] + command[4])
        return command, info

    def _committed(self, start) -> tuple[tuple[np.ndarray, np.ndarray] | None, float | None]:
        """The previous step's goal path from the node the robot now stands on, and its period.

        ``(None, None)`` if there is none or the robot did not land where it planned to
        (by more than ``commit_tolerance_m``: the PSO moved the step, or a fall-back was taken).
        """
        if self._last_path is None:
            return None, None
        nodes, headings, period = self._last_path
        if np.linalg.norm(nodes[0] - start.node) > self.config.period_search.commit_tolerance_m:
            return None, None
        nodes = np.concatenate([start.node[None], nodes[1:]])
        headings = np.concatenate([[start.heading], headings[1:]])
        return (nodes, headings), period

    def _rollouts(self, snapshot: Snapshot, start, body: BodyModel,
                  committed: tuple[np.ndarray, np.ndarray] | None = None,
                  wait_steps: tuple[int, ...] = (0,), fractions: tuple[float, ...] = (1.0,),
                  committed_body: BodyModel | None = None) -> GoalRollouts:
        cfg = self.config
        ps = cfg.period_search
        return GoalRollouts(
            body, self.robot, start, snapshot.goal, snapshot.goal_tolerance, horizon=cfg.prediction.horizon_s,
            step_size=cfg.rrt.step_size_m, lane_offsets=ps.rollout_lane_offsets_m,
            stride_fractions=fractions, lookahead=ps.rollout_lookahead_m,
            edge_samples=cfg.prediction.edge_samples, wait_steps=wait_steps,
            first_stride=lambda T: self._stride_window(snapshot, T), committed=committed,
            committed_body=committed_body)

    def _stride_window(self, snapshot: Snapshot, period: float) -> tuple[float, float] | None:
        """Front strides the LIPM accepts for the first step at ``period`` (see :func:`stride_window`)."""
        return stride_window(self.robot, snapshot.com_local, snapshot.vel_local, snapshot.support_side, period,
                             self.config.rrt.step_size_m, self.config.period_search.stride_grid)

    def choose_period(self, snapshot: Snapshot, collides: GoalRollouts, info: dict[str, Any],
                      committed_period: float | None = None) -> tuple[float, bool]:
        """Stage 1: the longest collision-free period (Algorithm 1), from the shortest reachable one.

        If the previous step's plan still holds at its period, that period is known to be
        free and becomes the search's lower end (so the result is never shorter). Returns
        the period [s] and whether any period was free. The fixed-period planner keeps T_n.
        """
        robot, ps = self.robot, self.config.period_search
        t_n = robot.nominal_period
        if not self.vary_period:
            free = bool(collides.free_walks(t_n, 1))
            info.update(period_search=t_n, period_floor=t_n, nominal_free=free, search_evaluations=1,
                        plan_kept=committed_period is not None and collides.committed_free(t_n))
            return t_n, free
        strides = (float(snapshot.previous_command[0]), self.config.rrt.step_size_m)
        floor = shortest_feasible_period(robot, snapshot.com_local, snapshot.vel_local, snapshot.support_side,
                                         strides, min(ps.t0_s, t_n), t_n, ps.floor_grid)
        kept = (committed_period is not None and floor <= committed_period <= t_n
                and collides.committed_free(committed_period))
        result = longest_free_period(collides, committed_period if kept else floor, t_n, ps.iterations)
        info.update(period_search=result.period, period_floor=floor, nominal_free=result.nominal_free,
                    search_evaluations=result.evaluations, plan_kept=kept)
        return result.period, result.any_free

    def command_from_path(self, snapshot: Snapshot, path, period: float,
                          window: tuple[float, float] | None = None) -> np.ndarray:
        """Stage 2's command: first node -> swing foot pose -> ``(S, L, θ)``; ``T`` split as ``T_SS + nominal T_DS``.

        A path without steps means "step in place" (the shortest stride of ``window`` if the
        CoM's momentum forbids stopping).
        """
        robot = self.robot
        side = snapshot.support_side
        if path.n_steps == 0:
            heading = path.headings[0]
            shortest = window[0] if window is not None else 0.0
            node = path.nodes[0] + shortest * np.array([np.cos(heading), np.sin(heading)])
        else:
            node, heading = path.nodes[1], path.headings[1]
        new_foot = footstep.foot_from_node(node, heading, -side, self.half_width)
        s, l, theta = footstep.command_between(snapshot.support_foot, side, new_foot)
        t_ds = robot.nominal_t_ds
        return pso.clip_command(robot, [s, l, theta, period - t_ds, t_ds], side)

    def make_feasible(self, snapshot: Snapshot, reference: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        """Stage 3: the reference if feasible, else the PSO's closest feasible command (eq. 5-8)."""
        ok = bool(self._feasible(snapshot, reference[None])[0])
        info["feasible_pre_pso"] = ok
        info["pso_ran"] = not ok
        if ok:
            info["predicted_feasible"] = True
            return reference
        p = self.config.pso
        rep = pso.repair_command(
            self.robot, snapshot.com_local, snapshot.vel_local, snapshot.support_side, reference, self.rng,
            delta_low=self.delta_low, delta_high=self.delta_high, particles=p.particles, iterations=p.iterations,
            inertia=p.inertia, c1=p.c1, c2=p.c2, patience=p.patience, deviation_weight=p.deviation_weight,
            infeasible_penalty=p.infeasible_penalty, violation_weight=p.violation_weight)
        info.update(predicted_feasible=rep.feasible, pso_iterations=rep.pso.iterations, pso_value=rep.pso.value)
        return rep.command


class FixedPeriodPlanner(PeriodAwarePlanner):
    """The paper's planner without the walking period: ``T = T_n`` throughout (see the module doc)."""

    name = "fixed-period"
    vary_period = False


class PSOOnlyPlanner(_Planner):
    """One PSO over the full command box per step; no binary search, no RRT (see the module doc)."""

    name = "pso-only"

    def _plan(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        robot, p = self.robot, self.config.pso_only
        side = snapshot.support_side
        low, high = robot.command_low.copy(), robot.command_high.copy()
        low[2], high[2] = footstep.turn_bounds(side, robot)
        objective = self.objective(snapshot)
        seed = pso.clip_command(robot, snapshot.previous_command, side)
        res = pso.minimise(objective, low, high, self.rng, particles=p.particles, iterations=p.iterations,
                           inertia=p.inertia, c1=p.c1, c2=p.c2, patience=p.patience, tolerance=p.tolerance,
                           seeds=seed[None])
        command = res.x.copy()
        info = {
            "command_pre_pso": None, "pso_ran": True, "feasible_pre_pso": None,
            "predicted_feasible": bool(self._feasible(snapshot, command[None])[0]),
            "pso_iterations": res.iterations, "pso_value": res.value, "period_search": None,
            "period": float(command[3] + command[4]),
        }
        return command, info

    def objective(self, snapshot: Snapshot) -> Callable[[np.ndarray], np.ndarray]:
        """``f(FC (P, 5))``: distance to goal + predicted-collision and infeasibility penalties."""
        robot, cfg = self.robot, self.config
        p = cfg.pso_only
        region = self.region(np.asarray(snapshot.com, dtype=float), snapshot.goal)
        predictor = ObstaclePredictor(snapshot, horizon=cfg.prediction.horizon_s,
                                      static_field=self.static_field(snapshot, region))
        side = snapshot.support_side
        support = np.asarray(snapshot.support_foot, dtype=float)
        goal = np.asarray(snapshot.goal, dtype=float)
        body0 = np.asarray(snapshot.com, dtype=float)
        n_edge = cfg.prediction.edge_samples
        dwell = np.arange(1, p.dwell_periods + 1) * robot.nominal_period
        safe = self.safe_distance

        def f(x: np.ndarray) -> np.ndarray:
            n = len(x)
            res = lipm.check_steps(robot, snapshot.com_local, snapshot.vel_local, x, side)
            fx, fy, _ = footstep.place_foot(support, side, x[:, 0], x[:, 1], x[:, 2])
            centre = 0.5 * (support[:2] + np.stack([fx, fy], axis=1))
            period = x[:, 3] + x[:, 4]
            pts, times = body_path_points(np.tile(body0, (n, 1)), centre, np.zeros(n), period, n_edge)
            if dwell.size:
                pts = np.concatenate([pts.reshape(n, n_edge, 2), np.repeat(centre[:, None], dwell.size, 1)], 1)
                times = np.concatenate([times.reshape(n, n_edge), period[:, None] + dwell[None]], 1)
            clear = predictor.clearance(pts.reshape(-1, 2), times.reshape(-1)).reshape(n, -1).min(axis=1)
            intrusion = np.maximum(safe - clear, 0.0)
            collision = np.where(intrusion > 0, p.collision_penalty + p.intrusion_weight * intrusion, 0.0)
            return (p.goal_weight * np.linalg.norm(centre - goal, axis=1) + collision
                    + pso.infeasibility_penalty(robot, res, p.infeasible_penalty, p.violation_weight))

        return f


#: The registry of scripted policies, by name.
POLICIES: dict[str, type[_Planner]] = {
    PeriodAwarePlanner.name: PeriodAwarePlanner,
    FixedPeriodPlanner.name: FixedPeriodPlanner,
    PSOOnlyPlanner.name: PSOOnlyPlanner,
}


def make_policy(name: str, robot: Robot | None = None, seed: int | None = None,
                config: PlannerConfig | None = None, **overrides: Any) -> Policy:
    """A policy of :data:`POLICIES` with ``configs/planner.yaml`` (plus ``overrides``) and ``robot``.

    ``overrides`` are planner config keys, per section (``rrt={"iterations": 200}``) or flat
    (``rrt_iterations=200``), applied on top of the YAML; ``config`` (a ready
    :class:`PlannerConfig`) and ``overrides`` are exclusive.
    """
    if name not in POLICIES:
        raise ValueError(f"unknown policy {name!r}; known: {', '.join(sorted(POLICIES))}")
    if config is None or overrides:
        if config is not None:
            raise ValueError("pass either config or overrides, not both")
        config = load_planner_config(overrides)
    return POLICIES[name](robot if robot is not None else load_robot(), config, seed)
