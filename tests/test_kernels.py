"""The compiled kernels (:data:`NUMBA`, :mod:`footstep_gym.kernels.numba_kernels`) against the numpy ones
(:data:`NUMPY`, :mod:`footstep_gym.kernels.numpy_kernels`), the test oracle.

Both implement :class:`footstep_gym.kernels.Kernels`; each is selected explicitly, as ``configs/planner.yaml``'s
``kernels.compiled`` selects it for the planners (:func:`~footstep_gym.kernels.select_kernels`). On real snapshots
of the three scenes (with per-shape horizons), random points and times, and random walks: the same booleans and
times as the numpy kernels, the same lane pursuit and the same RRT; and whole planner episodes with either: the
same outcomes, the commands to a few ulps. Selecting the numpy kernels never imports numba.

**What is exact, and where.** A kernel and its numpy twin do the same arithmetic, but not always through
the same library: numpy picks SIMD kernels per CPU at run time (with AVX-512, ``np.arctan2``, ``np.exp`` and
``np.expm1`` round some of their results an ulp otherwise than libm, which the kernels call; with AVX2 a
complex product is fused, ``a*c - b*d`` in one rounding, which the kernels' plain products are not), so their
floats agree to a few ulps on one CPU and bit for bit on another. The tests therefore compare

* floats from the two implementations to a few ulps of their scale (:data:`LENGTH_TOL`, :data:`HEADING_ATOL`);
* what is discrete (booleans, node counts, parents, sides, depths, goal nodes, which sample of a walk is
  blocked first, hence its time) exactly. A few-ulp difference flips such a decision only where the values
  it compares lie within about that of a tie, so each test also asserts that none of its decisions does
  by :data:`TIE_MARGIN` or less: on these inputs the discrete results are then the same on any CPU;
* the same kernels twice (a compiled kernel against itself in another batching) exactly, on any CPU.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import footstep
from footstep_gym.kernels import SHAPE_COLUMNS, WalkStart, select_kernels
from footstep_gym.kernels.numpy_kernels import NumpyKernels
from footstep_gym.planners.prediction import BodyModel, ObstaclePredictor
from footstep_gym.planners.rollouts import GoalRollouts
from planner_helpers import LEFT, RIGHT, empty_predictor_body, robot  # noqa: F401

SCENES = [("FootstepDoor-v0", dict(door_speed=17.0), 6), ("FootstepCrossing-v0", {}, 8), ("FootstepCrowd-v0", {}, 5)]

EPS = np.finfo(float).eps  # 2.2e-16
#: Coordinates, lengths and costs [m] of the two kernels (|x| < 4 m here): within 8 eps (1.8e-15 m) plus 2 ulps
#: of the value: a few roundings of one ulp each, which is all that differs between the two arithmetics.
LENGTH_TOL = dict(rtol=2 * EPS, atol=8 * EPS)
#: Headings [rad], compared modulo 2 pi: 16 ulps of pi (7.1e-15 rad). A turn re-drawn inside the limits adds to
#: its parent's heading, so a difference can grow by an ulp a level (the trees here are a few tens deep).
HEADING_ATOL = 16 * math.ulp(math.pi)
#: [m, rad] No decision of these tests may lie this close to a tie (a shape's clearance to the required one,
#: the nearest tree node to the next nearest, a turn to its limit, a body to the goal radius): hundreds of
#: times the tolerances above, so that a different CPU cannot flip it.
TIE_MARGIN = 1e-12

NUMPY, NUMBA = select_kernels(False), select_kernels(True)


def survival(kernels, body, start, nodes, headings, period, goal, goal_radius=0.1):
    """``(R,)`` [s]: when each walk is first blocked (``inf``: free), at 3 samples per step."""
    return kernels.walks_survival(body, start, [(nodes, headings)], [period], 3, goal, goal_radius)[0]


def assert_headings_close(got, want, err_msg=""):
    d = np.asarray(got, dtype=float) - np.asarray(want, dtype=float)
    d = d - 2.0 * np.pi * np.round(d / (2.0 * np.pi))  # pi and -pi (a heading wrapped either way) are one angle
    np.testing.assert_allclose(d, 0.0, rtol=0, atol=HEADING_ATOL, err_msg=err_msg)


def clearance_gaps(pred, points, times, needed):
    """``|distance - (radius + needed)|`` [m] of each point (at its time) to each shape checked then (``inf``
    beyond a shape's horizon): how far each of its obstacle verdicts is from a tie."""
    return np.abs(np.sqrt(pred._distance2(points, times)) - (pred.shapes.radius + needed))


def goal_gaps(bodies, goal, goal_radius):
    """``| |body - goal| - goal_radius |`` [m]: how far each "in the goal region" verdict is from a tie."""
    return np.abs(np.linalg.norm(np.asarray(bodies).reshape(-1, 2) - goal, axis=1) - goal_radius)


class RecordingBody:
    """A :class:`BodyModel`'s check that remembers every point it was asked about (for the numpy kernels, the
    oracle: not being a ``BodyModel``, it has no shape table and the compiled ones refuse it)."""

    def __init__(self, body: BodyModel) -> None:
        self.body, self.asked = body, []

    def free(self, points, times, normals, period):
        self.asked.append((np.array(points, dtype=float), np.array(times, dtype=float), np.array(normals), period))
        return self.body.free(points, times, normals, period)

    def slack(self, points, times, normals, period):
        return self.body.slack(points, times, normals, period)

    def smallest_gap(self) -> float:
        """The smallest :func:`clearance_gaps` [m] of everything asked."""
        gaps = [np.inf]
        for points, times, normals, period in self.asked:
            centres, needed = self.body.centres(points, normals, period)
            gaps.append(clearance_gaps(self.body.predictor, centres, times, needed).min(initial=np.inf))
        return min(gaps)


def snapshot_after(env_id, kwargs, steps, seed=0):
    env = gym.make(env_id, **kwargs)
    env.reset(seed=seed)
    for _ in range(steps):  # the crowd overtakes the nominal walk: the snapshot is then the one at contact
        *_, terminated, truncated, _ = env.step(env.unwrapped.robot.nominal_command)
        if terminated or truncated:
            break
    snap = env.unwrapped.sensing()
    env.close()
    return snap


def predictors(snap):
    """Every shape to the horizon; with a short horizon for the first moving shape; with the moving shapes
    accelerating (different accelerations, held 1 s; the first also with the short horizon)."""
    moving = [v.name for v in snap.obstacles if not v.static]
    yield ObstaclePredictor(snap, horizon=30.0)
    yield ObstaclePredictor(snap, horizon=30.0, horizons={moving[0]: 0.7})
    accelerations = {name: (0.05 * (-1) ** i, 0.03 * (i % 3 - 1)) for i, name in enumerate(moving)}
    yield ObstaclePredictor(snap, horizon=30.0, horizons={moving[0]: 0.7}, accelerations=accelerations,
                            acceleration_horizon=1.0)


@pytest.mark.parametrize("env_id,kwargs,steps", SCENES)
def test_points_free_matches_numpy(env_id, kwargs, steps):
    """The booleans exactly, on any CPU: no point lies within :data:`TIE_MARGIN` of a shape's threshold."""
    snap = snapshot_after(env_id, kwargs, steps)
    rng = np.random.default_rng(0)
    centre = np.asarray(snap.com)
    pts = centre + rng.uniform(-1.0, 2.5, (20000, 2))
    times = rng.uniform(0.0, 5.0, 20000)
    for pred in predictors(snap):
        assert pred.shapes.rows.shape == (pred.n_shapes, SHAPE_COLUMNS)  # the table the kernels read
        for safe in (0.0, 0.11, 0.2):
            got = NUMBA.points_free(pred.shapes, pts, times, safe)
            want = NUMPY.points_free(pred.shapes, pts, times, safe)
            np.testing.assert_array_equal(pred.free(pts, times, safe), want)  # the predictor's own check: numpy
            assert 0 < want.sum() < want.size
            assert clearance_gaps(pred, pts, times, safe).min() > TIE_MARGIN
            np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("env_id,kwargs,steps", SCENES)
@pytest.mark.parametrize("period", [0.3, 0.55, 0.8])
def test_walks_survival_matches_numpy(robot, env_id, kwargs, steps, period):
    """Random walks of 10 cm steps from near the robot (some reaching a goal nearby): the booleans exactly (no
    body point within :data:`TIE_MARGIN` of a tie), and the time of each walk's first blocked point exactly
    (both kernels compute the instants with the same operations: which point is first is all that could
    differ)."""
    snap = snapshot_after(env_id, kwargs, steps)
    rng = np.random.default_rng(1)
    centre = np.asarray(snap.com)
    start = WalkStart(node=centre + [0.0, 0.02], heading=0.1, side=LEFT, body=centre, previous_node=centre - [0, 0.06])
    heading = np.cumsum(rng.uniform(-0.4, 0.4, (300, 25)), axis=1)
    steps_xy = 0.1 * np.stack([np.cos(heading), np.sin(heading)], axis=-1)
    nodes = start.node + np.concatenate([np.zeros((300, 1, 2)), np.cumsum(steps_xy, axis=1)], axis=1)
    headings = np.concatenate([np.full((300, 1), start.heading), heading], axis=1)
    goal = centre + [0.8, 0.0]
    bodies = 0.5 * (np.concatenate([np.tile(start.previous_node, (300, 1, 1)), nodes[:, :-1]], axis=1) + nodes)
    assert goal_gaps(bodies[:, 1:], goal, 0.1).min() > TIE_MARGIN
    blocked = 0
    for pred in predictors(snap):
        body = BodyModel(pred, robot, 0.02)
        asked = RecordingBody(body)
        # the time of each walk's first blocked point: the same instant, inf exactly for the free walks
        got = survival(NUMBA, body, start, nodes, headings, period, goal)
        want = survival(NUMPY, asked, start, nodes, headings, period, goal)
        assert asked.smallest_gap() > TIE_MARGIN
        blocked += int(np.isfinite(want).sum())
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(survival(NUMPY, body, start, nodes, headings, period, goal), want)
    assert blocked > 0 or env_id == "FootstepCrossing-v0"  # the crossing's car may still be far at this time


@pytest.mark.parametrize("side,heading,goal", [(RIGHT, 0.0, (1.9, 0.0)), (LEFT, 2.5, (0.3, 0.6)),
                                               (RIGHT, -1.0, (-1.0, -1.2))])
@pytest.mark.parametrize("window", [None, (0.03, 0.06)])
def test_pursue_lanes_matches_numpy(robot, side, heading, goal, window):
    """``pursue_lanes`` of the compiled kernels against the numpy ones, on the lanes of :class:`GoalRollouts`."""
    start = WalkStart(node=np.array([0.01, -0.02]), heading=heading, side=side, body=np.zeros(2),
                      previous_node=np.zeros(2))
    rollouts = GoalRollouts(empty_predictor_body(robot), robot, start, goal, 0.1, horizon=30.0, step_size=0.1,
                            lane_offsets=(-0.13, -0.065, 0.0, 0.065, 0.13), stride_fractions=(0.7, 1.0),
                            lookahead=0.3, edge_samples=3, wait_steps=(0, 3, 6), kernels=NUMBA)
    depth = 40
    got_nodes, got_headings = NUMBA.pursue_lanes(rollouts.lanes, window, depth)
    want_nodes, want_headings = NUMPY.pursue_lanes(rollouts.lanes, window, depth)
    # within a few ulps (np.angle, np.abs and complex products against libm's atan2 and hypot and plain products);
    # where a rollout stops (its body in the goal region) is discrete: a flip would move its nodes by a stride
    np.testing.assert_allclose(got_nodes, want_nodes, **LENGTH_TOL)
    assert_headings_close(got_headings, want_headings)
    midpoints = 0.5 * (want_nodes[:, 1:] + want_nodes[:, :-1])
    assert goal_gaps(midpoints, np.asarray(goal), rollouts.goal_radius).min() > TIE_MARGIN
    assert np.ptp(got_nodes[:, 1:, :], axis=0).max() > 0.05  # the lanes, strides and waits differ


@pytest.mark.parametrize("env_id,kwargs,steps", SCENES)
def test_survivals_of_many_periods_in_one_call_match_one_period_at_a_time(robot, env_id, kwargs, steps):
    """:meth:`GoalRollouts.survivals` checks the walks of every period of a scan in one compiled call (each
    row with its own period, sway and depth): the same times as checking each period on its own, and
    ``inf`` exactly where ``ObstacleCollision(T)`` is false. The same compiled kernel both ways: exact on
    any CPU."""
    from footstep_gym.planners.walks import walk_start

    snap = snapshot_after(env_id, kwargs, steps)
    start = walk_start(snap, 0.5 * robot.nominal_side_stride)
    body = BodyModel(ObstaclePredictor(snap, horizon=30.0), robot, 0.02)
    periods = np.linspace(0.3, 0.8, 17)
    rollouts = GoalRollouts(body, robot, start, snap.goal, snap.goal_tolerance, horizon=30.0, step_size=0.1,
                            lane_offsets=(-0.13, 0.0, 0.13), stride_fractions=(0.7, 1.0), lookahead=0.3,
                            edge_samples=3, wait_steps=(0, 3), kernels=NUMBA)
    got = rollouts.survivals(periods)
    want = [survival(NUMBA, body, start, *rollouts.nodes(T), T, rollouts.goal, rollouts.goal_radius).max()
            for T in periods]
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(np.isinf(got), [not rollouts(T) for T in periods])
    assert np.isfinite(got).any() or env_id == "FootstepCrossing-v0"  # the times were compared (the car is far yet)


def random_seed_walks(start, rng, n_walks=3, steps=12):
    """Walks from the start node of 8 cm steps with small turns and a few steps in place."""
    walks = []
    for _ in range(n_walks):
        heading = start.heading + np.cumsum(rng.uniform(-0.3, 0.3, steps))
        stride = np.where(rng.random(steps) < 0.2, 0.0, 0.08)  # steps in place keep the last heading
        xy = start.node + np.cumsum(stride[:, None] * np.stack([np.cos(heading), np.sin(heading)], axis=1), axis=0)
        walks.append(np.concatenate([start.node[None], xy]))
    return walks


class TieGapsKernels(NumpyKernels):
    """The numpy kernels, recording how far each decision of the RRT they grow is from a tie."""

    def __init__(self, robot) -> None:
        self.robot = robot
        self.gaps = {"nearest node": [np.inf], "turn limits": [np.inf], "goal region": [np.inf]}

    def nearest_nodes(self, tree, samples):
        """The gap [m] between the distances to the nearest node and to the next nearest elsewhere (a
        step in place leaves two nodes on one spot, with equal distances in both kernels: no tie)."""
        parents = super().nearest_nodes(tree, samples)
        xy = tree.xy[: tree.n]
        dist = np.linalg.norm(samples[:, None, :] - xy[None, :, :], axis=-1)
        elsewhere = np.any(xy[None, :, :] != xy[parents][:, None, :], axis=-1)
        runner_up = np.where(elsewhere, dist, np.inf).min(axis=1)
        self.gaps["nearest node"].append(runner_up - dist[np.arange(len(samples)), parents])
        return parents

    def restrict_to_angle_limits(self, tree, step, parents, samples, redraw):
        vec = samples - tree.xy[parents]
        delta = footstep.wrap_angle(np.arctan2(vec[:, 1], vec[:, 0]) - tree.heading[parents])
        lo, hi = footstep.turn_bounds(tree.side[parents], self.robot)
        self.gaps["turn limits"].append(np.minimum(np.abs(delta - lo), np.abs(delta - hi)))
        return super().restrict_to_angle_limits(tree, step, parents, samples, redraw)

    def in_goal(self, xy, goal, goal_radius):
        self.gaps["goal region"].append(goal_gaps(xy, goal, goal_radius))
        return super().in_goal(xy, goal, goal_radius)

    def smallest_gaps(self):
        return {name: float(np.concatenate([np.ravel(g) for g in values]).min()) for name, values in self.gaps.items()}


def first_divergence(got, want):
    """The first node where two trees differ in shape (parent, side or depth), or ``None``."""
    n = min(got.n, want.n)
    differs = ((got.parent[:n] != want.parent[:n]) | (got.side[:n] != want.side[:n])
               | (got.depth[:n] != want.depth[:n]))
    return int(np.argmax(differs)) if differs.any() else (None if got.n == want.n else n)


@pytest.mark.parametrize("env_id,kwargs,steps", SCENES)
@pytest.mark.parametrize("time_aware", [True, False])
def test_compiled_rrt_grows_the_numpy_tree(robot, env_id, kwargs, steps, time_aware):
    """``extend_tree`` and ``insert_walks`` of the compiled kernels against the numpy ones: from the same
    generator, the same tree node for node, with seed walks, a first-stride window and short horizons.

    Exact on any CPU: the tree's shape (node count, parents, sides, depths), its goal nodes and which nodes the
    path takes, since no decision of the numpy tree lies within :data:`TIE_MARGIN` of a tie. Within a few
    ulps: coordinates, bodies, costs (:data:`LENGTH_TOL`) and headings (:data:`HEADING_ATOL`), as numpy's
    ``arctan2`` differs from libm's by an ulp now and then with AVX-512 (bit for bit without)."""
    from footstep_gym.planners.rrt import ModifiedRRT
    from footstep_gym.planners.walks import walk_start

    snap = snapshot_after(env_id, kwargs, steps)
    start = walk_start(snap, 0.5 * robot.nominal_side_stride)
    goals = [np.asarray(snap.goal), start.node + [0.6, 0.1]]  # the scene's goal and one a few steps away
    compared = blocked = 0
    for pred in predictors(snap):
        body = BodyModel(pred, robot, 0.02)
        for period, window, goal in [(0.8, None, goals[0]), (0.4, (0.04, 0.09), goals[1]), (0.55, None, goals[1])]:
            seeds = random_seed_walks(start, np.random.default_rng(int(period * 100)))
            trees = []
            oracle, asked = TieGapsKernels(robot), RecordingBody(body)
            for kernels, check in ((oracle, asked), (NUMBA, body)):
                rrt = ModifiedRRT(robot, iterations=300, batch_size=10, step_size=0.1, goal_sample_rate=0.2,
                                  n_paths=3, sample_margin=0.5, edge_samples=3, time_aware=time_aware,
                                  kernels=kernels)
                path = rrt.plan(start, goal, snap.goal_tolerance, check, period, np.random.default_rng(5),
                                seeds=seeds, first_stride=window)
                trees.append((rrt.tree, list(rrt.goal_nodes), path))
            (want, want_goals, want_path), (got, got_goals, got_path) = trees
            gaps = {"obstacles": asked.smallest_gap(), **oracle.smallest_gaps()}
            assert min(gaps.values()) > TIE_MARGIN, gaps  # else a few ulps could flip a decision
            where = first_divergence(got, want)
            assert where is None, f"the trees part at node {where} (of {want.n} / {got.n})"
            assert got_goals == want_goals
            for name in ("side", "parent", "depth"):
                np.testing.assert_array_equal(getattr(got, name)[: got.n], getattr(want, name)[: want.n], err_msg=name)
            for name in ("xy", "cost", "body"):
                np.testing.assert_allclose(getattr(got, name)[: got.n], getattr(want, name)[: want.n], **LENGTH_TOL,
                                           err_msg=name)
            assert_headings_close(got.heading[: got.n], want.heading[: want.n], err_msg="heading")
            assert (got_path is None) == (want_path is None)
            if want_path is not None:
                assert got_path.reached_goal == want_path.reached_goal
                np.testing.assert_array_equal(got_path.sides, want_path.sides)
                np.testing.assert_allclose(got_path.nodes, want_path.nodes, **LENGTH_TOL)
                np.testing.assert_allclose(got_path.cost, want_path.cost, **LENGTH_TOL)
            compared += want.n
            blocked += 300 + 1 + sum(len(s) - 1 for s in seeds) - want.n  # samples the obstacles (or goal) refused
    assert compared > 300 and blocked > 0


@pytest.mark.parametrize("env_id,kwargs,steps,ahead", [("FootstepDoor-v0", dict(door_speed=17.0), 6, 1.0),
                                                       ("FootstepCrossing-v0", {}, 3, 1.0),
                                                       ("FootstepCrowd-v0", {}, 3, 0.5)])
def test_free_walks_from_the_scan_table_are_the_walks_checked_again(robot, env_id, kwargs, steps, ahead):
    """Stage 1 reads the free walks at the chosen period from the scan's survival table: the same walks, in the
    same order, as checking that period again (the same compiled kernels both ways: exact on any CPU)."""
    from footstep_gym.planners.walks import walk_start

    snap = snapshot_after(env_id, kwargs, steps)
    start = walk_start(snap, 0.5 * robot.nominal_side_stride)
    body = BodyModel(ObstaclePredictor(snap, horizon=30.0), robot, 0.02)
    goal = start.node + [ahead, 0.0]  # a few steps away: some walks free, some blocked
    rollouts = GoalRollouts(body, robot, start, goal, 0.1, horizon=30.0, step_size=0.1,
                            lane_offsets=(-0.13, -0.065, 0.0, 0.065, 0.13), stride_fractions=(0.7, 1.0),
                            lookahead=0.3, edge_samples=3, wait_steps=(0, 3), kernels=NUMBA)
    periods = np.linspace(0.3, 0.8, 9)
    found = 0
    for T, blocked_at in zip(periods, rollouts.survival_table(periods)):
        want = rollouts.free_walks(float(T))
        got = rollouts.free_walks(float(T), blocked_at=blocked_at)
        assert len(got) == len(want) == int(np.isinf(blocked_at).sum())
        for g, w in zip(got, want):
            np.testing.assert_array_equal(g, w)
        found += len(want)
    assert 0 < found < 9 * len(rollouts._offsets)  # free walks compared, and some periods or walks blocked


# ====================================================================== the setting: kernels.compiled
def test_the_compiled_kernels_refuse_a_body_check_that_is_not_a_body_model(robot):
    """The compiled kernels read a :class:`BodyModel`'s shape table: any other body check is an error, not a
    silent fall back to numpy; the numpy kernels take it. Either is one shared object per setting."""
    from footstep_gym.planners.rrt import ModifiedRRT

    class Free:
        def free(self, points, times, normals, period):
            return np.ones(len(points), dtype=bool)

    start = WalkStart(node=np.zeros(2), heading=0.0, side=RIGHT, body=np.zeros(2), previous_node=np.zeros(2))
    nodes, headings = np.zeros((1, 3, 2)), np.zeros((1, 3))
    rrt = ModifiedRRT(robot, iterations=20, batch_size=10, step_size=0.1, goal_sample_rate=0.2, n_paths=1,
                      sample_margin=0.5, edge_samples=3, kernels=NUMBA)
    with pytest.raises(TypeError, match="need a prediction.BodyModel.*got Free"):
        rrt.plan(start, (1.0, 0.0), 0.1, Free(), 0.5, np.random.default_rng(0))
    with pytest.raises(TypeError, match="need a prediction.BodyModel"):
        survival(NUMBA, Free(), start, nodes, headings, 0.5, np.ones(2))
    with pytest.raises(TypeError, match="need a prediction.BodyModel"):
        NUMBA.body_free(Free(), nodes[0], np.zeros(3), np.zeros((3, 2)), 0.5)
    with pytest.raises(TypeError, match="need a prediction.BodyModel"):
        GoalRollouts(Free(), robot, start, (1.0, 0.0), 0.1, horizon=3.0, step_size=0.1, lane_offsets=(0.0,),
                     stride_fractions=(1.0,), lookahead=0.3, edge_samples=3, kernels=NUMBA)
    assert np.isinf(survival(NUMPY, Free(), start, nodes, headings, 0.5, np.ones(2))).all()
    body = empty_predictor_body(robot)
    assert np.isinf(survival(NUMBA, body, start, nodes, headings, 0.5, np.ones(2))).all()
    assert (NUMPY.name, NUMBA.name) == ("numpy", "numba") and select_kernels(True) is NUMBA
    with pytest.raises(TypeError, match="takes a bool"):
        select_kernels("yes")


#: Episodes planned with both kernels: each stage of each planner (the rollouts and the one-step fan, the scan and the
#: bisection, batches of 10 and of 1, the path and the node check), goals and collisions. Crossing, fixed-period,
#: seed 4 meets two goal paths of as many full strides, equally long but for rounding (rrt.COST_TIE_M).
EPISODES = [("FootstepDoor-v0", dict(door_speed=17.0), "period-aware", 0),
            ("FootstepDoor-v0", dict(door_speed=17.0), "paper-period-aware", 1),
            ("FootstepCrossing-v0", {}, "fixed-period", 4),
            ("FootstepCrossing-v0", {}, "paper-period-aware", 0),
            ("FootstepCrowd-v0", {}, "period-aware", 0),
            ("FootstepCrowd-v0", {}, "period-aware-no-centred-period", 1)]


def _episode(env_id, kwargs, name, seed, compiled):
    """One episode of planner ``name`` with ``kernels.compiled`` set: its end and every command."""
    from footstep_gym import make_policy

    env = gym.make(env_id, **kwargs)
    policy = make_policy(name, env.unwrapped.robot, seed=seed, kernels_compiled=compiled)
    assert policy.kernels is select_kernels(compiled)
    obs, _ = env.reset(seed=seed)
    policy.reset(seed=seed)
    commands = []
    while True:
        commands.append(np.array(policy.act(obs, env.unwrapped.sensing()), dtype=float))
        obs, _, terminated, truncated, info = env.step(commands[-1])
        if terminated or truncated:
            env.close()
            return (len(commands), info["termination"], info["is_success"]), np.array(commands)


@pytest.mark.parametrize("env_id,kwargs,name,seed", EPISODES)
def test_planner_episodes_are_the_same_with_both_kernels(env_id, kwargs, name, seed):
    """``kernels.compiled: false`` (numpy everywhere) plans the episodes of ``true``: the same end (steps,
    goal / collision / fall) and every command to a few ulps (strides and times :data:`LENGTH_TOL`, turns
    :data:`HEADING_ATOL`). An end could differ on another CPU only through a decision within a few ulps of a
    tie."""
    want_end, want = _episode(env_id, kwargs, name, seed, compiled=False)
    got_end, got = _episode(env_id, kwargs, name, seed, compiled=True)
    assert got_end == want_end
    np.testing.assert_allclose(got[:, [0, 1, 3, 4]], want[:, [0, 1, 3, 4]], **LENGTH_TOL)
    assert_headings_close(got[:, 2], want[:, 2])


def test_the_numpy_kernels_never_import_numba():
    """With ``kernels.compiled: false`` and the env's ``compiled_sweep: false``, an episode runs without numba."""
    import subprocess
    import sys

    code = ("import sys, gymnasium as gym, footstep_gym\n"
            "from footstep_gym import make_policy\n"
            "env = gym.make('FootstepDoor-v0', door_speed=17.0, compiled_sweep=False)\n"
            "policy = make_policy('period-aware', env.unwrapped.robot, seed=0, kernels_compiled=False)\n"
            "obs, _ = env.reset(seed=0)\n"
            "while True:\n"
            "    obs, _, terminated, truncated, info = env.step(policy.act(obs, env.unwrapped.sensing()))\n"
            "    if terminated or truncated:\n"
            "        break\n"
            "print(info['termination'], 'numba' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split()[-1] == "False", out.stdout + out.stderr  # (the episode's end printed before)
