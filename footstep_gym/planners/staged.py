"""The staged planners: the paper's planner (period search, modified RRT, PSO) and its two comparisons.

Every policy, scripted or learned, is a :class:`footstep_gym.policy.Policy` and is made by
name with the one factory :func:`footstep_gym.make_policy` (``reset(seed)``, then
``act(obs, snapshot)`` per footstep; see :mod:`footstep_gym.policy`). This module holds the
planners; :mod:`footstep_gym.planners.registry` names them (:data:`~.registry.POLICIES`).

The three planners here read only the :class:`~footstep_gym.sensing.Snapshot` (what a
robot could sense now and, for the staged planners, at the last steps; the future only through
its constant-velocity prediction, or the acceleration sensed over the last step,
``additions.acceleration``) and ignore ``observation``; a learned agent reads ``observation``
and ignores the snapshot.

``period-aware`` — the paper's planner, greedy (one footstep per call, replanned every
step), docs/model.md §5. :meth:`PeriodAwarePlanner._plan` is the paper's three calls,
each a unit returning a record:

1. :class:`~.period_search.PeriodSearch` -> :class:`~.period_search.PeriodChoice`: the
   walking period ``T`` by binary search (Algorithm 1) between ``T0`` and ``T_n``;
2. :class:`~.rrt.PathSearch` -> :class:`~.rrt.PathChoice`: the modified RRT
   (Algorithm 2) at that period; its first node, via the footstep convention
   (:func:`footstep.foot_from_node` then :func:`footstep.command_between`), gives
   ``(S, L, θ)``; ``T_SS = T - nominal T_DS``, ``T_DS`` nominal (the paper's Tables 2 and
   4 keep T_DS at 0.20 s and vary T_SS);
3. :class:`~.pso.CommandRepair` -> :class:`~.pso.RepairChoice`: PSO over Table 1's
   increments (eq. 5-8), only if that command is infeasible.

What we add to the paper's planner is a set of named switches (``configs/planner.yaml``,
section ``additions``: the second tier of the period search, the centred period, the long
look-ahead, short horizons for unsteady shapes, the LIPM's windows, the fallback, ...).
``paper-period-aware`` and ``paper-fixed-period`` are the same classes with every switch
off and, where the paper specifies something else than our defaults, the paper's reading
(:data:`PAPER_READINGS`: the text's T0, the one-sample RRT, the node checked now and after
T, a constant penalty, a finer bisection; every deviation is listed in docs/model.md §5.3).
``<policy>-no-<switch>`` names a policy with one switch off and ``<policy>-with-<switch>`` one with
a switch on (:mod:`.ablation`: ours less one addition, the paper's plus one);
``paper-period-aware-t0-<s>`` is the paper's planner with T0 fixed at ``<s>`` seconds
(``paper-period-aware-t0-0.3`` is our earlier reading of Algorithm 1's T0).

``fixed-period`` — the same planner "without considering the walking period" (the
paper's comparison, Fig. 8 A-C): the period is not a decision variable *anywhere*. The
binary search is skipped (``T = T_n``), the RRT predicts obstacles at ``T_n`` per step,
and the PSO may change only ``S, L, θ`` (``ΔT_SS = ΔT_DS = 0``). Letting the PSO shorten
``T`` would reintroduce the period through the back door and blur the comparison; since
changing the stride at a constant period is always cheap for the LIPM (docs/model.md §3),
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
from abc import abstractmethod
from collections import deque
from typing import Any, Callable

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.kernels import select_kernels
from footstep_gym.planners import pso
from footstep_gym.planners.params import PlannerConfig
from footstep_gym.planners.period_search import PeriodSearch
from footstep_gym.planners.prediction import (
    BodyModel,
    ObstaclePredictor,
    body_path_points,
    sensed_accelerations,
    steady_motion_horizons,
)
from footstep_gym.planners.pso import CommandRepair
from footstep_gym.planners.rrt import PathChoice, PathSearch
from footstep_gym.planners.tracking import Tracker
from footstep_gym.planners.walks import WalkStart, walk_start
from footstep_gym.policy import SeededPolicy
from footstep_gym.robot import Robot
from footstep_gym.sensing import Snapshot


class SnapshotPlanner(SeededPolicy):
    """Shared by the scripted planners: robot, config, generator, timing of ``act``."""

    def __init__(self, robot: Robot, config: PlannerConfig, seed: int | None = None, name: str | None = None) -> None:
        super().__init__(robot, seed, name)
        self.config = config
        self._seed = seed

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


class PeriodAwarePlanner(SnapshotPlanner):
    """The paper's three-stage planner (binary search + modified RRT + PSO); see the module doc."""

    name = "period-aware"
    vary_period = True

    def __init__(self, robot: Robot, config: PlannerConfig, seed: int | None = None, name: str | None = None) -> None:
        super().__init__(robot, config, seed, name)
        self.kernels = select_kernels(config.kernels.compiled)  # numpy or compiled, for every stage
        self.period_search = PeriodSearch(robot, config, self.kernels, vary_period=self.vary_period)  # stage 1
        self.path_search = PathSearch(robot, config, self.kernels)  # stage 2
        self.repair = CommandRepair(robot, config.pso, vary_period=self.vary_period,  # stage 3
                                    rescue=config.additions.feasibility_rescue)
        self.half_width = 0.5 * robot.nominal_side_stride
        add, pp = config.additions, config.prediction
        self.unsteady = ((pp.unsteady_horizon_s, pp.unsteady_speed_mps, pp.unsteady_turn_rad_s)
                         if add.unsteady_horizons else None)
        self.horizon = pp.horizon_s
        self.margin = pp.safety_margin_m
        self.search_margin = pp.safety_margin_m + (config.period_search.extra_margin_m if add.search_margin else 0.0)
        self.com_sway = add.com_sway
        self.acceleration_horizon = pp.acceleration_horizon_s if add.acceleration else 0.0
        self.acceleration_pooled = pp.acceleration_pooled
        # What was sensed at the last steps, oldest first (the previous snapshot last).
        self._history: deque[Snapshot] = deque(maxlen=pp.acceleration_steps if add.acceleration else 1)
        self.tracker = Tracker(config.tracking) if add.tracking else None  # filters what is sensed, step to step
        self.predictor: ObstaclePredictor | None = None  # the last call's prediction, for planners built on this one

    @property
    def _previous_snapshot(self) -> Snapshot | None:
        """What was sensed one step ago."""
        return self._history[-1] if self._history else None

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self._history.clear()
        if self.tracker is not None:
            self.tracker.reset()

    # -------------------------------------------------------------- the three stages
    def _plan(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        start = walk_start(snapshot, self.half_width)
        body, search_body, unsteady = self._predict(snapshot, start)

        t0 = time.perf_counter()
        period = self.period_search(snapshot, start, search_body)  # Algorithm 1
        t1 = time.perf_counter()
        path = self.path_search(snapshot, start, body, period.period, period.free_walks,  # Algorithm 2
                                period.first_stride, self.rng)
        t2 = time.perf_counter()
        repair = self.repair(snapshot, path.command, self.rng)  # eq. (5)-(8), only if infeasible
        t3 = time.perf_counter()

        info: dict[str, Any] = dict(unsteady_shapes=unsteady, **period.diagnostics(), **path.diagnostics(),
                                    stride_window=period.first_stride, **repair.diagnostics())
        info.update(time_period_search_ms=1e3 * (t1 - t0), time_rrt_ms=1e3 * (t2 - t1), time_pso_ms=1e3 * (t3 - t2),
                    command_pre_pso=path.command, period=float(repair.command[3] + repair.command[4]))
        return repair.command, info

    def _predict(self, snapshot: Snapshot, start: WalkStart) -> tuple[BodyModel, BodyModel, int]:
        """The body checks of the RRT and of the period search over the predicted obstacles, and how many
        shapes were found unsteady (their velocity changed since the previous step). With ``additions.tracking``
        everything here reads the tracker's estimates of what was sensed."""
        if self.tracker is not None:
            snapshot = self.tracker.update(snapshot)
            if self.tracker.revised:  # what was kept of earlier steps is the raw readings
                self._history.clear()
        noise = self.tracker.rate_change_stds() if self.tracker is not None else None
        steady_stds = self.tracker.params.steady_stds if self.tracker is not None else 0.0
        unsteady = (steady_motion_horizons(self._previous_snapshot, snapshot, *self.unsteady, noise, steady_stds)
                    if self.unsteady is not None else {})
        accelerations = (sensed_accelerations(self._history, snapshot, self.acceleration_pooled)
                         if self.acceleration_horizon > 0 else {})
        self._history.append(snapshot)
        predictor = ObstaclePredictor(snapshot, horizon=self.horizon, horizons=unsteady, accelerations=accelerations,
                                      acceleration_horizon=self.acceleration_horizon)
        self.predictor = predictor
        body = BodyModel(predictor, self.robot, self.margin, sway=self.com_sway)
        search_body = BodyModel(predictor, self.robot, self.search_margin, sway=self.com_sway)
        return body, search_body, len(unsteady)


class FixedPeriodPlanner(PeriodAwarePlanner):
    """The paper's planner without the walking period: ``T = T_n`` throughout (see the module doc)."""

    name = "fixed-period"
    vary_period = False


class PSOOnlyPlanner(SnapshotPlanner):
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
                           max_velocity=p.max_velocity,
                           seeds=seed[None])
        command = res.x.copy()
        info = {
            "command_pre_pso": None, "pso_ran": True, "feasible_pre_pso": None,
            "predicted_feasible": lipm.step_feasible(robot, snapshot.com_local, snapshot.vel_local, command, side),
            "pso_iterations": res.iterations, "pso_value": res.value, "period_search": None,
            "period": float(command[3] + command[4]),
        }
        return command, info

    def objective(self, snapshot: Snapshot) -> Callable[[np.ndarray], np.ndarray]:
        """``f(FC (P, 5))``: distance to goal + predicted-collision and infeasibility penalties."""
        robot, cfg = self.robot, self.config
        p = cfg.pso_only
        predictor = ObstaclePredictor(snapshot, horizon=cfg.prediction.horizon_s)
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
