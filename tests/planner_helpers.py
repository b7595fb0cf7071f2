"""Shared hand-made cases of the planner tests: body checks with known answers, starts, the hardware limits.

Written out here from the paper and docs/model.md, not read from the code under test.

Floating point across CPUs: the same code on the same inputs gives the same bits on any machine (a seeded
replay is compared exactly). Two routes through the same maths do not always: numpy picks SIMD kernels per
CPU at run time (``exp``, ``expm1``, ``arctan2`` and complex products round differently with AVX-512 or
AVX2 than libm and plain Python do), so their floats are compared to a few ulps and their verdicts exactly,
with the inputs kept off the ties a few ulps could flip (:data:`ZMP_TIE_MARGIN`).
"""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import footstep
from footstep_gym.planners.prediction import BodyModel, ObstaclePredictor
from footstep_gym.planners.walks import WalkStart
from footstep_gym.robot import load_robot

LEFT, RIGHT = 1, -1
EPS = 1e-9

#: Table 1 of the paper: ranges of the increments [dS, dL, dtheta, dT_SS, dT_DS] in SI units.
TABLE1_LOW = np.array([-0.01, -0.01, -math.radians(5.0), -0.4, -0.1])
TABLE1_HIGH = np.array([0.01, 0.01, math.radians(5.0), 0.0, 0.1])
#: PSO settings for the repair tests (fixed here so that config edits cannot change the tests).
PSO_SETTINGS = dict(particles=30, iterations=40, inertia=0.7, c1=1.5, c2=1.5, patience=8,
                    deviation_weight=100.0, infeasible_penalty=1000.0, violation_weight=10000.0)
#: RRT settings (the paper's Max_step_size = the robot's longest front stride, 10 cm).
RRT_SETTINGS = dict(iterations=400, batch_size=10, step_size=0.10, goal_sample_rate=0.2, n_paths=3,
                    sample_margin=0.5, edge_samples=4)


#: [m] The scalar LIPM check (``math``, ``cmath``) and the batched one (numpy) give ZMP offsets an ulp or so
#: apart, so their verdicts agree unless an offset lies that close to the stable region's edge; tests comparing
#: the two verdicts exactly assert no offset lies within this.
ZMP_TIE_MARGIN = 1e-12


def zmp_edge_gaps(robot, result):
    """``(N,)`` [m]: how far each ZMP offset of a batched :func:`lipm.check_steps` ``result`` lies from the edge
    of the stable region, on its nearer axis (a verdict can flip only where this is a few ulps)."""
    hx, hy = robot.zmp_half_extent
    p = np.asarray(result.zmp_offset)
    return np.minimum(np.abs(hx - np.abs(p[:, 0])), np.abs(hy - np.abs(p[:, 1])))


@pytest.fixture(scope="module")
def robot():
    return load_robot()



class AlwaysFree:
    """A body check with no obstacles; records the shapes of what it was asked."""

    def __init__(self):
        self.calls = []

    def free(self, points, times, normals, period):
        points, times, normals = np.asarray(points), np.asarray(times), np.asarray(normals)
        self.calls.append((points.shape, times.shape, normals.shape, period))
        return np.ones(len(points), dtype=bool)


class Wall:
    """Points with ``x0 <= x <= x1`` and ``|y| < half_width`` are blocked while ``t < until``."""

    def __init__(self, x0, x1, half_width=np.inf, until=np.inf):
        self.x0, self.x1, self.half_width, self.until = x0, x1, half_width, until

    def blocked(self, points, times):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        t = np.asarray(times, dtype=float).reshape(-1)
        return (p[:, 0] >= self.x0) & (p[:, 0] <= self.x1) & (np.abs(p[:, 1]) < self.half_width) & (t < self.until)

    def free(self, points, times, normals, period):
        return ~self.blocked(points, times)


def make_start(side=RIGHT, heading=0.0, node=(0.0, 0.0)):
    node = np.asarray(node, dtype=float)
    return WalkStart(node=node, heading=heading, side=side, body=node.copy(), previous_node=node.copy())


def angle_limits(parent_side, robot):
    """Hardware limits of the turn of the foot placed next to a ``parent_side`` support foot.

    Written out from docs/model.md §1 / paper Fig. 4: the left foot (swinging from a right
    support) may turn left (counter-clockwise, away from the support foot) by up to
    ``turn_outer`` and right by up to ``turn_inner``; mirrored for the right foot.
    """
    if parent_side == RIGHT:  # left foot swings
        return -robot.turn_inner, robot.turn_outer
    return -robot.turn_outer, robot.turn_inner


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def check_tree_edges(tree, start, robot, step_size):
    """Every edge of the tree, re-derived from node coordinates only."""
    n = tree.n
    assert n >= 2
    xy, parent = tree.xy[:n], tree.parent[:n]
    assert parent[0] == -1
    assert np.all(parent[1:] >= 0) and np.all(parent[1:] < np.arange(1, n))  # parents come first
    # headings and sides from coordinates and the tree's shape alone
    heading = np.empty(n)
    side = np.empty(n, dtype=int)
    depth = np.empty(n, dtype=int)
    cost = np.empty(n)
    heading[0], side[0], depth[0], cost[0] = start.heading, start.side, 0, 0.0
    for i in range(1, n):
        p = parent[i]
        vec = xy[i] - xy[p]
        length = float(np.hypot(*vec))
        assert length <= step_size + 1e-9, (i, length)
        # a zero-length edge (stepping in place; see test_rrt_goal_nodes_are_distinct_paths) has no
        # direction to derive: its stored heading is checked against the limits instead
        heading[i] = math.atan2(vec[1], vec[0]) if length > 0 else tree.heading[i]
        turn = wrap(heading[i] - heading[p])
        lo, hi = angle_limits(side[p], robot)
        assert (lo, hi) == footstep.turn_bounds(side[p], robot)
        assert lo - 1e-9 <= turn <= hi + 1e-9, (i, turn, lo, hi)
        side[i] = -side[p]
        depth[i] = depth[p] + 1
        cost[i] = cost[p] + length
    # the tree's own bookkeeping agrees with the geometry
    np.testing.assert_allclose(wrap(tree.heading[:n] - heading), 0.0, atol=1e-9)
    np.testing.assert_array_equal(tree.side[:n], side)
    np.testing.assert_array_equal(tree.depth[:n], depth)
    np.testing.assert_allclose(tree.cost[:n], cost, rtol=0, atol=1e-9)
    return heading, side, cost


def check_path(path, start, goal, goal_radius, robot, step_size):
    nodes = path.nodes
    assert nodes.ndim == 2 and nodes.shape[1] == 2 and len(nodes) >= 2
    np.testing.assert_array_equal(nodes[0], start.node)
    assert path.n_steps == len(nodes) - 1
    # sides alternate, starting from the support side
    assert path.sides[0] == start.side
    assert np.all(path.sides[1:] == -path.sides[:-1])
    # edges: step size and angle limits relative to the previous heading (from coordinates)
    vec = np.diff(nodes, axis=0)
    lengths = np.hypot(vec[:, 0], vec[:, 1])
    assert np.all(lengths > 0) and np.all(lengths <= step_size + 1e-9)
    heading = np.concatenate([[start.heading], np.arctan2(vec[:, 1], vec[:, 0])])
    for k in range(path.n_steps):
        lo, hi = angle_limits(path.sides[k], robot)
        turn = wrap(heading[k + 1] - heading[k])
        assert lo - 1e-9 <= turn <= hi + 1e-9, (k, turn, lo, hi)
    np.testing.assert_allclose(wrap(path.headings - heading), 0.0, atol=1e-9)
    # cost = cumulative length (Algorithm 2)
    assert path.cost == pytest.approx(lengths.sum(), abs=1e-9)
    if path.reached_goal:
        # the last step brings the body (the midpoint of its two nodes) into the goal region
        assert np.linalg.norm(0.5 * (nodes[-2] + nodes[-1]) - goal) <= goal_radius + 1e-12


def body_samples(path, start, period, samples):
    """The body's points and times along a path, derived here (docs/model.md §5: the body walks the node midpoints).

    During step ``d`` (``(d-1) T .. d T``) the body moves from where it was to the midpoint
    of nodes ``d-1`` and ``d``; it starts at ``start.body``.
    """
    nodes = path.nodes
    bodies = np.vstack([start.body, 0.5 * (nodes[:-1] + nodes[1:])])
    s = np.linspace(0.0, 1.0, samples)
    pts = bodies[:-1, None, :] + s[None, :, None] * (bodies[1:] - bodies[:-1])[:, None, :]
    d = np.arange(path.n_steps, dtype=float)
    times = (d[:, None] + s[None, :]) * period
    return pts.reshape(-1, 2), times.reshape(-1)


def empty_predictor_body(robot):
    env = gym.make("FootstepCrossing-v0")
    env.reset(seed=0)
    snap = dataclasses.replace(env.unwrapped.sensing(), obstacles=())
    env.close()
    return BodyModel(ObstaclePredictor(snap), robot, margin=0.02)



def play(env: gym.Env, policy, seed: int, policy_seed: int) -> tuple[np.ndarray, str]:
    """One episode of ``policy`` in ``env`` (reset with ``seed``, the policy with ``policy_seed``): the commands it
    chose ``(K, 5)`` and how the episode ended."""
    obs, _ = env.reset(seed=seed)
    policy.reset(seed=policy_seed)
    commands = []
    while True:
        commands.append(policy.act(obs, env.unwrapped.sensing()))
        obs, _, terminated, truncated, info = env.step(commands[-1])
        if terminated or truncated:
            return np.array(commands), info["termination"]
