"""Stage 2, :class:`ModifiedRRT` (Algorithm 2): free space, a wall with a gap, a blocking wall and a gate
that shuts at a known time, with body checks written here. Every edge is re-derived from the node
coordinates and checked against the hardware angle limits written out from docs/model.md §1 / paper
Fig. 4 (and cross-checked with ``footstep.turn_bounds``); the fallback branch when no path reaches the goal.

The body checks written here are not :class:`~footstep_gym.planners.prediction.BodyModel` s, so these trees
grow with the numpy kernels (:data:`NUMPY_RRT`); the compiled ones are held equal to them in
``tests/test_kernels.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from footstep_gym.kernels import select_kernels
from footstep_gym.planners.rrt import ModifiedRRT
from footstep_gym.planners.walks import WalkStart
from planner_helpers import (  # noqa: F401  (robot is a fixture)
    EPS, LEFT, RIGHT, RRT_SETTINGS, AlwaysFree, Wall, angle_limits, body_samples, check_path, check_tree_edges,
    empty_predictor_body, make_start, robot, wrap,
)

#: The RRT settings of the tests with the numpy kernels (``kernels.compiled: false``), which take any body check.
NUMPY_RRT = {**RRT_SETTINGS, "kernels": select_kernels(False)}


@pytest.mark.parametrize("body_kind,compiled", [("always_free", False), ("empty_snapshot", False),
                                                ("empty_snapshot", True)])
@pytest.mark.parametrize("side,heading", [(RIGHT, 0.0), (LEFT, 0.0), (RIGHT, 0.6), (LEFT, -1.0)])
def test_rrt_free_space_reaches_goal_within_hardware_limits(robot, body_kind, compiled, side, heading):
    body = AlwaysFree() if body_kind == "always_free" else empty_predictor_body(robot)
    start = make_start(side, heading, node=(0.2, -0.1))
    goal, radius = np.array([1.6, 0.4]), 0.1  # ~1.5 m away
    rrt = ModifiedRRT(robot, **{**RRT_SETTINGS, "iterations": 800, "kernels": select_kernels(compiled)})
    path = rrt.plan(start, goal, radius, body, period=0.8, rng=np.random.default_rng(1))
    assert path is not None and path.reached_goal
    check_path(path, start, goal, radius, robot, RRT_SETTINGS["step_size"])
    # at least the straight-line number of steps
    assert path.n_steps >= math.ceil((np.linalg.norm(goal - start.node) - radius) / RRT_SETTINGS["step_size"])
    _, _, cost = check_tree_edges(rrt.tree, start, robot, RRT_SETTINGS["step_size"])
    # the kept path is the least-cost of the tree's nodes whose step brings the body (midpoint of the
    # node and its parent) into the goal region
    tree = rrt.tree
    bodies = 0.5 * (tree.xy[tree.parent[1: tree.n]] + tree.xy[1: tree.n])
    in_goal = np.concatenate([[False], np.linalg.norm(bodies - goal, axis=1) <= radius])
    assert in_goal.sum() >= 1
    assert path.cost == pytest.approx(cost[in_goal].min(), abs=1e-9)
    if body_kind == "always_free":
        for pts_shape, times_shape, normals_shape, period in body.calls:
            assert len(pts_shape) == 2 and pts_shape[1] == 2
            assert times_shape == (pts_shape[0],) and normals_shape == pts_shape and period == 0.8


class Recorder(AlwaysFree):
    """Free space that remembers every (point, time, support normal) it was asked about."""

    def free(self, points, times, normals, period):
        self.rows = getattr(self, "rows", []) + [np.column_stack([points, times, normals])]
        return super().free(points, times, normals, period)


def test_rrt_checks_the_body_path_at_its_own_times(robot):
    """docs/model.md §5: during step d, i.e. [(d-1) T, d T], the body walks from (grandparent + parent) / 2
    to (parent + node) / 2, starting from where the body is now; the CoM sways towards the support
    foot (the parent's foot), so each segment is checked with that foot's normal."""
    period, samples = 0.55, 5
    start = WalkStart(node=np.array([0.0, 0.0]), heading=0.3, side=LEFT, body=np.array([0.01, 0.03]),
                      previous_node=np.array([-0.1, 0.0]))
    body = Recorder()
    rrt = ModifiedRRT(robot, **{**NUMPY_RRT, "edge_samples": samples, "iterations": 200})
    rrt.plan(start, (1.0, 0.5), 0.1, body, period=period, rng=np.random.default_rng(5))
    tree = rrt.tree
    xy, parent = tree.xy[: tree.n], tree.parent[: tree.n]
    heading_of = {0: start.heading}
    side_of = {0: start.side}
    depth_of = {0: 0}
    expected = []
    s = np.linspace(0.0, 1.0, samples)
    for i in range(1, tree.n):  # all free: every query became a node, in order
        p = parent[i]
        vec = xy[i] - xy[p]
        heading_of[i] = math.atan2(vec[1], vec[0]) if np.any(vec != 0) else tree.heading[i]
        side_of[i] = -side_of[p]
        depth_of[i] = depth_of[p] + 1
        a = start.body if p == 0 else 0.5 * (xy[parent[p]] + xy[p])
        b = 0.5 * (xy[p] + xy[i])
        pts = a + s[:, None] * (b - a)
        times = (depth_of[p] + s) * period
        h = heading_of[p]
        normal = side_of[p] * np.array([-math.sin(h), math.cos(h)])  # left normal, towards a left support foot
        expected.append(np.column_stack([pts, times, np.tile(normal, (samples, 1))]))
    np.testing.assert_allclose(np.concatenate(body.rows), np.concatenate(expected), atol=1e-12)


def test_rrt_angle_limits_bind(robot):
    """Goal 1 m straight behind: the path must turn around, no faster than the limits allow."""
    start = make_start(RIGHT, 0.0)
    goal, radius = np.array([-1.0, 0.0]), 0.1
    rrt = ModifiedRRT(robot, **{**NUMPY_RRT, "iterations": 3000})
    path = rrt.plan(start, goal, radius, AlwaysFree(), period=0.8, rng=np.random.default_rng(3))
    assert path is not None
    check_path(path, start, goal, radius, robot, RRT_SETTINGS["step_size"])
    check_tree_edges(rrt.tree, start, robot, RRT_SETTINGS["step_size"])
    # the fewest steps after which the heading can point backwards (|heading| > pi/2), turning
    # either way with the largest turn the alternating feet allow (Fig. 4 limits)
    fewest = []
    for sign in (1, -1):
        total, side, k = 0.0, RIGHT, 0
        while total <= math.pi / 2:
            lo, hi = angle_limits(side, robot)
            total += hi if sign > 0 else -lo
            side, k = -side, k + 1
        fewest.append(k)
    vec = np.diff(path.nodes, axis=0)
    backwards = np.flatnonzero(vec[:, 0] < 0)
    assert backwards.size > 0
    assert backwards[0] + 1 >= min(fewest)


def test_rrt_first_stride_window(robot):
    start = make_start(RIGHT, 0.0)
    rrt = ModifiedRRT(robot, **NUMPY_RRT)
    rrt.plan(start, (1.5, 0.0), 0.1, AlwaysFree(), period=0.5, rng=np.random.default_rng(0),
             first_stride=(0.04, 0.06))
    tree = rrt.tree
    root_children = np.flatnonzero(tree.parent[: tree.n] == 0)
    assert root_children.size > 0
    lengths = np.linalg.norm(tree.xy[root_children] - start.node, axis=1)
    assert np.all((lengths >= 0.04 - 1e-12) & (lengths <= 0.06 + 1e-12))


def test_rrt_seeded_replay_and_seed_dependence(robot):
    """The same seed replays the same tree bit for bit (the same code on the same inputs: on any CPU)."""
    start = make_start(RIGHT, 0.0)
    goal = (1.5, 0.0)

    def run(seed):
        rrt = ModifiedRRT(robot, **NUMPY_RRT)
        path = rrt.plan(start, goal, 0.1, AlwaysFree(), period=0.8, rng=np.random.default_rng(seed))
        return path, rrt.tree.xy[: rrt.tree.n].copy()

    p1, t1 = run(7)
    p2, t2 = run(7)
    assert p1 is not None
    np.testing.assert_array_equal(p1.nodes, p2.nodes)
    np.testing.assert_array_equal(t1, t2)
    assert p1.cost == p2.cost
    others = [run(s)[1] for s in (8, 9, 10)]
    assert any(o.shape != t1.shape or not np.array_equal(o, t1) for o in others)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rrt_goes_around_a_wall(robot, seed):
    wall = Wall(0.6, 0.8, half_width=0.25)
    start = make_start(RIGHT, 0.0)
    goal, radius = np.array([1.5, 0.0]), 0.1
    settings = {**NUMPY_RRT, "iterations": 1500}
    rrt = ModifiedRRT(robot, **settings)
    path = rrt.plan(start, goal, radius, wall, period=0.8, rng=np.random.default_rng(seed))
    assert path is not None
    check_path(path, start, goal, radius, robot, settings["step_size"])
    check_tree_edges(rrt.tree, start, robot, settings["step_size"])
    pts, times = body_samples(path, start, 0.8, settings["edge_samples"])
    assert not wall.blocked(pts, times).any()
    # between two free samples (<= step_size / (edge_samples - 1) apart) the body can clip
    # the wall's corner by at most half that spacing: densely, a wall shrunk by it is clear
    slack = 0.5 * settings["step_size"] / (settings["edge_samples"] - 1) + 1e-9
    pts, times = body_samples(path, start, 0.8, 50)
    assert not Wall(0.6 + slack, 0.8 - slack, half_width=0.25 - slack).blocked(pts, times).any()
    # it went around: the body passed the wall's x-range beside it
    beside = (pts[:, 0] >= 0.6 + slack) & (pts[:, 0] <= 0.8 - slack)
    assert beside.any() and np.all(np.abs(pts[beside, 1]) >= 0.25 - slack)


def test_rrt_blocked_wall_gives_none_and_partial_on_start_side(robot):
    wall = Wall(0.6, 0.8)  # spans every y
    start = make_start(RIGHT, 0.0)
    goal = np.array([1.5, 0.0])
    rrt = ModifiedRRT(robot, **NUMPY_RRT)
    assert rrt.plan(start, goal, 0.1, wall, period=0.8, rng=np.random.default_rng(0)) is None
    partial = rrt.best_partial_path()
    assert not partial.reached_goal
    check_path(partial, start, goal, 0.1, robot, RRT_SETTINGS["step_size"])
    # body midpoints stay before the wall, so nodes stay within half a step of it
    pts, times = body_samples(partial, start, 0.8, 50)
    assert np.all(pts[:, 0] < 0.6)
    assert np.all(partial.nodes[:, 0] < 0.6 + 0.5 * RRT_SETTINGS["step_size"])
    all_nodes = rrt.tree.xy[: rrt.tree.n]
    assert np.all(all_nodes[:, 0] < 0.6 + 0.5 * RRT_SETTINGS["step_size"])
    # the wall stops the body (the midpoint of the last two nodes), not the node itself:
    # nodes get past the wall's face, as the body lags half a step behind
    assert all_nodes[:, 0].max() > 0.6
    # it is the branch to the node nearest the goal, and it got close to the wall
    d_end = np.linalg.norm(partial.nodes[-1] - goal)
    assert d_end <= np.linalg.norm(all_nodes - goal, axis=1).min() + 1e-6
    assert partial.nodes[-1, 0] > 0.45


class ClosingWall(Wall):
    """Points with ``x0 <= x <= x1`` are blocked from ``t >= closes`` on (a gate that shuts)."""

    def __init__(self, x0, x1, closes):
        super().__init__(x0, x1)
        self.closes = closes

    def blocked(self, points, times):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        t = np.asarray(times, dtype=float).reshape(-1)
        return (p[:, 0] >= self.x0) & (p[:, 0] <= self.x1) & (t >= self.closes)


@pytest.mark.parametrize("seed", [0, 1])
def test_rrt_is_time_aware_races_a_closing_gate(robot, seed):
    """A gate across the way shuts at t = 2.4 s: the path's body is through it before then.

    At T = 0.4 s per step the body's times come from the depth of each node (docs/model.md §5):
    walking straight at the longest stride, the body leaves the band (x = 0.5) at 2.2 s,
    so only quick, nearly straight branches get through; one that dawdles would be in the
    band after it shuts, and a tree that misdated its nodes by one step would either find
    no path (late) or grow nodes into the shut gate (early).
    """
    period, closes = 0.4, 2.4
    gate = ClosingWall(0.3, 0.5, closes)
    start = make_start(RIGHT, 0.0)
    goal, radius = np.array([1.0, 0.0]), 0.1
    settings = {**NUMPY_RRT, "edge_samples": 6}
    rrt = ModifiedRRT(robot, **settings)
    path = rrt.plan(start, goal, radius, gate, period=period, rng=np.random.default_rng(seed))
    assert path is not None
    check_path(path, start, goal, radius, robot, settings["step_size"])
    check_tree_edges(rrt.tree, start, robot, settings["step_size"])  # depths too
    pts, times = body_samples(path, start, period, settings["edge_samples"])
    assert not gate.blocked(pts, times).any()
    beyond = np.flatnonzero(pts[:, 0] > 0.5)
    assert beyond.size and times[beyond[0]] <= closes + period / (settings["edge_samples"] - 1) + 1e-9
    # the same tree checked the gate at every node's own time: no node's body segment is in the
    # band after it shut
    tree = rrt.tree
    n = tree.n
    for i in range(1, n):
        p = tree.parent[i]
        depth = tree.depth[p]
        a = start.body if p == 0 else 0.5 * (tree.xy[tree.parent[p]] + tree.xy[p])
        b = 0.5 * (tree.xy[p] + tree.xy[i])
        s = np.linspace(0.0, 1.0, settings["edge_samples"])
        seg = a + s[:, None] * (b - a)
        assert not gate.blocked(seg, (depth + s) * period).any(), i


def test_rrt_blocking_gate_that_shut_before_any_crossing(robot):
    """The same gate shut from the start (closes at 0): no path, partial path before it."""
    gate = ClosingWall(0.3, 0.5, 0.0)
    start = make_start(RIGHT, 0.0)
    rrt = ModifiedRRT(robot, **NUMPY_RRT)
    assert rrt.plan(start, (1.0, 0.0), 0.1, gate, period=0.4, rng=np.random.default_rng(0)) is None
    assert np.all(rrt.best_partial_path().nodes[:, 0] < 0.3 + 0.5 * RRT_SETTINGS["step_size"])


def test_rrt_goal_nodes_are_distinct_paths(robot):
    """``n_paths`` goal nodes should be ``n_paths`` different ways to the goal, not one path plus steps in place."""
    start = make_start(RIGHT, 0.6, node=(0.2, -0.1))
    goal = np.array([1.6, 0.4])
    for seed in range(20):
        rrt = ModifiedRRT(robot, **NUMPY_RRT)
        rrt.plan(start, goal, 0.1, AlwaysFree(), period=0.8, rng=np.random.default_rng(seed))
        tree = rrt.tree
        edge = np.linalg.norm(tree.xy[1:tree.n] - tree.xy[tree.parent[1:tree.n]], axis=1)
        assert np.all(edge > 0), (seed, np.flatnonzero(edge == 0) + 1)


@pytest.mark.parametrize("compiled", [False, True])
def test_rrt_takes_the_first_of_equally_long_goal_paths(robot, compiled):
    """Two seed walks of ten full strides reach the goal: equally long, but for rounding (the one 0.02 rad off
    the axis sums to 0.9999999999999998 m in numpy, the straight one to 1.0). The first found is taken either
    way round, with both kernels: rounding, which differs between them, does not choose the path."""
    from footstep_gym.planners.rrt import COST_TIE_M

    start = make_start(RIGHT, 0.0)
    k = np.arange(11)[:, None] * 0.1
    straight = start.node + k * [1.0, 0.0]
    tilted = start.node + k * [math.cos(0.02), math.sin(0.02)]
    goal = start.node + 0.95 * 0.5 * (np.array([1.0, 0.0]) + [math.cos(0.02), math.sin(0.02)])  # by both last bodies
    for seeds in ([straight, tilted], [tilted, straight]):
        rrt = ModifiedRRT(robot, **{**RRT_SETTINGS, "iterations": 1, "n_paths": 2,
                                     "kernels": select_kernels(compiled)})
        path = rrt.plan(start, goal, 0.03, empty_predictor_body(robot), period=0.8, rng=np.random.default_rng(0),
                        seeds=seeds)
        costs = rrt.tree.cost[rrt.goal_nodes[:2]]
        assert rrt.goal_nodes[:2] == [10, 20] and abs(costs[0] - costs[1]) < COST_TIE_M
        np.testing.assert_array_equal(path.nodes, seeds[0])
    if not compiled:
        assert costs[0] != costs[1]  # the numpy kernels' costs do differ by rounding (as the docstring says)


# ====================================================================== stage 3: PSO

class LateZone:
    """Blocks ``x > x0`` for times ``t > after``, and everything for ``t > closes``; ``slack`` agrees with ``free``."""

    def __init__(self, x0, after, closes=np.inf):
        self.x0, self.after, self.closes = x0, after, closes

    def blocked(self, points, times):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        t = np.asarray(times, dtype=float).reshape(-1)
        return ((p[:, 0] > self.x0) & (t > self.after)) | (t > self.closes)

    def free(self, points, times, normals, period):
        return ~self.blocked(points, times)

    def slack(self, points, times, normals, period):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        room = np.minimum(np.abs(self.x0 - p[:, 0]), 1.0)
        return np.where(self.blocked(points, times), -0.05 - room, room)


def test_best_partial_path_waits_where_it_stays_free(robot):
    """Beyond x = 0.5 everything is blocked after 1 s. At 0.1 s per step the tree gets past 0.5 before
    then, but a robot standing there would be hit: with stay_until it stops short of 0.5."""
    period, goal = 0.1, np.array([1.5, 0.0])
    zone = LateZone(0.5, 1.0)
    start = make_start(RIGHT, 0.0)
    rrt = ModifiedRRT(robot, **NUMPY_RRT)
    assert rrt.plan(start, goal, 0.1, zone, period=period, rng=np.random.default_rng(0)) is None
    tree = rrt.tree
    xy, body = tree.xy[: tree.n], tree.body[: tree.n]
    dist = np.linalg.norm(xy - goal, axis=1)
    greedy = rrt.best_partial_path()
    assert greedy.nodes[-1, 0] > 0.5  # nearest the goal, in the zone that closes
    stay = rrt.best_partial_path(stay_until=3.0)
    assert not stay.reached_goal
    end = stay.nodes[-1]
    assert end[0] <= 0.5  # standing there until 3 s is free
    # spots whose whole stay (body from where it arrived to the node, then on the node) is at x <= 0.5
    safe = (xy[:, 0] <= 0.5) & (body[:, 0] <= 0.5)
    assert safe.sum() > 1
    assert np.linalg.norm(end - goal) <= dist[safe].min() + 1e-5
    assert np.linalg.norm(end - goal) > np.linalg.norm(greedy.nodes[-1] - goal)
    check_path(stay, start, goal, 0.1, robot, RRT_SETTINGS["step_size"])


def test_best_partial_path_takes_the_spot_hit_last(robot):
    """Beyond x = 0.3 blocked after 1 s, everything after 2.5 s: every spot is hit, those at x <= 0.3 last."""
    period, goal = 0.1, np.array([1.5, 0.0])
    zone = LateZone(0.3, 1.0, closes=2.5)
    start = make_start(RIGHT, 0.0)
    rrt = ModifiedRRT(robot, **NUMPY_RRT)
    assert rrt.plan(start, goal, 0.1, zone, period=period, rng=np.random.default_rng(1)) is None
    xy = rrt.tree.xy[: rrt.tree.n]
    assert xy[:, 0].max() > 0.4
    greedy = rrt.best_partial_path()
    assert greedy.nodes[-1, 0] > 0.3
    late = rrt.best_partial_path(stay_until=5.0)
    assert late.nodes[-1, 0] <= 0.3


# ====================================================================== the paper's RRT (switches off)
def test_rrt_not_time_aware_checks_every_node_against_the_obstacles_after_one_period(robot):
    """``time_aware=False`` (the paper: the obstacle predicted after T, then the tree): the same tree as the
    time-aware one in free space, every body point asked at t = T (the same numpy kernels both ways, only the
    times differ: exact on any CPU)."""
    period = 0.55
    start = make_start(RIGHT, 0.0)
    timed, frozen = Recorder(), Recorder()
    a = ModifiedRRT(robot, **{**NUMPY_RRT, "iterations": 200})
    b = ModifiedRRT(robot, **{**NUMPY_RRT, "iterations": 200}, time_aware=False)
    a.plan(start, (1.0, 0.5), 0.1, timed, period=period, rng=np.random.default_rng(5))
    b.plan(start, (1.0, 0.5), 0.1, frozen, period=period, rng=np.random.default_rng(5))
    rows_a, rows_b = np.concatenate(timed.rows), np.concatenate(frozen.rows)
    assert rows_a[:, 2].max() > 2 * period  # the time-aware tree asks about later times
    np.testing.assert_array_equal(rows_b[:, 2], period)
    np.testing.assert_array_equal(rows_b[:, [0, 1, 3, 4]], rows_a[:, [0, 1, 3, 4]])


def test_rrt_not_time_aware_is_blocked_by_a_gate_that_opens_later(robot):
    """A wall across the way that clears at 2 s: the time-aware tree reaches the goal behind it (its nodes
    there come later than 2 s at 0.8 s per step), the paper's tree sees the wall as it stands at T and does not."""
    start = make_start(RIGHT, 0.0)
    gate = Wall(0.3, 0.4, until=2.0)
    timed = ModifiedRRT(robot, **{**NUMPY_RRT, "iterations": 2000})
    frozen = ModifiedRRT(robot, **{**NUMPY_RRT, "iterations": 2000}, time_aware=False)
    assert timed.plan(start, (1.0, 0.0), 0.1, gate, period=0.8, rng=np.random.default_rng(0)) is not None
    assert frozen.plan(start, (1.0, 0.0), 0.1, gate, period=0.8, rng=np.random.default_rng(0)) is None


def test_path_search_without_fallback_takes_the_branch_nearest_the_goal(robot):
    """Stage 2's unit with ``additions.fallback`` off: no goal path -> the node nearest the goal
    (:meth:`best_partial_path` without ``stay_until``); with it on, the spot that stays free longest."""
    import gymnasium as gym

    from footstep_gym.planners.params import load_planner_config
    from footstep_gym.planners.rrt import PathSearch
    from footstep_gym.planners.walks import walk_start

    env = gym.make("FootstepCrossing-v0")
    env.reset(seed=0)
    snap = env.unwrapped.sensing()
    env.close()
    start = walk_start(snap, 0.5 * robot.nominal_side_stride)
    zone = LateZone(0.5, 1.0)
    out = {}
    for fallback in (False, True):
        stage = PathSearch(robot, load_planner_config({"additions_fallback": fallback}), select_kernels(False))
        out[fallback] = stage(snap, start, zone, 0.1, (), None, np.random.default_rng(0))
        assert not out[fallback].reached_goal and out[fallback].path.n_steps > 0
    assert out[False].path.nodes[-1, 0] > 0.5  # the greedy branch enters the zone that closes after 1 s
    assert out[True].path.nodes[-1, 0] <= 0.5  # the fallback waits short of it
