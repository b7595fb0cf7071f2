"""Where a walk starts, and the walks' geometry shared by the planner's stages.

A *walk* is a chain of nodes (robot centres in the paper's footstep convention, Fig. 5)
starting at the support foot's node, one step per period. Stage 1 checks whole walks
(:mod:`.rollouts`), stage 2 grows a tree of them (:mod:`.rrt`); both start from a
:class:`WalkStart` and move the body (the robot centre between its feet) along the
midpoints of consecutive nodes: step ``d`` moves it from ``(n[d-2] + n[d-1]) / 2`` to
``(n[d-1] + n[d]) / 2`` during ``[(d - 1) T, d T]`` (docs/model.md §5). The checks of whole walks
are a kernel (:meth:`footstep_gym.kernels.Kernels.walks_survival`).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from footstep_gym.kernels import BodyCheck, WalkStart  # noqa: F401  (the planners' names for them)


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
