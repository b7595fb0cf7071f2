"""The planners' kernels in numpy (:class:`NumpyKernels`): the readable implementation and the test oracle.

Each method is the vectorised form of a loop of :mod:`.numba_kernels`, with the same signature
(:class:`~footstep_gym.kernels.Kernels`). Walks and RRT edges are checked through ``body.free``, so
any :class:`~footstep_gym.kernels.BodyCheck` will do (a test's toy check included). 2D points are
complex numbers ``x + iy`` where one expression then serves all shapes. No numba here.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from footstep_gym import footstep
from footstep_gym.kernels import BodyCheck, Lanes, ShapeTable, TreeArrays, TreeStep, WalkStart, step_fractions


def centre_line_gap2(p: np.ndarray, centre: np.ndarray, rot: np.ndarray, a: np.ndarray, ab: np.ndarray,
                     ab2: np.ndarray) -> np.ndarray:
    """Squared distances ``(N, S)`` [m^2] from points ``p`` (N,) to shapes' centre lines (complex, world frame).

    A shape's body sits at ``centre`` turned by ``rot`` (unit complex; both (N, S) or broadcastable); its centre
    line runs from ``a`` to ``a + ab`` in the body frame, ``ab2 = |ab|^2`` (a circle: ``ab = 0``).
    """
    ap = p[:, None] - (centre + rot * a)
    if not np.any(ab2):  # circles only: the nearest point of each centre line is its one point (u = 0 below)
        return ap.real ** 2 + ap.imag ** 2
    ab_world = rot * ab
    u = (ap * ab_world.conj()).real / np.where(ab2 > 0, ab2, 1.0)
    np.clip(u, 0.0, 1.0, out=u)
    d = ap - u * ab_world
    return d.real ** 2 + d.imag ** 2


def shape_gap2(shapes: ShapeTable, points: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Squared distances ``(N, S)`` [m^2] from point ``i`` at ``times[i]`` [s] to each shape's centre line, the
    shape at ``p + v t`` (plus ``a tau (t - tau / 2)``, ``tau = min(t, acceleration_time)``, for an accelerating
    one) turned by ``angle + omega t``; ``inf`` where ``t`` is beyond the shape's horizon."""
    c = shapes.complex_form
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    p = pts[:, 0] + 1j * pts[:, 1]
    tt = np.broadcast_to(np.asarray(times, dtype=float), p.shape)[:, None]
    rot = np.exp(1j * (c["angle"] + c["omega"] * tt))
    centre = c["position"] + c["velocity"] * tt
    if c["accelerates"]:  # accelerating for tau = min(t, cap), then at the velocity reached
        tau = np.minimum(tt, c["acceleration_time"])
        centre = centre + c["acceleration"] * (tau * (tt - 0.5 * tau))
    d2 = centre_line_gap2(p, centre, rot, c["a"], c["ab"], c["ab2"])
    if np.isfinite(shapes.horizon).any():
        d2[tt > shapes.horizon] = np.inf
    return d2


def body_path_points(starts: np.ndarray, ends: np.ndarray, t_start: np.ndarray, t_end: np.ndarray,
                     samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Points and times along straight body-path segments, ``samples`` per segment, ends included.

    ``starts``/``ends`` ``(N, 2)``, ``t_start``/``t_end`` ``(N,)``; returns ``(N * samples, 2)``
    points and ``(N * samples,)`` times, segment by segment.
    """
    s = step_fractions(samples)
    pts = starts[:, None, :] + s[None, :, None] * (ends - starts)[:, None, :]
    times = t_start[:, None] + s[None, :] * (t_end - t_start)[:, None]
    return pts.reshape(-1, 2), times.reshape(-1)


def support_normal(heading: np.ndarray, side: np.ndarray) -> np.ndarray:
    """Unit vectors ``(N, 2)`` towards the support foot: ``side`` (+1 left) times the left normal of ``heading``."""
    heading = np.asarray(heading, dtype=float)
    side = np.asarray(side, dtype=float)
    return np.stack([-side * np.sin(heading), side * np.cos(heading)], axis=-1)


def in_goal(xy: np.ndarray, goal: np.ndarray, goal_radius: float) -> np.ndarray:
    """Whether each body ``(N, 2)`` [m] is within ``goal_radius`` [m] of ``goal``."""
    return np.linalg.norm(xy - goal, axis=1) <= goal_radius


#: Where :meth:`NumpyKernels.walks_survival` stops to drop the walks already blocked (fractions of their steps):
#: most blocked walks are blocked early, and the steps after a walk's first blocked point are not checked.
SURVIVAL_STAGES = (0.25,)
#: A library of fewer points than this is checked in one stage (a second call costs more than it saves).
STAGED_POINTS = 1024


class NumpyKernels:
    """:class:`~footstep_gym.kernels.Kernels` in numpy; the RRT's batch is split into Algorithm 2's steps
    (:meth:`nearest_nodes`, :meth:`restrict_to_angle_limits`, :meth:`steer`, :meth:`edges_free`,
    :meth:`insert`), which a test may override to watch the decisions."""

    name = "numpy"

    def check_body(self, body: BodyCheck) -> None:
        """Any body check will do."""

    def points_free(self, shapes: ShapeTable, points: np.ndarray, times: np.ndarray,
                    safe_distance: float | np.ndarray) -> np.ndarray:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        return (shape_gap2(shapes, pts, times) >= (shapes.radius + safe_distance) ** 2).all(axis=1)

    def body_free(self, body: BodyCheck, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray,
                  period: float) -> np.ndarray:
        return body.free(points, times, support_normals, period)

    # ------------------------------------------------------------------ whole walks
    def walks_survival(self, body: BodyCheck, start: WalkStart, walks: Sequence[tuple[np.ndarray, np.ndarray]],
                       periods: Sequence[float], edge_samples: int, goal: np.ndarray,
                       goal_radius: float) -> list[np.ndarray]:
        return [self._survival(body, start, nodes, headings, float(T), edge_samples, goal, goal_radius)
                for (nodes, headings), T in zip(walks, periods)]

    def _survival(self, body: BodyCheck, start: WalkStart, nodes: np.ndarray, headings: np.ndarray, period: float,
                  edge_samples: int, goal: np.ndarray, goal_radius: float) -> np.ndarray:
        """One group of :meth:`walks_survival`."""
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
        reached = np.linalg.norm(bodies[:, 1:] - goal, axis=-1) <= goal_radius
        done_before = np.concatenate([np.zeros((n_roll, 1), bool), np.cumsum(reached, axis=1)[:, :-1] > 0], axis=1)
        # Points past the step that brings a walk's body into the goal region do not count, and the walks are
        # checked in stages of their steps (SURVIVAL_STAGES): only those still free and not yet in the goal region
        # go on to the next stage.
        unchecked = np.repeat(done_before, edge_samples, axis=1)
        pts, times, normals = pts.reshape(n_roll, -1, 2), times.reshape(n_roll, -1), normals.reshape(n_roll, -1, 2)
        out = np.full(n_roll, np.inf)
        alive = np.arange(n_roll)
        stages = SURVIVAL_STAGES if pts.size >= 2 * STAGED_POINTS else ()
        bounds = sorted({0, n_nodes - 1, *(math.ceil(f * (n_nodes - 1)) for f in stages)})
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            cols = slice(lo * edge_samples, hi * edge_samples)
            rows = alive if len(alive) < n_roll else slice(None)  # every walk: no copy
            free = self.body_free(body, pts[rows, cols].reshape(-1, 2), times[rows, cols].reshape(-1),
                                  normals[rows, cols].reshape(-1, 2), period).reshape(len(alive), -1)
            blocked = ~(free | unchecked[alive, cols])
            hit = blocked.any(axis=1)
            out[alive[hit]] = times[alive[hit], lo * edge_samples + np.argmax(blocked[hit], axis=1)]
            alive = alive[~hit]
            if hi < n_nodes - 1:
                alive = alive[~unchecked[alive, hi * edge_samples]]  # in the goal region: nothing more to check
            if not alive.size:
                break
        return out

    def pursue_lanes(self, lanes: Lanes, window: tuple[float, float] | None,
                     depth: int) -> tuple[np.ndarray, np.ndarray]:
        n_roll = lanes.offsets.size
        node0 = complex(*lanes.node)
        axis = complex(*lanes.axis)
        goal = complex(*lanes.goal)
        lane = lanes.offsets * (1j * axis)
        limits = {footstep.LEFT: lanes.left, footstep.RIGHT: lanes.right}
        pos = np.full(n_roll, node0)
        heading = np.full(n_roll, float(lanes.heading))
        out = np.empty((n_roll, depth + 1), dtype=complex)
        headings = np.empty((n_roll, depth + 1))
        out[:, 0], headings[:, 0] = pos, heading
        side = lanes.side
        arrived = np.zeros(n_roll, dtype=bool)
        for d in range(1, depth + 1):
            if arrived.all():  # every walk stands in the goal region: it stays there (steps of zero length)
                out[:, d:], headings[:, d:] = pos[:, None], heading[:, None]
                break
            ahead = ((pos - node0) * axis.conjugate()).real + lanes.lookahead  # along the axis, plus the lookahead
            taper = np.clip((lanes.length - ahead) / lanes.lookahead, 0.0, 1.0)  # the lane closes onto the goal
            aim = node0 + np.minimum(ahead, lanes.length) * axis + taper * lane
            lo, hi = limits[side]
            to_aim = (aim - pos) * np.exp(-1j * heading)
            turn = np.clip(np.arctan2(to_aim.imag, to_aim.real), lo, hi)  # np.angle
            heading = np.where(arrived, heading, heading + turn)
            stride = np.where(d <= lanes.waits, 0.0, lanes.strides)
            if d == 1 and window is not None:
                stride = np.clip(stride, *window)
            stride = np.where(arrived, 0.0, np.minimum(stride, np.abs(goal - pos)))  # never past the goal
            new = pos + stride * np.exp(1j * heading)
            arrived |= np.abs(0.5 * (pos + new) - goal) <= lanes.goal_radius  # the body is in: it stands still
            pos = new
            out[:, d], headings[:, d] = pos, heading
            side = -side
        return np.stack([out.real, out.imag], axis=-1), headings

    # ------------------------------------------------------------------ the RRT
    def extend_tree(self, tree: TreeArrays, step: TreeStep, body: BodyCheck, samples: np.ndarray,
                    redraw: np.ndarray) -> list[int]:
        """Steps 5-16 of Algorithm 2 for one batch, each sample from its nearest node in the tree as it was."""
        parents = self.nearest_nodes(tree, samples)
        delta = self.restrict_to_angle_limits(tree, step, parents, samples, redraw)
        new_xy, new_heading, length = self.steer(tree, step, parents, samples, delta)
        # A node whose body is already in the goal region ends its path: extending it would only add
        # steps in place that count as more "paths" (n_paths) without being any.
        free = ~self.in_goal(tree.body[parents], step.goal, step.goal_radius) | (parents == 0)
        free[free] = self.edges_free(tree, step, body, parents[free], new_xy[free])
        return self.insert(tree, step, parents[free], new_xy[free], new_heading[free], length[free])

    def nearest_nodes(self, tree: TreeArrays, samples: np.ndarray) -> np.ndarray:
        """Step 5: index of the nearest tree node of each sample."""
        xy = tree.xy[: tree.n]
        d2 = ((samples[:, None, :] - xy[None, :, :]) ** 2).sum(axis=-1)
        return np.argmin(d2, axis=1)

    def restrict_to_angle_limits(self, tree: TreeArrays, step: TreeStep, parents: np.ndarray, samples: np.ndarray,
                                 redraw: np.ndarray) -> np.ndarray:
        """Steps 6-8: turn ``delta`` [rad] of each extension relative to the parent's heading.

        The foot placed at the new node swings opposite the parent's foot, so the limits
        are those of the parent's side. Outside them, a turn is re-drawn uniformly inside them
        (``lo + (hi - lo) * redraw``, ``redraw`` uniform in [0, 1)).
        """
        vec = samples - tree.xy[parents]
        delta = footstep.wrap_angle(np.arctan2(vec[:, 1], vec[:, 0]) - tree.heading[parents])
        left = tree.side[parents] > 0
        lo = np.where(left, step.left[0], step.right[0])
        hi = np.where(left, step.left[1], step.right[1])
        outside = (delta < lo) | (delta > hi)
        return np.where(outside, lo + (hi - lo) * redraw, delta)

    def steer(self, tree: TreeArrays, step: TreeStep, parents: np.ndarray, samples: np.ndarray,
              delta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Steps 9-10: new node at ``min(distance, step_size)`` along the (restricted) direction."""
        base = tree.xy[parents]
        length = np.minimum(np.linalg.norm(samples - base, axis=1), step.step_size)
        if step.first_stride is not None:
            root = parents == 0
            length = np.where(root, np.clip(length, *step.first_stride), length)
        heading = footstep.wrap_angle(tree.heading[parents] + delta)
        new_xy = base + length[:, None] * np.stack([np.cos(heading), np.sin(heading)], axis=1)
        return new_xy, heading, length

    def edges_free(self, tree: TreeArrays, step: TreeStep, body: BodyCheck, parents: np.ndarray,
                   new_xy: np.ndarray) -> np.ndarray:
        """Step 11: the body segment of each extension clears every obstacle at its own time."""
        period = step.period
        t0 = tree.depth[parents] * period
        if step.check_node:  # the node itself, now and after T (at the start and end of its step if time-aware)
            k = 2
            pts = np.repeat(new_xy, k, axis=0)
            times = (np.stack([t0, t0 + period], axis=1).reshape(-1) if step.time_aware
                     else np.tile([0.0, period], len(parents)))
        else:
            k = step.edge_samples
            starts = tree.body[parents]
            ends = 0.5 * (tree.xy[parents] + new_xy)
            pts, times = body_path_points(starts, ends, t0, t0 + period, k)
            if not step.time_aware:
                times = np.full_like(times, period)  # the obstacles predicted after one period
        normals = np.repeat(support_normal(tree.heading[parents], tree.side[parents]), k, axis=0)
        free = self.body_free(body, pts, times, normals, period)
        return free.reshape(len(parents), k).all(axis=1)

    def insert(self, tree: TreeArrays, step: TreeStep, parents: np.ndarray, new_xy: np.ndarray,
               heading: np.ndarray, length: np.ndarray) -> list[int]:
        """Steps 12-16: append the nodes, with cumulative length as cost; returns the goal nodes."""
        return self.append(tree, parents, new_xy, heading, side=-tree.side[parents], cost=tree.cost[parents] + length,
                           depth=tree.depth[parents] + 1, body=0.5 * (tree.xy[parents] + new_xy), goal=step.goal,
                           goal_radius=step.goal_radius)

    def in_goal(self, xy: np.ndarray, goal: np.ndarray, goal_radius: float) -> np.ndarray:
        """Whether each body ``(N, 2)`` [m] is in the goal region."""
        return in_goal(xy, goal, goal_radius)

    def append(self, tree: TreeArrays, parents: np.ndarray, new_xy: np.ndarray, heading: np.ndarray, *,
               side: np.ndarray, cost: np.ndarray, depth: np.ndarray, body: np.ndarray, goal: np.ndarray,
               goal_radius: float) -> list[int]:
        """Write the new nodes after the last one; returns those whose body is in the goal region."""
        sl = slice(tree.n, tree.n + len(parents))
        tree.xy[sl], tree.heading[sl], tree.parent[sl] = new_xy, heading, parents
        tree.side[sl], tree.cost[sl], tree.depth[sl], tree.body[sl] = side, cost, depth, body
        goal_nodes = (tree.n + np.flatnonzero(self.in_goal(body, goal, goal_radius))).tolist()
        tree.n += len(parents)
        return goal_nodes

    def insert_walks(self, tree: TreeArrays, walks: Sequence[np.ndarray], goal: np.ndarray,
                     goal_radius: float) -> list[int]:
        """All walks in one batch. A step of zero length is a step in place: the new node keeps the heading of
        its walk's last step that moved (the root's if none did)."""
        chains = [nodes for nodes in walks if len(nodes) >= 2]
        if not chains:
            return []
        steps = np.array([len(nodes) - 1 for nodes in chains])
        first = np.concatenate([[0], np.cumsum(steps)[:-1]])  # each chain's first step
        new_xy = np.concatenate([nodes[1:] for nodes in chains])
        vec = np.concatenate([np.diff(nodes, axis=0) for nodes in chains])
        length = np.hypot(vec[:, 0], vec[:, 1])
        heading = np.arctan2(vec[:, 1], vec[:, 0])
        index = np.arange(len(vec))
        chain_start = np.repeat(first, steps)
        last = np.maximum.accumulate(np.where(length > 1e-9, index, -1))
        heading = np.where(last >= chain_start, heading[np.maximum(last, 0)], tree.heading[0])
        in_chain = index - chain_start
        parents = np.where(in_chain == 0, 0, tree.n + index - 1)
        previous_xy = np.where((in_chain == 0)[:, None], tree.xy[0], np.roll(new_xy, 1, axis=0))
        return self.append(tree, parents, new_xy, heading, side=-tree.side[0] * (-1) ** in_chain,
                           cost=np.concatenate([np.cumsum(length[a:a + k]) for a, k in zip(first, steps)]),
                           depth=in_chain + 1, body=0.5 * (previous_xy + new_xy), goal=goal, goal_radius=goal_radius)


#: The numpy kernels (:func:`footstep_gym.kernels.select_kernels` with ``compiled=False``).
NUMPY = NumpyKernels()
