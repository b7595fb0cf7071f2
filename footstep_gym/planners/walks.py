"""Data shared by the planner's stages: where a walk starts, and the body check of a walk.

A *walk* is a chain of nodes (robot centres in the paper's footstep convention, Fig. 5)
starting at the support foot's node, one step per period. Stage 1 checks whole walks
(:mod:`.rollouts`), stage 2 grows a tree of them (:mod:`.rrt`); both start from a
:class:`WalkStart` and move the body (the robot centre between its feet) along the
midpoints of consecutive nodes: step ``d`` moves it from ``(n[d-2] + n[d-1]) / 2`` to
``(n[d-1] + n[d]) / 2`` during ``[(d - 1) T, d T]`` (docs/model.md §5).

**Two routes.** The checks of whole walks (:func:`walks_survival_at`), like the RRT's batches
and the rollouts' lane pursuit, exist twice: a compiled loop (:mod:`.kernels`) and its numpy
reference, which the tests hold it equal to. Which one runs is the argument ``compiled``, the
setting ``kernels.compiled`` of ``configs/planner.yaml`` passed down by the stages, never the type
of the body check (:func:`on_route`). ``compiled=False`` runs numpy everywhere and never imports
numba.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, Sequence

import numpy as np

from footstep_gym.planners.prediction import BodyModel, body_path_points, step_fractions, support_normal


class BodyCheck(Protocol):
    """``free(points (N, 2), times (N,), support_normals (N, 2), period) -> (N,)`` bool, and ``slack``
    (the same arguments) -> clearance [m] beyond the required one (e.g. :class:`.prediction.BodyModel`)."""

    def free(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray,
             period: float) -> np.ndarray: ...

    def slack(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray,
              period: float) -> np.ndarray: ...


@dataclass(frozen=True)
class WalkStart:
    """Where a walk (a rollout or the RRT) starts, in the paper's node convention.

    ``node``: the support foot's node (the point ``half_width`` inside the support foot,
    perpendicular to its yaw, i.e. the inverse of :func:`footstep.foot_from_node`);
    ``heading``: the support foot's yaw; ``side``: the support side (+1 left, -1 right);
    ``body``: where the body (CoM ground projection) is now; ``previous_node``: the swing
    foot's node.
    """

    node: np.ndarray  # (2,) [m]
    heading: float  # [rad]
    side: int
    body: np.ndarray  # (2,) [m]
    previous_node: np.ndarray  # (2,) [m]


def node_of_foot(foot_pose: Sequence[float], side: int, half_width: float) -> np.ndarray:
    """The node [m] a foot ``(x, y, yaw)`` stands for: inverse of :func:`footstep.foot_from_node`."""
    x, y, yaw = foot_pose
    return np.array([x + side * half_width * np.sin(yaw), y - side * half_width * np.cos(yaw)])


def walk_start(snapshot, half_width: float) -> WalkStart:
    """The :class:`WalkStart` of a :class:`~footstep_gym.sensing.Snapshot` (``half_width`` [m])."""
    side = int(snapshot.support_side)
    return WalkStart(
        node=node_of_foot(snapshot.support_foot, side, half_width),
        heading=float(snapshot.support_foot[2]),
        side=side,
        body=np.asarray(snapshot.com, dtype=float),
        previous_node=node_of_foot(snapshot.swing_foot, -side, half_width),
    )


def on_route(body: BodyCheck, compiled: bool) -> BodyCheck:
    """``body`` on the route ``compiled`` names (``configs/planner.yaml``'s ``kernels.compiled``).

    Compiled: the walks' and the RRT's compiled loops read the shape table of a
    :class:`~.prediction.BodyModel`'s predictor, so any other body check raises :class:`TypeError`;
    the model returned also checks single points in the compiled kernel. Numpy (the reference): a
    ``BodyModel`` checks its points in numpy too, any other body check (a test's) is used as it is.
    """
    if isinstance(body, BodyModel):
        return body.routed(compiled)
    if compiled:
        raise TypeError(f"the compiled walks and RRT (kernels.compiled: true) need a prediction.BodyModel, whose "
                        f"shape table they read; got {type(body).__name__}: plan with kernels.compiled false "
                        f"(compiled=False) to check walks with any BodyCheck")
    return body


def walks_free(body: BodyCheck, start: WalkStart, nodes: np.ndarray, headings: np.ndarray, period: float,
               edge_samples: int, goal: np.ndarray, goal_radius: float, *, compiled: bool) -> np.ndarray:
    """``(R,)`` bool: walk ``r`` (nodes ``(R, D + 1, 2)`` [m], row 0 the start; step ``d`` during
    ``[(d-1) T, d T]`` with ``T = period`` [s]) keeps its body free of every obstacle.

    Each body segment is checked at ``edge_samples`` points by ``body.free`` with the
    support foot's normal of its step (the CoM sway). Once a walk's body (the midpoint of its
    last two nodes, where the env measures the robot centre) has reached the goal region
    (``goal (2,)``, ``goal_radius`` [m]) the episode is over: later steps are not checked.
    ``compiled``: the route (:func:`walks_survival_at`).
    """
    return np.isinf(walks_survival(body, start, nodes, headings, period, edge_samples, goal, goal_radius,
                                   compiled=compiled))


def walks_survival(body: BodyCheck, start: WalkStart, nodes: np.ndarray, headings: np.ndarray, period: float,
                   edge_samples: int, goal: np.ndarray, goal_radius: float, *, compiled: bool) -> np.ndarray:
    """``(R,)`` [s]: the time of each walk's first blocked body point, ``inf`` for a free walk
    (the checks of :func:`walks_free`, which is ``isinf`` of this)."""
    return walks_survival_at(body, start, [(nodes, headings)], [period], edge_samples, goal, goal_radius,
                             compiled=compiled)[0]


def walks_survival_at(body: BodyCheck, start: WalkStart, walks: Sequence[tuple[np.ndarray, np.ndarray]],
                      periods: Sequence[float], edge_samples: int, goal: np.ndarray, goal_radius: float, *,
                      compiled: bool) -> list[np.ndarray]:
    """:func:`walks_survival` of several groups of walks, group ``i`` (``(nodes, headings)``) at ``periods[i]``
    [s]. ``compiled``: all in one compiled call (:func:`.kernels.walks_survival`; a period search asks about
    many periods), which needs a :class:`BodyModel`; else group by group in numpy (:func:`_walks_survival_numpy`,
    the reference), with any :class:`BodyCheck` (:func:`on_route`)."""
    body = on_route(body, compiled)
    if compiled:
        return _walks_survival_compiled(body, start, walks, periods, edge_samples, goal, goal_radius)
    return [_walks_survival_numpy(body, start, n, h, T, edge_samples, goal, goal_radius)
            for (n, h), T in zip(walks, periods)]


def _walks_survival_compiled(body: BodyModel, start: WalkStart, walks: Sequence[tuple[np.ndarray, np.ndarray]],
                             periods: Sequence[float], edge_samples: int, goal: np.ndarray,
                             goal_radius: float) -> list[np.ndarray]:
    """:func:`walks_survival_at` in one compiled loop (:func:`.kernels.walks_survival`)."""
    from footstep_gym.planners import kernels  # imports numba: only on the compiled route

    pred = body.predictor
    counts = [len(n) for n, _ in walks]
    widths = [n.shape[1] for n, _ in walks]
    rows, depth = sum(counts), max(widths)
    first = np.cumsum([0, *counts])
    if min(widths) == depth:  # the usual case: one call each
        nodes, headings = np.concatenate([n for n, _ in walks]), np.concatenate([h for _, h in walks])
    else:
        nodes = np.empty((rows, depth, 2))  # a row's nodes beyond its own n_nodes are never read
        headings = np.empty((rows, depth))
        for (n, h), a, b in zip(walks, first[:-1], first[1:]):
            nodes[a:b, : n.shape[1]], headings[a:b, : n.shape[1]] = n, h
    n_nodes = np.repeat(np.asarray(widths, dtype=np.int64), counts)
    period = np.repeat(np.asarray(periods, dtype=float), counts)
    shift, needed = np.repeat(np.array([body.shift_and_clearance(T) for T in periods]).reshape(-1, 2), counts, axis=0).T
    shift, needed = np.ascontiguousarray(shift), np.ascontiguousarray(needed)
    blocked_at = np.empty(rows)
    kernels.walks_survival(float(start.previous_node[0]), float(start.previous_node[1]), float(start.body[0]),
                           float(start.body[1]), nodes, headings, n_nodes, int(start.side), period,
                           step_fractions(edge_samples), float(goal[0]), float(goal[1]), float(goal_radius), shift,
                           needed, pred.kernel_shapes, pred.kernel_radius, pred.kernel_horizon, blocked_at)
    return [blocked_at[a:b] for a, b in zip(first[:-1], first[1:])]


def _walks_survival_numpy(body: BodyCheck, start: WalkStart, nodes: np.ndarray, headings: np.ndarray,
                          period: float, edge_samples: int, goal: np.ndarray, goal_radius: float) -> np.ndarray:
    """:func:`walks_survival` in numpy, for any :class:`BodyCheck`: the reference implementation, the test
    oracle of the compiled loop (``tests/test_kernels.py``), and the route of ``kernels.compiled: false``."""
    n_roll, n_nodes, _ = nodes.shape
    prev = np.concatenate([np.tile(start.previous_node, (n_roll, 1, 1)), nodes[:, :-1]], axis=1)
    bodies = 0.5 * (prev + nodes)  # body at the end of step d = midpoint(n[d-1], n[d])
    bodies[:, 0] = start.body
    starts = bodies[:, :-1].reshape(-1, 2)
    ends = bodies[:, 1:].reshape(-1, 2)
    d = np.tile(np.arange(n_nodes - 1, dtype=float), n_roll)
    pts, times = body_path_points(starts, ends, d * period, (d + 1) * period, edge_samples)
    sides = start.side * np.where(np.arange(n_nodes - 1) % 2 == 0, 1.0, -1.0)
    normals = support_normal(headings[:, :-1], sides[None, :]).reshape(-1, 2)
    normals = np.repeat(normals, edge_samples, axis=0)
    free = body.free(pts, times, normals, period).reshape(n_roll, -1)
    reached = np.linalg.norm(bodies[:, 1:] - goal, axis=-1) <= goal_radius
    done_before = np.concatenate([np.zeros((n_roll, 1), bool), np.cumsum(reached, axis=1)[:, :-1] > 0], axis=1)
    blocked = ~(free | np.repeat(done_before, edge_samples, axis=1))
    first = np.argmax(blocked, axis=1)
    return np.where(blocked.any(axis=1), times.reshape(n_roll, -1)[np.arange(n_roll), first], np.inf)


def trim_at_goal(nodes: np.ndarray, goal: np.ndarray, goal_radius: float) -> np.ndarray:
    """A walk's nodes ``(k + 1, 2)`` up to (and including) the first step that brings its body (the
    midpoint of the step's two nodes) into the goal region."""
    return nodes[: int(steps_to_goal(nodes[None], goal, goal_radius)[0]) + 1]


def steps_to_goal(nodes: np.ndarray, goal: np.ndarray, goal_radius: float) -> np.ndarray:
    """``(R,)``: for walks ``(R, k + 1, 2)`` [m], the number of the first step that brings the body (the
    midpoint of the step's two nodes) into the goal region, ``k`` if none does (:func:`trim_at_goal`
    keeps the nodes up to it)."""
    if nodes.shape[1] < 2:  # no step at all
        return np.zeros(len(nodes), dtype=int)
    bodies = 0.5 * (nodes[:, :-1] + nodes[:, 1:])
    inside = np.linalg.norm(bodies - goal, axis=-1) <= goal_radius
    return np.where(inside.any(axis=1), np.argmax(inside, axis=1) + 1, nodes.shape[1] - 1)
