"""``lattice``: A* over a discrete footstep set extended with discrete walking periods, in space and time.

The planner the paper argues against (Lee et al. §2.4: a discrete transition model that
includes the walking period "has too many cases to be practical"), in the style of the ROS
``footstep_planner`` family: every node is a stance (support foot pose and side, the LIPM's
CoM state relative to it) at a time ``t``; its children are the commands of a fixed
transition set, strides ``S`` x side strides ``L`` x turns ``θ`` x periods ``T``
(``T_SS = T - T_DS``, ``T_DS`` nominal, as the paper's tables vary the period). A child is
kept when the LIPM accepts the command from the carried CoM state
(:func:`footstep_gym.lipm.check_steps`) and the body's path over ``[t, t + T]`` stays clear
of the obstacles predicted at constant velocity (:class:`.prediction.ObstaclePredictor`,
the same prediction the staged planners use; never the simulator's future).

The cost is time: ``g`` = seconds walked, ``h`` = the distance of the robot centre to the
goal over the fastest centre speed of the transition set (admissible), ``f = g + w h``
(``w = heuristic_weight``; 1 is A*). States closer than the duplicate grid (position,
yaw, side, time) are one state. The search stops at the goal, at ``max_depth`` footsteps
or after ``max_expansions`` expansions; without a path to the goal the planner walks
towards the frontier node deepest in time, then nearest the goal. The first footstep of
the plan is executed and the search runs again at the next footstep (receding horizon).
"""

from __future__ import annotations

import heapq
import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.planners.params import LatticeParams, PlannerConfig
from footstep_gym.planners.prediction import ObstaclePredictor, body_path_points, sway_band
from footstep_gym.planners.staged import SnapshotPlanner
from footstep_gym.robot import Robot
from footstep_gym.sensing import Snapshot


def transition_set(robot: Robot, params: LatticeParams) -> np.ndarray:
    """The commands ``(K, 5)`` ``[S, L, θ, T_SS, T_DS]`` of the lattice: strides x side strides x turns x
    periods, each period split as ``T_SS = T - T_DS``, ``T_DS`` nominal. Turn limits are per side (the
    search drops the turns a side cannot make)."""
    t_ds = robot.nominal_t_ds
    rows = [(s, l, th, period - t_ds, t_ds)
            for s, l, th, period in itertools.product(params.strides, params.side_strides, params.turns,
                                                      params.periods)]
    return np.array(rows, dtype=float).reshape(-1, 5)


def centre_speed_bound(robot: Robot, commands: np.ndarray) -> float:
    """The fastest the robot centre moves [m/s] under ``commands`` after any command of the robot's box.

    A step moves the centre by half the swing foot's displacement: from ``(-S0, L0)`` to ``(S1, L1)``
    in the support foot's frame, at most ``hypot(2 S_max, L_max - L_min)``; over the set's shortest
    period. Turns are left out (their few millimetres at these strides), so with turns in the set
    ``h`` is a close estimate rather than a strict bound.
    """
    if not len(commands):
        raise ValueError("the lattice's transition set is empty")
    s_max = max(float(np.max(np.abs(commands[:, 0]))), *np.abs(robot.stride_front))
    lateral = robot.stride_side[1] - robot.stride_side[0]
    t_min = float(np.min(commands[:, 3] + commands[:, 4]))
    return 0.5 * math.hypot(2.0 * s_max, lateral) / t_min


@dataclass(frozen=True)
class _Nodes:
    """Stances of the search as arrays over ``n``: the root, or the children of one expansion (one support side and
    depth). A frontier entry is one of them, ``(nodes, j)``."""

    support: np.ndarray  # (n, 3) support foot pose (x, y, yaw) [m, m, rad], world
    side: int  # +1 left, -1 right
    centre: np.ndarray  # (n, 2) robot centre [m], world
    com: np.ndarray  # (n, 2) CoM relative to the support foot, its frame [m]
    vel: np.ndarray  # (n, 2) CoM velocity, same frame [m/s]
    time: np.ndarray  # (n,) [s] from now
    depth: int  # footsteps from the start
    first: np.ndarray  # (n,) index of the first command of the path that reached each node (-1 at the root)
    h: np.ndarray  # (n,) heuristic time to goal [s]
    at_goal: np.ndarray  # (n,) bool: the centre is within the goal tolerance
    key: np.ndarray  # (n, 5) int: the duplicate grid's cell (x, y, yaw, side, time)


@dataclass(frozen=True)
class LatticeResult:
    """What one search found: the first command index (``-1``: none), whether it reaches the goal, the counts."""

    first: int
    reached_goal: bool
    expanded: int
    generated: int
    depth: int  # footsteps of the chosen plan
    plan_time_s: float  # [s] walking time of the chosen plan (to the goal or the chosen frontier node)


class LatticeSearch:
    """The A* itself, over one snapshot's predicted obstacles (see the module doc)."""

    def __init__(self, robot: Robot, params: LatticeParams, safe_distance: float, edge_samples: int) -> None:
        self.robot = robot
        self.params = params
        self.safe = safe_distance
        self.edge_samples = edge_samples
        self.commands = transition_set(robot, params)
        self.speed = centre_speed_bound(robot, self.commands)
        lo_l, hi_l = footstep.turn_bounds(footstep.LEFT, robot)
        lo_r, hi_r = footstep.turn_bounds(footstep.RIGHT, robot)
        theta = self.commands[:, 2]
        #: The commands each support side may take (indices into :attr:`commands`).
        self.by_side = {footstep.LEFT: np.flatnonzero((theta >= lo_l - 1e-9) & (theta <= hi_l + 1e-9)),
                        footstep.RIGHT: np.flatnonzero((theta >= lo_r - 1e-9) & (theta <= hi_r + 1e-9))}
        #: The clearance [m] each command's CoM path needs: the safe distance plus the LIPM's sway at its period.
        self.needed = safe_distance + np.array([max(sway_band(robot, round(float(t), 4)))
                                                for t in self.commands[:, 3] + self.commands[:, 4]])

    def _nodes(self, support: np.ndarray, side: int, centre: np.ndarray, com: np.ndarray, vel: np.ndarray,
               time: np.ndarray, depth: int, first: np.ndarray, goal: np.ndarray, tolerance: float) -> _Nodes:
        p = self.params
        dist = np.hypot(centre[:, 0] - goal[0], centre[:, 1] - goal[1])
        key = np.stack([np.round(support[:, 0] / p.xy_resolution_m), np.round(support[:, 1] / p.xy_resolution_m),
                        np.round(footstep.wrap_angle(support[:, 2]) / p.yaw_resolution_rad),
                        np.full(len(time), float(side)), np.round(time / p.time_resolution_s)], axis=1)
        return _Nodes(support, side, centre, com, vel, time, depth, first,
                      np.maximum(dist - tolerance, 0.0) / self.speed, (dist <= tolerance) & (depth > 0),
                      key.astype(np.int64))

    def children(self, nodes: _Nodes, j: int, predictor: ObstaclePredictor, goal: np.ndarray, tolerance: float
                 ) -> _Nodes | None:
        """The nodes one command of the set away from node ``j`` of ``nodes`` that the LIPM accepts and the
        prediction keeps clear (``None``: no such node)."""
        side, support, time = nodes.side, tuple(float(v) for v in nodes.support[j]), float(nodes.time[j])
        idx = self.by_side[side]
        cmds = self.commands[idx]
        res = lipm.check_steps(self.robot, nodes.com[j], nodes.vel[j], cmds, side)
        ok = res.feasible
        if not ok.any():
            return None
        idx, cmds = idx[ok], cmds[ok]
        end_com, end_vel = res.end_com[ok], res.end_vel[ok]
        fx, fy, fyaw = footstep.place_foot(support, side, cmds[:, 0], cmds[:, 1], cmds[:, 2])
        feet = np.stack([fx, fy], axis=1)
        period = cmds[:, 3] + cmds[:, 4]
        start = footstep.local_to_world(support, nodes.com[j])[None]
        end = footstep.local_to_world((fx, fy, fyaw), end_com)
        clear = self.body_clearance(predictor, start, end, time, period) >= self.needed[idx]
        if not clear.any():
            return None
        first = idx[clear] if nodes.first[j] < 0 else np.full(int(clear.sum()), nodes.first[j])
        return self._nodes(np.stack([fx, fy, fyaw], axis=1)[clear], -side,
                           0.5 * (np.asarray(support[:2])[None] + feet[clear]), end_com[clear], end_vel[clear],
                           time + period[clear], nodes.depth + 1, first, goal, tolerance)

    def body_clearance(self, predictor: ObstaclePredictor, com_start: np.ndarray, com_end: np.ndarray,
                       t_start: float, period: np.ndarray) -> np.ndarray:
        """The smallest clearance [m] of the body's centre along straight CoM paths ``com_start -> com_end``
        ``(N, 2)`` over ``[t_start, t_start + period]``, ``(N,)``; a command's path is clear where this reaches its
        :attr:`needed`."""
        n = len(period)
        pts, times = body_path_points(np.broadcast_to(com_start, (n, 2)), com_end, np.full(n, t_start),
                                      t_start + period, self.edge_samples)
        return predictor.clearance(pts, times).reshape(n, -1).min(axis=1)

    def search(self, snapshot: Snapshot, predictor: ObstaclePredictor) -> LatticeResult:
        """A* from the snapshot's stance to its goal over ``predictor``'s obstacles."""
        p = self.params
        goal = np.asarray(snapshot.goal, dtype=float)
        tol = float(snapshot.goal_tolerance)
        root = self._nodes(np.asarray(snapshot.support_foot, dtype=float).reshape(1, 3), int(snapshot.support_side),
                           np.asarray(snapshot.centre, dtype=float).reshape(1, 2),
                           np.asarray(snapshot.com_local, dtype=float).reshape(1, 2),
                           np.asarray(snapshot.vel_local, dtype=float).reshape(1, 2), np.zeros(1), 0,
                           np.full(1, -1), goal, tol)
        tie = itertools.count()
        frontier: list[tuple[float, int, _Nodes, int]] = [(p.heuristic_weight * float(root.h[0]), next(tie), root, 0)]
        closed: set[tuple[int, ...]] = set()
        best, best_j = root, 0  # the deepest node in time, then nearest the goal
        expanded = generated = 0
        while frontier and expanded < p.max_expansions:
            _, _, nodes, j = heapq.heappop(frontier)
            key = tuple(nodes.key[j].tolist())
            if key in closed:
                continue
            closed.add(key)
            if nodes.at_goal[j]:
                return LatticeResult(int(nodes.first[j]), True, expanded, generated, nodes.depth,
                                     float(nodes.time[j]))
            if (nodes.depth, -nodes.h[j]) > (best.depth, -best.h[best_j]):
                best, best_j = nodes, j
            if nodes.depth >= p.max_depth:
                continue
            expanded += 1
            kids = self.children(nodes, j, predictor, goal, tol)
            if kids is None:
                continue
            generated += len(kids.time)
            for k, f in enumerate((kids.time + p.heuristic_weight * kids.h).tolist()):
                heapq.heappush(frontier, (f, next(tie), kids, k))
        return LatticeResult(int(best.first[best_j]), False, expanded, generated, best.depth,
                             float(best.time[best_j]))


class LatticePlanner(SnapshotPlanner):
    """``lattice``: a discrete footstep x period A* in space and time, replanned every footstep (module doc)."""

    name = "lattice"

    def __init__(self, robot: Robot, config: PlannerConfig, seed: int | None = None, name: str | None = None) -> None:
        super().__init__(robot, config, seed, name)
        self.search = LatticeSearch(robot, config.lattice, self.safe_distance, config.prediction.edge_samples)

    def _plan(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        predictor = ObstaclePredictor(snapshot, horizon=self.config.prediction.horizon_s)
        result = self.search.search(snapshot, predictor)
        if result.first >= 0:
            command = self.search.commands[result.first].copy()
        else:
            command = self._least_bad(snapshot, predictor)
        info: dict[str, Any] = {
            "lattice_expanded": result.expanded, "lattice_generated": result.generated,
            "lattice_reached_goal": result.reached_goal, "lattice_depth": result.depth,
            "lattice_plan_s": result.plan_time_s, "lattice_transitions": len(self.search.commands),
            "period": float(command[3] + command[4]),
        }
        return command, info

    def _least_bad(self, snapshot: Snapshot, predictor: ObstaclePredictor) -> np.ndarray:
        """No command of the set is both feasible and clear: the LIPM-feasible one whose CoM path keeps the most
        clearance (the nominal command if the LIPM rejects them all)."""
        side = int(snapshot.support_side)
        cmds = self.search.commands[self.search.by_side[side]]
        res = lipm.check_steps(self.robot, snapshot.com_local, snapshot.vel_local, cmds, side)
        if not res.feasible.any():
            return self.robot.nominal_command.copy()
        cmds, end_com = cmds[res.feasible], res.end_com[res.feasible]
        fx, fy, fyaw = footstep.place_foot(snapshot.support_foot, side, cmds[:, 0], cmds[:, 1], cmds[:, 2])
        end = footstep.local_to_world((fx, fy, fyaw), end_com)
        clear = self.search.body_clearance(predictor, np.asarray(snapshot.com, dtype=float), end, 0.0,
                                           cmds[:, 3] + cmds[:, 4])
        return cmds[int(np.argmax(clear))].copy()
