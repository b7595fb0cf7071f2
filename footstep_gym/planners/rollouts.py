"""``ObstacleCollision(T)`` of Algorithm 1: the walks stage 1 checks at a period ``T``.

Two predicates, both answering "which of these walks at period ``T`` stay free?"
(:meth:`free_walks`), "does ``T`` collide?" (``__call__``: every walk collides) and "how long
does the best walk at each of these periods stay free?" (:meth:`survivals`, for a period search
that scans rather than bisects):

* :class:`NextNodeFan` — the paper's check (Fig. 2): the next node at ``Max_step_size``
  in each of a fan of directions across the hardware angle limits (the "selectable
  range of a next node"), the body's step to it checked against the obstacles predicted
  over ``[0, T]``. One step: nothing beyond the next node is looked at.
* :class:`GoalRollouts` — our look-ahead (switch ``additions.long_lookahead``): a small
  library of goal-directed walks checked over the whole prediction horizon, so that a
  wing that will close the gap in three steps shortens the period now, not when it is
  too late.

Both evaluate from scratch at every call (the walk geometry is memoised, the verdicts
are not): the period search (:mod:`.period_search`) keeps what it needs in its record.

The walks are pursued and checked by the planner's kernels (:class:`footstep_gym.kernels.Kernels`:
:meth:`~footstep_gym.kernels.Kernels.pursue_lanes`, :meth:`~footstep_gym.kernels.Kernels.walks_survival`),
the compiled ones (which need a :class:`~.prediction.BodyModel`) or the numpy ones (any body check).
"""

from __future__ import annotations

import functools
import math
from abc import ABC, abstractmethod
from typing import Callable, Sequence

import numpy as np

from footstep_gym import footstep
from footstep_gym.footstep import LEFT, RIGHT
from footstep_gym.kernels import BodyCheck, Kernels, Lanes, WalkStart
from footstep_gym.kernels.numpy_kernels import support_normal
from footstep_gym.planners.walks import steps_to_goal
from footstep_gym.robot import Robot

#: ``(lo, hi)`` [m] of the first step's front stride the LIPM accepts at period ``T``, or ``None`` (no limit).
StrideWindow = Callable[[float], "tuple[float, float] | None"]


class _Walks(ABC):
    """What both predicates share: the body check, the kernels that check it and the ordering of free walks."""

    def __init__(self, body: BodyCheck, robot: Robot, start: WalkStart, goal: Sequence[float],
                 goal_radius: float, *, edge_samples: int, kernels: Kernels,
                 first_stride: StrideWindow | None = None) -> None:
        kernels.check_body(body)
        self.kernels = kernels
        self.body = body
        self.robot = robot
        self.start = start
        self.goal = np.asarray(goal, dtype=float)
        self.goal_radius = goal_radius
        self.edge_samples = edge_samples
        self.first_stride = first_stride

    @abstractmethod
    def nodes(self, period: float) -> tuple[np.ndarray, np.ndarray]:
        """Walk nodes ``(R, D + 1, 2)`` [m] and headings ``(R, D + 1)`` [rad] (index 0: the start) at ``period`` [s]."""

    def _free(self, nodes: np.ndarray, headings: np.ndarray, period: float) -> np.ndarray:
        """``(R,)`` bool: each walk's body stays free (until it reaches the goal region)."""
        return np.isinf(self.kernels.walks_survival(self.body, self.start, [(nodes, headings)], [period],
                                                    self.edge_samples, self.goal, self.goal_radius)[0])

    def free_walks(self, period: float, limit: int | None = None,
                   blocked_at: np.ndarray | None = None) -> list[np.ndarray]:
        """Free walks ``(k + 1, 2)`` [m] at ``period`` [s], those ending nearest the goal first (ties: the
        shortest), each cut at the step that brings its body into the goal region.

        ``blocked_at``: the walks' survival times at ``period`` if already known (a row of
        :meth:`survival_table`), so that they are not checked again.
        """
        nodes, headings = self.nodes(period)
        ok = self._free(nodes, headings, period) if blocked_at is None else np.isinf(blocked_at)
        free = nodes[ok]
        ends = steps_to_goal(free, self.goal, self.goal_radius) + 1
        walks = [walk[:end] for walk, end in zip(free, ends.tolist())]
        walks.sort(key=lambda w: (round(float(np.linalg.norm(w[-1] - self.goal)), 3), len(w)))
        return walks[:limit] if limit is not None else walks

    def __call__(self, period: float) -> bool:
        """``ObstacleCollision(period)``: every walk collides."""
        nodes, headings = self.nodes(period)
        return not self._free(nodes, headings, period).any()

    def survival_table(self, periods: Sequence[float]) -> list[np.ndarray]:
        """For each of ``periods`` [s], the time [s] each walk at that period is first blocked (``inf``: free).
        All walks of all periods are checked in one call (compiled: one loop)."""
        periods = [float(T) for T in periods]
        groups = [self.nodes(T) for T in periods]
        return self.kernels.walks_survival(self.body, self.start, groups, periods, self.edge_samples, self.goal,
                                           self.goal_radius)

    def survivals(self, periods: Sequence[float]) -> np.ndarray:
        """``(P,)`` [s]: for each of ``periods`` [s], how long the walk at that period that stays free
        longest does so; ``inf`` where ``ObstacleCollision(T)`` is false (the best of :meth:`survival_table`)."""
        return np.array([t.max() for t in self.survival_table(periods)])


class GoalRollouts(_Walks):
    """Goal-directed rollouts at period ``T``, checked over the prediction horizon.

    Rollout ``(k, j, w)`` follows the *lane* parallel to the line from the start node to
    the goal, offset sideways by ``lane_offsets[k]`` [m] (pure pursuit of the lane point
    ``lookahead`` ahead; the lane closes onto the goal over the last ``lookahead``), with a
    stride of ``stride_fractions[j] * step_size`` [m] after ``wait_steps[w]`` steps in place
    (so that "let the wing pass, then go" is in the library), the first stride clipped into
    ``first_stride(T)``. Every step turns at most the side-dependent hardware limits. A
    rollout that reaches the goal stops there. Rollouts span ``ceil(horizon / T)`` steps,
    but no more than the slowest of them needs to reach the goal:
    ``ceil(distance / shortest stride * depth_slack) + longest wait + extra_steps`` (the slack
    covers the lanes' detours; a long horizon costs nothing once the goal is within it).
    """

    def __init__(self, body: BodyCheck, robot: Robot, start: WalkStart, goal: Sequence[float],
                 goal_radius: float, *, horizon: float, step_size: float, lane_offsets: Sequence[float],
                 stride_fractions: Sequence[float], lookahead: float, edge_samples: int, kernels: Kernels,
                 wait_steps: Sequence[int] = (0,), depth_slack: float = 1.2, extra_steps: int = 2,
                 first_stride: StrideWindow | None = None) -> None:
        super().__init__(body, robot, start, goal, goal_radius, edge_samples=edge_samples, kernels=kernels,
                         first_stride=first_stride)
        self.horizon = horizon
        self.lookahead = lookahead
        self._offsets, self._strides, self._waits = _library(tuple(map(float, lane_offsets)),
                                                             tuple(map(float, stride_fractions)),
                                                             tuple(map(int, wait_steps)), float(step_size))
        axis = self.goal - start.node
        self._length = float(np.linalg.norm(axis))
        self._max_depth = (math.ceil(self._length / float(self._strides.min()) * depth_slack)
                           + int(self._waits.max()) + extra_steps)
        self._dir = axis / self._length if self._length > 0 else np.array([np.cos(start.heading),
                                                                           np.sin(start.heading)])
        self.lanes = Lanes(node=start.node, axis=self._dir, length=self._length, goal=self.goal,
                           goal_radius=float(goal_radius), lookahead=float(lookahead), heading=float(start.heading),
                           side=int(start.side), offsets=self._offsets, strides=self._strides, waits=self._waits,
                           left=footstep.turn_bounds(LEFT, robot), right=footstep.turn_bounds(RIGHT, robot))
        self._walk_cache: dict[tuple[float, float] | None, tuple[np.ndarray, np.ndarray]] = {}

    def nodes(self, period: float) -> tuple[np.ndarray, np.ndarray]:
        depth = max(1, min(math.ceil(self.horizon / period - 1e-9), self._max_depth))
        window = self.first_stride(period) if self.first_stride is not None else None
        if window not in self._walk_cache:  # the walks depend on the period only through the first stride
            self._walk_cache[window] = self.kernels.pursue_lanes(self.lanes, window, self._max_depth)
        nodes, headings = self._walk_cache[window]
        return nodes[:, : depth + 1], headings[:, : depth + 1]


@functools.lru_cache(maxsize=16)
def _library(lane_offsets: tuple[float, ...], stride_fractions: tuple[float, ...], wait_steps: tuple[int, ...],
             step_size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rollouts' lane offsets [m], strides [m] and waits [steps], one entry per rollout (read-only)."""
    off, frac, wait = np.meshgrid(np.asarray(lane_offsets, float), np.asarray(stride_fractions, float),
                                  np.asarray(wait_steps, dtype=np.int64), indexing="ij")
    out = (off.ravel(), frac.ravel() * step_size, wait.ravel())
    for a in out:
        a.flags.writeable = False
    return out


class NextNodeFan(_Walks):
    """The paper's ``ObstacleCollision(T)`` (Fig. 2): can the tree extend one node at period ``T``?

    The candidate next nodes lie at ``stride_fractions[j] * step_size`` [m] (clipped into
    ``first_stride(T)`` and to the distance to the goal) in ``directions`` headings spread
    evenly across the hardware angle limits of the support side (the selectable range of
    the next node); each body step to them is checked against the obstacles predicted
    over ``[0, T]``. The period collides iff every candidate does.

    ``check_node`` (``prediction.check: node``, the paper's Fig. 2 read literally): the next
    node itself is checked against the obstacles now and predicted after ``T``, instead of
    the body's step to it.
    """

    def __init__(self, body: BodyCheck, robot: Robot, start: WalkStart, goal: Sequence[float],
                 goal_radius: float, *, step_size: float, stride_fractions: Sequence[float], directions: int,
                 edge_samples: int, kernels: Kernels, first_stride: StrideWindow | None = None,
                 check_node: bool = False) -> None:
        super().__init__(body, robot, start, goal, goal_radius, edge_samples=edge_samples, kernels=kernels,
                         first_stride=first_stride)
        self.check_node = check_node
        lo, hi = footstep.turn_bounds(start.side, robot)
        turn, frac = np.meshgrid(np.linspace(lo, hi, directions), np.asarray(stride_fractions, float), indexing="ij")
        self._headings = float(start.heading) + turn.ravel()
        self._strides = frac.ravel() * step_size

    def nodes(self, period: float) -> tuple[np.ndarray, np.ndarray]:
        window = self.first_stride(period) if self.first_stride is not None else None
        stride = self._strides if window is None else np.clip(self._strides, *window)
        dist = float(np.linalg.norm(self.goal - self.start.node))
        stride = np.minimum(stride, dist)
        n = self._headings.size
        nodes = np.empty((n, 2, 2))
        nodes[:, 0] = self.start.node
        nodes[:, 1] = self.start.node + stride[:, None] * np.stack([np.cos(self._headings),
                                                                    np.sin(self._headings)], axis=1)
        headings = np.stack([np.full(n, float(self.start.heading)), self._headings], axis=1)
        return nodes, headings

    def _node_blocked_at(self, nodes: np.ndarray, period: float) -> np.ndarray:
        """``check_node``: ``(R,)`` [s] 0 where the next node is blocked now, ``period`` where only after
        ``period``, ``inf`` where it is free at both."""
        pts = np.repeat(nodes[:, 1], 2, axis=0)
        times = np.tile([0.0, float(period)], len(nodes))
        normal = support_normal(np.array([float(self.start.heading)]), np.array([self.start.side]))
        free = self.kernels.body_free(self.body, pts, times, np.repeat(normal, len(pts), axis=0),
                                      period).reshape(-1, 2)
        return np.where(~free[:, 0], 0.0, np.where(~free[:, 1], float(period), np.inf))

    def _free(self, nodes: np.ndarray, headings: np.ndarray, period: float) -> np.ndarray:
        if not self.check_node:
            return super()._free(nodes, headings, period)
        return np.isinf(self._node_blocked_at(nodes, period))

    def survival_table(self, periods: Sequence[float]) -> list[np.ndarray]:
        if not self.check_node:
            return super().survival_table(periods)
        return [self._node_blocked_at(self.nodes(float(T))[0], float(T)) for T in periods]
