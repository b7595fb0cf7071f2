"""``lookahead``: a receding-horizon period-aware planner that optimises K footsteps with their periods.

The paper's planner (``period-aware``) is greedy: it chooses one footstep per call. The
paper names multi-step optimisation as its future work; this planner does it by sampling.
With ``greedy_seed`` (the default) each call first asks ``period-aware`` for its command and its
RRT path's next footsteps and rolls that plan out as below, with ``period-aware``'s own prediction
(its tracker and unsteady horizons included); if the plan holds for K footsteps, its command is
returned unchanged. Otherwise (and always without ``greedy_seed``) the call optimises a sequence of ``K`` commands ``[S, L, θ, T_SS]`` (``T_DS`` nominal) with
the cross-entropy method: a population of sequences is rolled out through the LIPM (each
step's CoM state carried to the next, every step checked for feasibility,
:func:`footstep_gym.lipm.check_steps`) and through the prediction of the obstacles
(:class:`.prediction.ObstaclePredictor`; never the simulator's future): the body's CoM path is checked at every step, and the last stance for
``dwell_s`` seconds after the sequence (a plan must not end where it is trapped). The cost is
the time to the goal (reached: when; not reached: the time walked plus the remaining distance
over the fastest centre speed), plus penalties for a collision or an infeasible step (larger
the earlier it comes) and for clearance below ``soft_margin_m``. The elites refit a Gaussian per
command dimension; the best sequence's first command is executed (through stage 3's PSO if the
LIPM rejects it), and the rest seeds the next call (shifted by one footstep).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.planners.lattice import centre_speed_bound
from footstep_gym.planners.params import LookaheadParams, PlannerConfig
from footstep_gym.planners.prediction import ObstaclePredictor, sway_band
from footstep_gym.planners.pso import CommandRepair
from footstep_gym.planners.staged import PeriodAwarePlanner, SnapshotPlanner
from footstep_gym.robot import Robot
from footstep_gym.sensing import Snapshot


@dataclass(frozen=True)
class Rollouts:
    """What a population of K-step sequences does (arrays over the population ``(N,)``)."""

    cost: np.ndarray  # the objective (lower is better)
    reached: np.ndarray  # bool: the goal reached within the sequence
    first_clear: np.ndarray  # [m] clearance beyond what is needed along the first step (< 0: collides)
    first_feasible: np.ndarray  # bool: the LIPM accepts the first step
    survived: np.ndarray  # steps taken before the first collision or infeasible step (K: all)
    end_centre: np.ndarray  # (N, 2) [m] robot centre after the last step taken (at the goal: where it arrived)
    time: np.ndarray  # [s] walked until then


class SwayTable:
    """``max(sway_band(robot, T))`` [m] interpolated over the period range (one table per robot)."""

    def __init__(self, robot: Robot, points: int = 33) -> None:
        lo = robot.t_ss[0] + robot.t_ds[0]
        hi = robot.t_ss[1] + robot.t_ds[1]
        self.periods = np.linspace(lo, hi, points)
        self.sway = np.array([max(sway_band(robot, round(float(t), 4))) for t in self.periods])

    def __call__(self, period: np.ndarray) -> np.ndarray:
        return np.interp(period, self.periods, self.sway)


def roll_out(robot: Robot, params: LookaheadParams, snapshot: Snapshot, predictor: ObstaclePredictor,
             commands: np.ndarray, safe: float, sway: SwayTable, speed: float, edge_samples: int) -> Rollouts:
    """Roll ``commands`` ``(N, K, 5)`` out from ``snapshot``'s stance and score them (see the module doc)."""
    n, k_steps, _ = commands.shape
    goal = np.asarray(snapshot.goal, dtype=float)
    tol = float(snapshot.goal_tolerance)
    side = int(snapshot.support_side)
    support = tuple(np.full(n, float(v)) for v in snapshot.support_foot)
    com = np.tile(np.asarray(snapshot.com_local, dtype=float), (n, 1))
    vel = np.tile(np.asarray(snapshot.vel_local, dtype=float), (n, 1))
    centre = np.tile(np.asarray(snapshot.centre, dtype=float), (n, 1))
    t = np.zeros(n)
    alive = np.ones(n, dtype=bool)
    reached = np.zeros(n, dtype=bool)
    t_goal = np.full(n, np.inf)
    survived = np.full(n, k_steps)
    penalty = np.zeros(n)
    soft = np.zeros(n)
    first_clear = np.full(n, -np.inf)
    first_feasible = np.zeros(n, dtype=bool)
    frac = np.linspace(0.0, 1.0, edge_samples)
    for k in range(k_steps):
        cmd = commands[:, k]
        res = lipm.check_steps(robot, com, vel, cmd, side)
        fx, fy, fyaw = footstep.place_foot(support, side, cmd[:, 0], cmd[:, 1], cmd[:, 2])
        period = cmd[:, 3] + cmd[:, 4]
        start = footstep.local_to_world(support, com)
        end = footstep.local_to_world((fx, fy, fyaw), res.end_com)
        pts = start[:, None] + frac[None, :, None] * (end - start)[:, None]
        times = t[:, None] + frac[None] * period[:, None]
        slack = (predictor.clearance(pts.reshape(-1, 2), times.reshape(-1)).reshape(n, -1).min(axis=1)
                 - safe - sway(period))
        if k == 0:
            first_clear, first_feasible = slack, res.feasible
        ok = alive & ~reached
        fail = ok & (~res.feasible | (slack < 0))
        weight = (k_steps - k) / k_steps  # an early failure costs more than a late one
        penalty += np.where(fail & ~res.feasible, params.infeasible_penalty * weight, 0.0)
        penalty += np.where(fail & res.feasible & (slack < 0), params.collision_penalty * weight, 0.0)
        survived = np.where(fail & (survived == k_steps), k, survived)
        soft += np.where(ok & ~fail, np.maximum(params.soft_margin_m - slack, 0.0), 0.0)
        alive &= ~fail
        new_centre = 0.5 * (np.stack(support[:2], axis=1) + np.stack([fx, fy], axis=1))
        go = alive & ~reached
        t = np.where(go, t + period, t)
        centre = np.where(go[:, None], new_centre, centre)
        arrived = go & (np.hypot(*(centre - goal).T) <= tol)
        t_goal = np.where(arrived, t, t_goal)
        reached |= arrived
        support = tuple(np.where(go, new, old) for new, old in zip((fx, fy, fyaw), support))
        com = np.where(go[:, None], res.end_com, com)
        vel = np.where(go[:, None], res.end_vel, vel)
        side = -side if k < k_steps - 1 else side
    # The last stance (the CoM where the sequence left it) must stay clear for dwell_s after the sequence.
    if params.dwell_s > 0:
        last = footstep.local_to_world(support, com)
        dwell = np.linspace(0.0, params.dwell_s, params.dwell_samples)
        times = t[:, None] + dwell[None]
        slack = (predictor.clearance(np.repeat(last, len(dwell), axis=0), times.reshape(-1)).reshape(n, -1)
                 .min(axis=1) - safe - sway(np.full(n, robot.nominal_period)))
        trapped = alive & ~reached & (slack < 0)
        penalty += np.where(trapped, params.collision_penalty / k_steps, 0.0)
    remaining = np.maximum(np.hypot(*(centre - goal).T) - tol, 0.0) / speed
    cost = np.where(reached, t_goal, t + remaining) + penalty + params.soft_weight * soft
    return Rollouts(cost, reached, first_clear, first_feasible, survived, centre, t)


class LookaheadPlanner(SnapshotPlanner):
    """``lookahead``: cross-entropy optimisation of K footsteps with their periods, replanned every footstep."""

    name = "lookahead"
    #: The greedy planner whose plan seeds every population (``greedy_seed``).
    greedy_class: type[PeriodAwarePlanner] = PeriodAwarePlanner

    def __init__(self, robot: Robot, config: PlannerConfig, seed: int | None = None, name: str | None = None) -> None:
        super().__init__(robot, config, seed, name)
        self.params = config.lookahead
        self.sway = SwayTable(robot)
        self.low = np.array([robot.stride_front[0], robot.stride_side[0], -robot.turn_limit, robot.t_ss[0]])
        self.high = np.array([robot.stride_front[1], robot.stride_side[1], robot.turn_limit, robot.t_ss[1]])
        box = np.array([[robot.stride_front[1], robot.stride_side[1], 0.0, robot.t_ss[0], robot.nominal_t_ds]])
        self.speed = centre_speed_bound(robot, box)
        self.repair = CommandRepair(robot, config.pso, vary_period=True, rescue=True)
        # The greedy planner's choice seeds every population: the lookahead keeps it unless K steps show better.
        self.greedy = self.greedy_class(robot, config, seed, name) if self.params.greedy_seed else None
        self._plan_ahead: np.ndarray | None = None

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        if self.greedy is not None:
            self.greedy.reset(seed)
        self._plan_ahead = None

    def _commands(self, x: np.ndarray, side: int) -> np.ndarray:
        """Decision vectors ``(N, K, 4)`` ``[S, L, θ, T_SS]`` as commands ``(N, K, 5)`` inside the box and each
        step's turn limits (sides alternate from ``side``), ``T_DS`` nominal."""
        x = np.clip(x, self.low, self.high)
        out = np.empty(x.shape[:2] + (5,))
        out[..., :4] = x
        out[..., 4] = self.robot.nominal_t_ds
        for k in range(x.shape[1]):
            lo, hi = footstep.turn_bounds(side if k % 2 == 0 else -side, self.robot)
            out[:, k, 2] = np.clip(out[:, k, 2], lo, hi)
        return out

    def _greedy_plan(self, snapshot: Snapshot) -> np.ndarray:
        """The greedy planner's command now and its RRT path's next footsteps, at its period, as ``(K, 4)``
        (stepping in place where the path ends)."""
        r, k = self.robot, self.params.horizon_steps
        command = self.greedy.act(None, snapshot)
        info = self.greedy.last_info
        period = float(info["period"])
        place = np.array([0.0, r.nominal_side_stride, 0.0, period - r.nominal_t_ds])
        out = [command[:4]]
        nodes = np.asarray(info.get("path", np.empty((0, 2))), dtype=float).reshape(-1, 2)
        half = 0.5 * r.nominal_side_stride
        side = int(snapshot.support_side)
        support = footstep.place_foot(snapshot.support_foot, side, *command[:3])
        heading = support[2]
        for i in range(2, min(len(nodes), k + 1)):
            side = -side
            d = nodes[i] - nodes[i - 1]
            heading = float(np.arctan2(d[1], d[0])) if np.hypot(*d) > 1e-9 else heading
            new = footstep.foot_from_node(nodes[i], heading, -side, half)
            s_, l_, th = footstep.command_between(support, side, new)
            out.append(np.array([s_, l_, th, period - r.nominal_t_ds]))
            support = new
        while len(out) < k:
            out.append(place)
        return np.stack(out)

    def _seeds(self, snapshot: Snapshot) -> np.ndarray:
        """Fixed members of the first population ``(M, K, 4)``: stepping in place at the nominal period, walking
        straight at the nominal and at a short period, last call's plan shifted by a footstep and, with
        ``greedy_seed``, the greedy planner's plan (last: the first mean)."""
        k = self.params.horizon_steps
        r = self.robot
        place = np.array([0.0, r.nominal_side_stride, 0.0, r.nominal_t_ss])
        out = [np.tile(place, (k, 1))]
        for t_ss in (r.nominal_t_ss, r.t_ss[0] + 0.1):
            out.append(np.tile([0.6 * r.stride_front[1], r.nominal_side_stride, 0.0, t_ss], (k, 1)))
        if self._plan_ahead is not None:
            out.append(np.concatenate([self._plan_ahead[1:], place[None]]))
        if self.greedy is not None:
            out.append(self._greedy_plan(snapshot))
        return np.clip(np.stack(out), self.low, self.high)

    def _rollout_predictor(self, snapshot: Snapshot) -> ObstaclePredictor:
        """What the rollouts check the body against: with the greedy planner, its prediction (unsteady horizons,
        sensed accelerations; it has just planned on ``snapshot``); else constant velocity."""
        if self.greedy is not None:
            return self.greedy.predictor
        return ObstaclePredictor(snapshot, horizon=self.config.prediction.horizon_s)

    def _plan(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        p, cfg = self.params, self.config
        side = int(snapshot.support_side)
        seeds = self._seeds(snapshot)
        predictor = self._rollout_predictor(snapshot)
        mean = seeds[-1].copy()
        std = np.broadcast_to(p.initial_std * (self.high - self.low), mean.shape).copy()
        best_x, best_cost = None, np.inf
        best_first = -np.inf
        if self.greedy is not None:
            greedy = roll_out(self.robot, p, snapshot, predictor, self._commands(seeds[-1:], side), self.safe_distance,
                              self.sway, self.speed, cfg.prediction.edge_samples)
            if greedy.survived[0] == p.horizon_steps:  # the greedy plan holds for K footsteps: keep it
                self._plan_ahead = seeds[-1]
                command = self.greedy.last_info["command"]
                return np.asarray(command, dtype=float).copy(), {
                    "lookahead_cost": float(greedy.cost[0]), "lookahead_reached_goal": bool(greedy.reached[0]),
                    "lookahead_kept_greedy": True, "predicted_feasible": self.greedy.last_info["predicted_feasible"],
                    "period": float(command[3] + command[4])}
        for it in range(p.iterations):
            x = mean[None] + std[None] * self.rng.standard_normal((p.samples,) + mean.shape)
            if it == 0:
                x = np.concatenate([seeds, x[len(seeds):]])
            x = np.clip(x, self.low, self.high)
            roll = roll_out(self.robot, p, snapshot, predictor, self._commands(x, side), self.safe_distance,
                            self.sway, self.speed, cfg.prediction.edge_samples)
            order = np.argsort(roll.cost, kind="stable")
            if roll.cost[order[0]] < best_cost:
                best_cost, best_x = float(roll.cost[order[0]]), x[order[0]].copy()
                best_first = float(roll.first_clear[order[0]])
                best_reached = bool(roll.reached[order[0]])
            elites = x[order[:p.elites]]
            mean = elites.mean(axis=0)
            std = np.maximum(elites.std(axis=0), p.min_std * (self.high - self.low))
        self._plan_ahead = best_x
        command = self._commands(best_x[None], side)[0, 0]
        repair = self.repair(snapshot, command, self.rng)  # the paper's stage 3, only if the LIPM rejects it
        return repair.command.copy(), {
            "lookahead_cost": best_cost, "lookahead_reached_goal": best_reached, "lookahead_kept_greedy": False,
            "lookahead_first_clearance": best_first, **repair.diagnostics(), "command_pre_pso": command,
            "period": float(repair.command[3] + repair.command[4]),
        }
