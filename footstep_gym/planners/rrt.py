"""Stage 2: the modified RRT (paper Algorithm 2, Fig. 3-5), time-aware.

A tree of *nodes* (robot centres in the paper's footstep convention, Fig. 5) grows from
the support foot's node towards the goal:

1. :meth:`ModifiedRRT._sample_points` — random coordinates (the goal with probability
   ``goal_sample_rate``) in the box around start and goal;
2. :meth:`_nearest_nodes` — the closest tree node of each;
3. :meth:`_restrict_to_angle_limits` — if the direction from that node lies outside the
   hardware angle limits relative to the node's heading (the previous support foot's
   direction; ``-θ_inner … θ_outer`` mirrored by the side that swings, paper Fig. 4),
   a direction is re-drawn uniformly inside the limits (Algorithm 2, steps 6-8);
4. :meth:`_steer` — the distance is clamped to ``step_size`` (steps 9-10);
5. :meth:`_edges_free` — node and edge are checked against the obstacles (steps 11-12);
6. :meth:`_insert` — the node joins the tree with cost = parent's cost + edge length
   (step 13); nodes whose step brings the body within ``goal_radius`` of the goal are
   remembered (steps 14-16; the env measures the robot centre, the midpoint of the feet,
   so the body and not the node must reach the goal);
7. after ``n_paths`` goal nodes (or all iterations) the least-cost path is returned
   (step 19). No shortcutting: the path's edges are the tree's edges.

**Time.** A node at depth ``d`` is reached about ``d T`` after now when every step takes
the period ``T``. The body (the robot centre between its feet) walks from
``(grandparent + parent) / 2`` to ``(parent + node) / 2`` during ``[(d - 1) T, d T]``, and
that segment is checked against the obstacles predicted *at those times* by a
:class:`~footstep_gym.planners.prediction.BodyModel` (robot radius, safety margin and
the CoM's sway towards the support foot). So a
shorter period lets the tree slip through a gap before a door wing closes it, and
short edges (small steps) let it wait for an obstacle to pass.

:class:`PathSearch` is the stage: it grows the tree at stage 1's period and returns a
:class:`PathChoice` (the path, whether it reached the goal, the reference command).

**Extensions beyond Algorithm 2** (each a switch of ``configs/planner.yaml``'s ``additions``):

* ``time_aware`` (``time_aware_rrt``): the timing above; off, every body point is checked
  against the obstacles predicted after one period ``T`` (the paper: "the position of
  the predicted obstacle before extending a node");
* ``check_node`` (``prediction.check``): ``path`` (ours) checks the body's path as above; ``node``
  (the paper: Algorithm 2 step 11 tests "the selected node", §2.2 against "the predicted position
  of the obstacle and the current obstacle position") checks the new node itself, at the start and
  the end of its step (now and after ``T`` when not time-aware; docs/model.md §5.3);

* ``seeds`` (``rrt_seeds``): walks already known to be collision-free (the period search's free
  rollouts) are inserted as branches before sampling, so the tree never does worse
  than the evidence that chose the period;
* ``first_stride`` (``lipm_windows``): the first step's length is kept inside the strides the LIPM accepts
  from the current CoM state (at a short period the robot cannot stop in one step);
* :meth:`ModifiedRRT.best_partial_path` with ``stay_until`` (``fallback``): when no path reaches the goal, the branch to
  the node where stepping in place would stay free longest (to the prediction horizon
  if any can), then the roomiest, then the nearest the goal, so that the greedy planner
  advances as far as it safely can and waits there instead of walking into a closing gap.

**Batched and compiled.** Samples are drawn ``batch_size`` at a time, each extended from its
nearest node in the tree as it was at the start of the batch (``batch_size=1`` is Algorithm 2
verbatim). Each batch extends the tree by at most one level, so ``iterations / batch_size``
bounds the depth of the tree. With ``compiled`` (``configs/planner.yaml``'s ``kernels.compiled``), a
batch (steps 5-16) and the seed walks are one compiled call each (:func:`.kernels.extend_tree`,
:func:`.kernels.insert_walks`) on the tree's arrays and the predictor's shape table, so the body
check must be a :class:`~footstep_gym.planners.prediction.BodyModel`; without, the numpy methods
run: the reference implementation the compiled calls are held equal to, node for node, which takes
any body check and never imports numba. The random numbers are drawn in
numpy in the same order either way, so a seed grows the same tree: the same nodes, parents and goal
nodes, with coordinates and headings equal to a few ulps (bit for bit unless numpy's ``arctan2``
takes its AVX-512 kernel, which rounds an ulp otherwise than libm's now and then).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from footstep_gym import footstep
from footstep_gym.planners.params import PlannerConfig
from footstep_gym.planners.prediction import BodyModel, body_path_points, step_fractions, support_normal
from footstep_gym.planners.pso import clip_command
from footstep_gym.planners.walks import BodyCheck, WalkStart, on_route
from footstep_gym.robot import Robot
from footstep_gym.sensing import Snapshot


@dataclass(frozen=True)
class RRTPath:
    """A path of the tree from its root: ``nodes (n + 1, 2)`` [m] with the root first.

    ``headings[i]`` [rad] is the heading of node ``i`` (its support foot's yaw: the
    direction of the edge into it; the root's is the current support foot's yaw);
    ``sides[i]`` the side of the foot placed at node ``i``; ``cost`` the cumulative
    length [m]; ``reached_goal`` whether the last step brings the body (the
    midpoint of the last two nodes, where the env measures the robot centre) into the goal region.
    """

    nodes: np.ndarray
    headings: np.ndarray
    sides: np.ndarray
    cost: float
    reached_goal: bool

    @property
    def n_steps(self) -> int:
        return len(self.nodes) - 1


class Tree:
    """The RRT's nodes in preallocated arrays (index 0 is the root)."""

    def __init__(self, start: WalkStart, capacity: int) -> None:
        self.capacity = capacity
        self.xy = np.empty((capacity, 2))
        self.heading = np.empty(capacity)
        self.side = np.empty(capacity, dtype=int)
        self.parent = np.empty(capacity, dtype=int)
        self.cost = np.empty(capacity)
        self.depth = np.empty(capacity, dtype=int)
        self.body = np.empty((capacity, 2))  # body position when the node is reached
        self.xy[0] = start.node
        self.heading[0] = start.heading
        self.side[0] = start.side
        self.parent[0] = -1
        self.cost[0] = 0.0
        self.depth[0] = 0
        self.body[0] = start.body
        self.n = 1

    def path_to(self, index: int, reached_goal: bool) -> RRTPath:
        chain = []
        while index >= 0:
            chain.append(index)
            index = int(self.parent[index])
        chain.reverse()
        idx = np.array(chain)
        return RRTPath(self.xy[idx].copy(), self.heading[idx].copy(), self.side[idx].copy(),
                       float(self.cost[idx[-1]]), reached_goal)


#: [m] Goal paths whose costs differ by less than this are equally long (the first found is taken): the
#: costs of two paths of as many full strides are equal but for rounding.
COST_TIE_M = 1e-9


class ModifiedRRT:
    """Algorithm 2 with the parameters of ``configs/planner.yaml`` (section ``rrt``).

    ``iterations``: samples in all; ``batch_size``: samples extended per vectorised batch;
    ``step_size``: largest distance between nodes [m]; ``goal_sample_rate``: probability
    a sample is the goal; ``n_paths``: goal nodes collected before stopping;
    ``sample_margin``: the sampling box extends this far [m] beyond start and goal;
    ``edge_samples``: points checked along each body segment; ``clearance_weight`` [m of goal
    distance per m], ``clearance_cap`` [m]: how :meth:`best_partial_path` trades clearance for
    progress; ``time_aware``: a node at depth ``d`` is checked during ``[(d - 1) T, d T]`` (else
    every point at ``T``); ``check_node`` (``prediction.check: node``, Algorithm 2 step 11): the new
    node itself is checked, at the start and the end of its step (``0`` and ``T`` if not
    ``time_aware``: the obstacles now and predicted after ``T``, §2.2), instead of the body's path;
    ``compiled`` (``kernels.compiled``): each batch is one compiled call (:func:`.kernels.extend_tree`),
    which needs a :class:`~footstep_gym.planners.prediction.BodyModel` (:func:`.walks.on_route` raises
    otherwise); ``False``: the numpy methods, the reference it is tested against, with any body check.
    Both grow the same tree, its floats to a few ulps.
    """

    def __init__(self, robot: Robot, *, iterations: int, batch_size: int, step_size: float,
                 goal_sample_rate: float, n_paths: int, sample_margin: float, edge_samples: int, compiled: bool,
                 clearance_weight: float = 0.0, clearance_cap: float = 0.0,
                 time_aware: bool = True, check_node: bool = False) -> None:
        self.robot = robot
        self.iterations = iterations
        self.batch_size = batch_size
        self.step_size = step_size
        self.goal_sample_rate = goal_sample_rate
        self.n_paths = n_paths
        self.sample_margin = sample_margin
        self.edge_samples = edge_samples
        self.clearance_weight = clearance_weight
        self.clearance_cap = clearance_cap
        self.time_aware = time_aware
        self.check_node = check_node
        self.compiled = compiled
        self.tree: Tree | None = None
        self.goal_nodes: list[int] = []

    # ------------------------------------------------------------------ the loop
    def plan(self, start: WalkStart, goal: Sequence[float], goal_radius: float, body: BodyCheck,
             period: float, rng: np.random.Generator, *, seeds: Sequence[np.ndarray] = (),
             first_stride: tuple[float, float] | None = None) -> RRTPath | None:
        """The least-cost path to the goal region, or ``None`` if no node reached it.

        ``period`` [s]: time per step (a node at depth ``d`` is checked at ``d * period``).
        ``seeds``: collision-free walks ``(k + 1, 2)`` from the root node (row 0) inserted
        first; ``first_stride``: ``(lo, hi)`` [m] for the length of the root's extensions.
        After a ``None``, :meth:`best_partial_path` gives the branch that got closest.
        """
        goal = np.asarray(goal, dtype=float)
        n_seeded = sum(max(len(sd) - 1, 0) for sd in seeds)
        self.tree = tree = Tree(start, self.iterations + 1 + n_seeded)
        self.goal_nodes = []
        self._goal, self._goal_radius, self._period = goal, goal_radius, period
        compiled = self.compiled
        self._body = body = on_route(body, compiled)
        self._first_stride = first_stride
        self._box = self._sampling_box(start.node, goal)
        seeds = [np.asarray(seed, dtype=float) for seed in seeds]
        (self._insert_seeds_compiled if compiled else self._insert_seeds)(seeds)
        extend = None
        done = 0
        while done < self.iterations and len(self.goal_nodes) < self.n_paths:
            batch = min(self.batch_size, self.iterations - done)
            done += batch
            samples = self._sample_points(batch, rng)
            if extend is None:
                extend = self._compiled_batch(body) if compiled else self._numpy_batch
            extend(samples, rng.random(batch))
        if not self.goal_nodes:
            return None
        # The least cost; among costs equal to within COST_TIE_M (common: paths of as many full strides), the goal node
        # found first, so that rounding, which differs between the two routes, does not pick the path.
        costs = tree.cost[self.goal_nodes]
        best = self.goal_nodes[int(np.argmax(costs <= costs.min() + COST_TIE_M))]
        return tree.path_to(best, reached_goal=True)

    def _numpy_batch(self, samples: np.ndarray, redraw: np.ndarray) -> None:
        """Steps 5-16 for one batch of ``samples`` [m]; ``redraw`` (uniform in [0, 1)) re-draws the turns
        outside the limits. In numpy: the reference implementation, the test oracle of :func:`.kernels.extend_tree`
        (``tests/test_kernels.py``), and the route of ``kernels.compiled: false``."""
        tree = self.tree
        parents = self._nearest_nodes(samples)
        delta = self._restrict_to_angle_limits(parents, samples, redraw)
        new_xy, new_heading, length = self._steer(parents, samples, delta)
        # A node whose body is already in the goal region ends its path: extending it would only add
        # steps in place that count as more "paths" (n_paths) without being any.
        free = ~self._in_goal(tree.body[parents]) | (parents == 0)
        free[free] = self._edges_free(parents[free], new_xy[free])
        self._insert(parents[free], new_xy[free], new_heading[free], length[free])

    def _compiled_batch(self, body: BodyModel) -> Callable[[np.ndarray, np.ndarray], None]:
        """:meth:`_numpy_batch` as one compiled call per batch (:func:`.kernels.extend_tree`), for a
        :class:`BodyModel`: the same tree (its floats to a few ulps)."""
        from footstep_gym.planners import kernels  # imports numba: only on the compiled route

        tree, pred = self.tree, body.predictor
        shift, needed = body.shift_and_clearance(self._period)
        need2 = (pred.kernel_radius + needed) ** 2
        (l_lo, l_hi), (r_lo, r_hi) = (footstep.turn_bounds(side, self.robot)
                                      for side in (footstep.LEFT, footstep.RIGHT))
        first_lo, first_hi = self._first_stride if self._first_stride is not None else (0.0, 0.0)
        fractions = step_fractions(self.edge_samples)
        goal_nodes = np.empty(self.batch_size, dtype=np.int64)
        fixed = (float(self._goal[0]), float(self._goal[1]), float(self._goal_radius), float(self.step_size),
                 self._first_stride is not None, float(first_lo), float(first_hi), float(l_lo), float(l_hi),
                 float(r_lo), float(r_hi), float(self._period), bool(self.time_aware), fractions, float(shift),
                 pred.kernel_shapes, need2, pred.kernel_horizon, goal_nodes, bool(self.check_node))

        def extend(samples: np.ndarray, redraw: np.ndarray) -> None:
            tree.n, n_goal = kernels.extend_tree(tree.xy, tree.heading, tree.side, tree.parent, tree.cost, tree.depth,
                                                 tree.body, tree.n, samples, redraw, *fixed)
            self.goal_nodes.extend(goal_nodes[:n_goal].tolist())

        return extend

    def best_partial_path(self, stay_until: float | None = None) -> RRTPath:
        """For when :meth:`plan` fails: the branch to the node closest to the goal (ties: least cost).

        With ``stay_until`` [s], the candidates are the nodes where the robot, stepping in
        place once it has arrived, would stay free the longest (all those that last until
        ``stay_until``, the root included, if any do): a greedy planner that cannot see a way
        to the goal advances as far as it safely can and waits there, and when every spot
        will be hit, it takes the one hit last rather than the one nearest the goal.
        """
        tree = self.tree
        assert tree is not None, "plan() first"
        n = tree.n
        key = np.linalg.norm(tree.xy[:n] - self._goal, axis=1) + 1e-6 * tree.cost[:n]
        if stay_until is not None:
            survival, slack = self._stay_time(np.arange(n), stay_until)
            # Of the spots that last longest, the roomiest (up to clearance_cap) first, then the nearest the goal.
            key = key - self.clearance_weight * np.minimum(slack, self.clearance_cap)
            key = np.where(survival >= survival.max() - 1e-9, key, np.inf)
        return tree.path_to(int(np.argmin(key)), reached_goal=False)

    def _stay_time(self, nodes: np.ndarray, until: float) -> tuple[np.ndarray, np.ndarray]:
        """How long [s] stepping in place at each node stays free (``until`` if it lasts that long),
        and the smallest clearance [m] beyond the required one over the stay's first step.

        The in-place step (body from where it arrived to the node) is checked at
        ``edge_samples`` instants, then standing on the node at ``2 * edge_samples`` more up
        to ``until``; the answer is the last instant before the first one that collides.
        """
        tree, e = self.tree, self.edge_samples
        t_arrive = tree.depth[nodes] * self._period
        pts_a, times_a = body_path_points(tree.body[nodes], tree.xy[nodes], t_arrive, t_arrive + self._period, e)
        t_end = np.maximum(until, t_arrive + self._period)
        pts_b, times_b = body_path_points(tree.xy[nodes], tree.xy[nodes], t_arrive + self._period, t_end, 2 * e)
        k = 3 * e
        pts = np.concatenate([pts_a.reshape(-1, e, 2), pts_b.reshape(-1, 2 * e, 2)], axis=1).reshape(-1, 2)
        times = np.concatenate([times_a.reshape(-1, e), times_b.reshape(-1, 2 * e)], axis=1)
        normals = np.zeros((len(nodes), k, 2))
        normals[:, :e] = support_normal(tree.heading[nodes], tree.side[nodes])[:, None, :]
        slack = self._body.slack(pts, times.reshape(-1), normals.reshape(-1, 2), self._period).reshape(len(nodes), k)
        free = slack >= 0.0
        first_hit = np.where(free.all(axis=1), k, np.argmin(free, axis=1))
        last_free = np.where(first_hit > 0, times[np.arange(len(nodes)), np.maximum(first_hit - 1, 0)], 0.0)
        return np.where(first_hit == k, until, np.minimum(last_free, until)), slack[:, : 2 * e].min(axis=1)

    # ------------------------------------------------------------------ the steps
    def _sampling_box(self, start: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo = np.minimum(start, goal) - self.sample_margin
        hi = np.maximum(start, goal) + self.sample_margin
        return lo, hi

    def _sample_points(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Step 4: ``n`` random points in the box; at most one goal sample per batch (duplicates add nothing)."""
        lo, hi = self._box
        pts = lo + (hi - lo) * rng.random((n, 2))
        if rng.random() < 1.0 - (1.0 - self.goal_sample_rate) ** n:
            pts[0] = self._goal
        return pts

    def _nearest_nodes(self, samples: np.ndarray) -> np.ndarray:
        """Step 5: index of the nearest tree node of each sample."""
        xy = self.tree.xy[: self.tree.n]
        d2 = ((samples[:, None, :] - xy[None, :, :]) ** 2).sum(axis=-1)
        return np.argmin(d2, axis=1)

    def _restrict_to_angle_limits(self, parents: np.ndarray, samples: np.ndarray, redraw: np.ndarray) -> np.ndarray:
        """Steps 6-8: turn ``delta`` [rad] of each extension relative to the parent's heading.

        The foot placed at the new node swings opposite the parent's foot, so the limits
        are :func:`footstep.turn_bounds` of the parent's side. Outside them, a turn is
        re-drawn uniformly inside them (``lo + (hi - lo) * redraw``, ``redraw`` uniform in [0, 1)).
        """
        tree = self.tree
        vec = samples - tree.xy[parents]
        delta = footstep.wrap_angle(np.arctan2(vec[:, 1], vec[:, 0]) - tree.heading[parents])
        lo, hi = footstep.turn_bounds(tree.side[parents], self.robot)
        outside = (delta < lo) | (delta > hi)
        return np.where(outside, lo + (hi - lo) * redraw, delta)

    def _steer(self, parents: np.ndarray, samples: np.ndarray,
               delta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Steps 9-10: new node at ``min(distance, step_size)`` along the (restricted) direction."""
        tree = self.tree
        base = tree.xy[parents]
        length = np.minimum(np.linalg.norm(samples - base, axis=1), self.step_size)
        if self._first_stride is not None:
            root = parents == 0
            length = np.where(root, np.clip(length, *self._first_stride), length)
        heading = footstep.wrap_angle(tree.heading[parents] + delta)
        new_xy = base + length[:, None] * np.stack([np.cos(heading), np.sin(heading)], axis=1)
        return new_xy, heading, length

    def _edges_free(self, parents: np.ndarray, new_xy: np.ndarray) -> np.ndarray:
        """Step 11: the body segment of each extension clears every obstacle at its own time."""
        tree = self.tree
        t0 = tree.depth[parents] * self._period
        if self.check_node:  # the node itself, now and after T (at the start and end of its step if time-aware)
            k = 2
            pts = np.repeat(new_xy, k, axis=0)
            times = (np.stack([t0, t0 + self._period], axis=1).reshape(-1) if self.time_aware
                     else np.tile([0.0, self._period], len(parents)))
        else:
            k = self.edge_samples
            starts = tree.body[parents]
            ends = 0.5 * (tree.xy[parents] + new_xy)
            pts, times = body_path_points(starts, ends, t0, t0 + self._period, k)
            if not self.time_aware:
                times = np.full_like(times, self._period)  # the obstacles predicted after one period
        normals = np.repeat(support_normal(tree.heading[parents], tree.side[parents]), k, axis=0)
        free = self._body.free(pts, times, normals, self._period)
        return free.reshape(len(parents), k).all(axis=1)

    def _insert_seeds(self, seeds: Sequence[np.ndarray]) -> None:
        """Insert known-free walks (row 0 of each = the root) as chains of nodes from the root, all in one batch.

        A step of zero length is a step in place: the new node keeps its parent's heading. In numpy: the
        reference implementation, the test oracle of :func:`.kernels.insert_walks`.
        """
        tree = self.tree
        chains = [nodes for nodes in seeds if len(nodes) >= 2]
        if not chains:
            return
        steps = np.array([len(nodes) - 1 for nodes in chains])
        first = np.concatenate([[0], np.cumsum(steps)[:-1]])  # each chain's first step
        new_xy = np.concatenate([nodes[1:] for nodes in chains])
        vec = np.concatenate([np.diff(nodes, axis=0) for nodes in chains])
        length = np.hypot(vec[:, 0], vec[:, 1])
        heading = np.arctan2(vec[:, 1], vec[:, 0])
        index = np.arange(len(vec))
        chain_start = np.repeat(first, steps)
        # a step in place inherits the heading of its chain's last step that moved (the root's if none did)
        last = np.maximum.accumulate(np.where(length > 1e-9, index, -1))
        heading = np.where(last >= chain_start, heading[np.maximum(last, 0)], tree.heading[0])
        in_chain = index - chain_start
        parents = np.where(in_chain == 0, 0, tree.n + index - 1)
        previous_xy = np.where((in_chain == 0)[:, None], tree.xy[0], np.roll(new_xy, 1, axis=0))
        self._append(parents, new_xy, heading, side=-tree.side[0] * (-1) ** in_chain,
                     cost=np.concatenate([np.cumsum(length[a:a + k]) for a, k in zip(first, steps)]),
                     depth=in_chain + 1, body=0.5 * (previous_xy + new_xy))

    def _insert_seeds_compiled(self, seeds: Sequence[np.ndarray]) -> None:
        """:meth:`_insert_seeds` in one compiled call (:func:`.kernels.insert_walks`)."""
        if not seeds:
            return
        from footstep_gym.planners import kernels  # imports numba: only on the compiled route

        tree = self.tree
        walk_nodes = np.concatenate(seeds).reshape(-1, 2)
        walk_first = np.cumsum([0, *(len(nodes) for nodes in seeds)])
        goal_nodes = np.empty(len(walk_nodes), dtype=np.int64)
        tree.n, n_goal = kernels.insert_walks(tree.xy, tree.heading, tree.side, tree.parent, tree.cost, tree.depth,
                                              tree.body, tree.n, walk_nodes, walk_first, float(self._goal[0]),
                                              float(self._goal[1]), float(self._goal_radius), goal_nodes)
        self.goal_nodes.extend(goal_nodes[:n_goal].tolist())

    def _in_goal(self, xy: np.ndarray) -> np.ndarray:
        return np.linalg.norm(xy - self._goal, axis=1) <= self._goal_radius

    def _insert(self, parents: np.ndarray, new_xy: np.ndarray, heading: np.ndarray,
                length: np.ndarray) -> None:
        """Steps 12-16: append the nodes, with cumulative length as cost; note goal nodes."""
        tree = self.tree
        self._append(parents, new_xy, heading, side=-tree.side[parents],
                     cost=tree.cost[parents] + length, depth=tree.depth[parents] + 1,
                     body=0.5 * (tree.xy[parents] + new_xy))

    def _append(self, parents: np.ndarray, new_xy: np.ndarray, heading: np.ndarray, *, side: np.ndarray,
                cost: np.ndarray, depth: np.ndarray, body: np.ndarray) -> None:
        """Write the new nodes after the last one and remember those whose body is in the goal region."""
        tree = self.tree
        sl = slice(tree.n, tree.n + len(parents))
        tree.xy[sl], tree.heading[sl], tree.parent[sl] = new_xy, heading, parents
        tree.side[sl], tree.cost[sl], tree.depth[sl], tree.body[sl] = side, cost, depth, body
        self.goal_nodes.extend((tree.n + np.flatnonzero(self._in_goal(body))).tolist())
        tree.n += len(parents)


# ---------------------------------------------------------------------- stage 2
@dataclass(frozen=True)
class PathChoice:
    """Stage 2's record: the path taken and the command its first node gives."""

    path: RRTPath  # to the goal region, or the fallback branch
    reached_goal: bool  # a path reached the goal region
    command: np.ndarray  # (5,) [S, L, θ, T_SS, T_DS] from the first node, T split as T_SS + nominal T_DS
    tree_nodes: int  # nodes in the tree
    seeds: int  # stage 1's free walks inserted as branches

    def diagnostics(self) -> dict[str, object]:
        """The record as ``policy.last_info`` entries."""
        return dict(rrt_reached_goal=self.reached_goal, rrt_nodes=self.tree_nodes, rrt_seeds=self.seeds,
                    path=self.path.nodes)


class PathSearch:
    """Stage 2 with the parameters of ``configs/planner.yaml`` (sections ``rrt``, ``additions``; ``kernels``: the
    compiled RRT or its numpy reference)."""

    def __init__(self, robot: Robot, config: PlannerConfig) -> None:
        c, add = config, config.additions
        self.robot = robot
        self.rrt = ModifiedRRT(
            robot, iterations=c.rrt.iterations, batch_size=c.rrt.batch_size, step_size=c.rrt.step_size_m,
            goal_sample_rate=c.rrt.goal_sample_rate, n_paths=c.rrt.n_paths,
            sample_margin=c.rrt.sample_margin_m, edge_samples=c.prediction.edge_samples,
            clearance_weight=c.rrt.fallback_clearance_weight, clearance_cap=c.rrt.fallback_clearance_cap_m,
            time_aware=add.time_aware_rrt, check_node=c.prediction.check == "node", compiled=c.kernels.compiled)
        self.seed_paths = c.rrt.seed_paths if add.rrt_seeds else 0
        self.stay_until = c.prediction.horizon_s if add.fallback else None
        self.half_width = 0.5 * robot.nominal_side_stride

    def __call__(self, snapshot: Snapshot, start: WalkStart, body: BodyCheck, period: float,
                 free_walks: Sequence[np.ndarray], first_stride: tuple[float, float] | None,
                 rng: np.random.Generator) -> PathChoice:
        """Algorithm 2 at ``period`` [s] from ``start``; the first node's command.

        ``free_walks``: stage 1's evidence, best first (up to ``rrt.seed_paths`` become the
        tree's first branches); ``first_stride``: ``(lo, hi)`` [m] of the first step's length.
        """
        seeds = list(free_walks[: self.seed_paths]) if self.seed_paths else []
        path = self.rrt.plan(start, snapshot.goal, snapshot.goal_tolerance, body, period, rng,
                             seeds=seeds, first_stride=first_stride)
        reached = path is not None
        if path is None:
            path = self.rrt.best_partial_path(stay_until=self.stay_until)
        command = self.command_from_path(snapshot, path, period, first_stride)
        return PathChoice(path, reached, command, self.rrt.tree.n, len(seeds))

    def command_from_path(self, snapshot: Snapshot, path: RRTPath, period: float,
                          window: tuple[float, float] | None = None) -> np.ndarray:
        """First node -> swing foot pose -> ``(S, L, θ)``; ``T`` [s] split as ``T_SS + nominal T_DS``.

        The footstep convention (:func:`footstep.foot_from_node`, then
        :func:`footstep.command_between`); the paper's Tables 2 and 4 keep T_DS at 0.20 s and
        vary T_SS. A path without steps means "step in place" (the shortest stride of
        ``window`` [m] if the CoM's momentum forbids stopping).
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
        return clip_command(robot, [s, l, theta, period - t_ds, t_ds], side)
