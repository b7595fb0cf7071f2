"""Stage 2: the modified RRT (paper Algorithm 2, Fig. 3-5), time-aware.

A tree of *nodes* (robot centres in the paper's footstep convention, Fig. 5) grows from
the support foot's node towards the goal:

1. :meth:`ModifiedRRT._sample_points` — random coordinates (the goal with probability
   ``goal_sample_rate``) in the box around start and goal;

then, one batch of samples in one call of the kernels (:meth:`footstep_gym.kernels.Kernels.extend_tree`;
the steps are methods of the numpy kernels, :class:`~footstep_gym.kernels.numpy_kernels.NumpyKernels`):

2. ``nearest_nodes`` — the closest tree node of each;
3. ``restrict_to_angle_limits`` — if the direction from that node lies outside the
   hardware angle limits relative to the node's heading (the previous support foot's
   direction; ``-θ_inner … θ_outer`` mirrored by the side that swings, paper Fig. 4),
   a direction is re-drawn uniformly inside the limits (Algorithm 2, steps 6-8);
4. ``steer`` — the distance is clamped to ``step_size`` (steps 9-10);
5. ``edges_free`` — node and edge are checked against the obstacles (steps 11-12);
6. ``insert`` — the node joins the tree with cost = parent's cost + edge length
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

**Batched, on the planner's kernels.** Samples are drawn ``batch_size`` at a time, each extended from its
nearest node in the tree as it was at the start of the batch (``batch_size=1`` is Algorithm 2
verbatim). Each batch extends the tree by at most one level, so ``iterations / batch_size``
bounds the depth of the tree. A batch (steps 5-16) and the seed walks are one call each of the
planner's kernels (:meth:`~footstep_gym.kernels.Kernels.extend_tree`,
:meth:`~footstep_gym.kernels.Kernels.insert_walks`) on the tree's arrays: the compiled ones read the
predictor's shape table, so their body check must be a
:class:`~footstep_gym.planners.prediction.BodyModel`; the numpy ones take any body check. The random
numbers are drawn here, in the same order either way, so a seed grows the same tree: the same nodes,
parents and goal nodes, with coordinates and headings equal to a few ulps (bit for bit unless numpy's
``arctan2`` takes its AVX-512 kernel, which rounds an ulp otherwise than libm's now and then).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from footstep_gym import footstep
from footstep_gym.kernels import BodyCheck, Kernels, TreeStep, WalkStart
from footstep_gym.planners.params import PlannerConfig
from footstep_gym.kernels.numpy_kernels import body_path_points, support_normal
from footstep_gym.planners.pso import clip_command
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
    ``kernels``: what grows the tree (:func:`footstep_gym.kernels.select_kernels`); the compiled kernels
    need a :class:`~footstep_gym.planners.prediction.BodyModel` (and raise ``TypeError`` otherwise), the
    numpy ones take any body check. Both grow the same tree, its floats to a few ulps.
    """

    def __init__(self, robot: Robot, *, iterations: int, batch_size: int, step_size: float,
                 goal_sample_rate: float, n_paths: int, sample_margin: float, edge_samples: int, kernels: Kernels,
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
        self.kernels = kernels
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
        kernels = self.kernels
        kernels.check_body(body)
        n_seeded = sum(max(len(sd) - 1, 0) for sd in seeds)
        self.tree = tree = Tree(start, self.iterations + 1 + n_seeded)
        self._goal, self._period, self._body = goal, period, body
        step = TreeStep(goal=goal, goal_radius=float(goal_radius), step_size=float(self.step_size),
                        first_stride=None if first_stride is None else (float(first_stride[0]), float(first_stride[1])),
                        left=footstep.turn_bounds(footstep.LEFT, self.robot),
                        right=footstep.turn_bounds(footstep.RIGHT, self.robot), period=float(period),
                        time_aware=bool(self.time_aware), edge_samples=int(self.edge_samples),
                        check_node=bool(self.check_node))
        self._box = self._sampling_box(start.node, goal)
        self.goal_nodes = kernels.insert_walks(tree, [np.asarray(seed, dtype=float) for seed in seeds], goal,
                                               goal_radius)
        done = 0
        while done < self.iterations and len(self.goal_nodes) < self.n_paths:
            batch = min(self.batch_size, self.iterations - done)
            done += batch
            samples = self._sample_points(batch, rng)
            self.goal_nodes += kernels.extend_tree(tree, step, body, samples, rng.random(batch))
        if not self.goal_nodes:
            return None
        # The least cost; among costs equal to within COST_TIE_M (common: paths of as many full strides), the goal node
        # found first, so that rounding, which differs between the two kernels, does not pick the path.
        costs = tree.cost[self.goal_nodes]
        best = self.goal_nodes[int(np.argmax(costs <= costs.min() + COST_TIE_M))]
        return tree.path_to(best, reached_goal=True)

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
    """Stage 2 with the parameters of ``configs/planner.yaml`` (sections ``rrt``, ``additions``), growing its
    tree with the planner's ``kernels``."""

    def __init__(self, robot: Robot, config: PlannerConfig, kernels: Kernels) -> None:
        c, add = config, config.additions
        self.robot = robot
        self.rrt = ModifiedRRT(
            robot, iterations=c.rrt.iterations, batch_size=c.rrt.batch_size, step_size=c.rrt.step_size_m,
            goal_sample_rate=c.rrt.goal_sample_rate, n_paths=c.rrt.n_paths,
            sample_margin=c.rrt.sample_margin_m, edge_samples=c.prediction.edge_samples,
            clearance_weight=c.rrt.fallback_clearance_weight, clearance_cap=c.rrt.fallback_clearance_cap_m,
            time_aware=add.time_aware_rrt, check_node=c.prediction.check == "node", kernels=kernels)
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
