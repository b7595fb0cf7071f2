"""The walks of stage 1 (:mod:`footstep_gym.planners.rollouts`): waiting rollouts, and the paper's one-step fan
of next nodes (Fig. 2), with body checks written here (not :class:`~footstep_gym.planners.prediction.BodyModel` s:
with the numpy kernels; the compiled ones are held equal to them in ``tests/test_kernels.py``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from footstep_gym.kernels.numpy_kernels import NUMPY
from footstep_gym.planners.rollouts import GoalRollouts, NextNodeFan
from planner_helpers import LEFT, RIGHT, AlwaysFree, angle_limits, make_start, robot, wrap  # noqa: F401


class Blocks:
    """Body check blocking points with ``y > y0`` at times ``t > after`` (a stub of BodyModel.free)."""

    def __init__(self, y0, after=-np.inf):
        self.y0, self.after = y0, after

    def free(self, points, times, normals, period):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        t = np.asarray(times, dtype=float).reshape(-1)
        return ~((p[:, 1] > self.y0) & (t > self.after))



def make_rollouts(robot, body, wait_steps=(0,), horizon=3.2, lanes=(-0.065, 0.0, 0.065)):
    return GoalRollouts(body, robot, make_start(RIGHT, 0.0), (2.0, 0.0), 0.1, horizon=horizon, step_size=0.1,
                        lane_offsets=lanes, stride_fractions=(0.7, 1.0), lookahead=0.3, edge_samples=3,
                        wait_steps=wait_steps, kernels=NUMPY)


def test_waiting_rollouts_step_in_place_first(robot):
    period = 0.8
    rollouts = make_rollouts(robot, AlwaysFree(), wait_steps=(0, 3), horizon=4.0, lanes=(0.0, 0.065))
    nodes, headings = rollouts.nodes(period)
    assert nodes.shape == (8, 6, 2) and headings.shape == (8, 6)  # 2 lanes x 2 strides x 2 waits, 5 steps
    np.testing.assert_array_equal(nodes[:, 0], np.zeros((8, 2)))
    steps = np.linalg.norm(np.diff(nodes, axis=1), axis=2)  # (8, 5) stride of each step
    waiting = np.all(steps[:, :3] == 0.0, axis=1)
    assert waiting.sum() == 4
    # the others set off at once; the waiting ones set off at step 4, with the library's strides
    assert np.all(steps[~waiting, 0] > 0.05)
    assert np.all(steps[waiting, 3] > 0.05)
    np.testing.assert_allclose(np.sort(steps[waiting, 3]), [0.07, 0.07, 0.1, 0.1], atol=1e-12)
    np.testing.assert_allclose(np.sort(steps[~waiting, 0]), [0.07, 0.07, 0.1, 0.1], atol=1e-12)
    # waiting rollouts then walk the same lanes as the others, three steps later
    for w in np.flatnonzero(waiting):
        match = [o for o in np.flatnonzero(~waiting)
                 if np.allclose(nodes[w, 3:], nodes[o, :3], atol=1e-12)]
        assert match, w



# ====================================================================== the paper's one-step check (Fig. 2)
class Closes:
    """Blocks every point at times ``t > at`` [s] (a stub of BodyModel.free)."""

    def __init__(self, at):
        self.at = at

    def free(self, points, times, normals, period):
        return np.asarray(times, dtype=float).reshape(-1) <= self.at


def make_fan(robot, body, side=RIGHT, heading=0.0, directions=9, fractions=(1.0,), goal=(2.0, 0.0), window=None):
    return NextNodeFan(body, robot, make_start(side, heading), goal, 0.1, step_size=0.1, stride_fractions=fractions,
                       directions=directions, edge_samples=3, first_stride=window, kernels=NUMPY)


@pytest.mark.parametrize("side,heading", [(RIGHT, 0.0), (LEFT, 0.0), (RIGHT, 0.7), (LEFT, -2.0)])
def test_fan_spans_the_selectable_range_of_the_next_node(robot, side, heading):
    """Fig. 2 / Fig. 4: next nodes at Max_step_size, in headings from the inner to the outer limit of the foot
    that swings next (limits written out in planner_helpers, not read from the code)."""
    fan = make_fan(robot, AlwaysFree(), side, heading, directions=7, fractions=(0.5, 1.0))
    nodes, headings = fan.nodes(0.8)
    assert nodes.shape == (14, 2, 2) and headings.shape == (14, 2)
    np.testing.assert_array_equal(nodes[:, 0], 0.0)
    vec = nodes[:, 1] - nodes[:, 0]
    np.testing.assert_allclose(np.sort(np.hypot(vec[:, 0], vec[:, 1])), [0.05] * 7 + [0.1] * 7, atol=1e-12)
    turn = wrap(np.arctan2(vec[:, 1], vec[:, 0]) - heading)
    lo, hi = angle_limits(side, robot)
    assert turn.min() == pytest.approx(lo) and turn.max() == pytest.approx(hi)
    np.testing.assert_allclose(np.unique(np.round(turn, 12)), np.linspace(lo, hi, 7), atol=1e-12)
    np.testing.assert_allclose(wrap(headings[:, 1] - np.arctan2(vec[:, 1], vec[:, 0])), 0.0, atol=1e-12)


def test_fan_looks_one_step_ahead_only(robot):
    """Everything is blocked after 1 s: one step of 0.8 s is free, one of 1.2 s is not; the goal rollouts, which
    look further, collide at 0.8 s too."""
    fan = make_fan(robot, Closes(1.0))
    assert not fan(0.8) and fan(1.2)
    assert len(fan.free_walks(0.8)) == 9 and fan.free_walks(1.2) == []
    assert make_rollouts(robot, Closes(1.0))(0.8)


def test_fan_free_walks_are_the_free_directions_nearest_the_goal_first(robot):
    """Body points left of y = 0.01 are blocked; the body steps to the midpoint of the two nodes, so only the
    next nodes with y <= 0.02 are free (those turning right, straight on, and a little left)."""
    fan = make_fan(robot, Blocks(0.01), directions=9)
    nodes, _ = fan.nodes(0.8)
    walks = fan.free_walks(0.8)
    assert len(walks) == int(np.sum(nodes[:, 1, 1] <= 0.02)) and 0 < len(walks) < 9
    assert all(w.shape == (2, 2) and w[1, 1] <= 0.02 for w in walks)
    goal = np.array([2.0, 0.0])
    dist = [round(float(np.linalg.norm(w[-1] - goal)), 3) for w in walks]  # to the millimetre
    assert dist == sorted(dist)


def test_fan_strides_keep_to_the_window_and_never_pass_the_goal(robot):
    fan = make_fan(robot, AlwaysFree(), fractions=(0.2, 1.0), window=lambda T: (0.04, 0.07))
    nodes, _ = fan.nodes(0.5)
    np.testing.assert_allclose(np.sort(np.linalg.norm(nodes[:, 1], axis=1)), [0.04] * 9 + [0.07] * 9, atol=1e-12)
    near = make_fan(robot, AlwaysFree(), goal=(0.03, 0.0))  # 3 cm ahead: no candidate strides past the goal
    nodes, _ = near.nodes(0.5)
    np.testing.assert_allclose(np.linalg.norm(nodes[:, 1], axis=1), 0.03, atol=1e-12)


class BlocksDuring:
    """Body check blocking every point at times in ``[t0, t1]`` [s]."""

    def __init__(self, t0, t1):
        self.t0, self.t1 = t0, t1

    def free(self, points, times, normals, period):
        t = np.asarray(times, dtype=float).reshape(-1)
        return ~((t >= self.t0) & (t <= self.t1))


def test_a_walk_is_checked_until_its_body_reaches_the_goal(robot):
    """The env ends an episode when the robot centre (the midpoint of the feet) is within the goal tolerance,
    not the support foot's node: node 2 of this walk lies in the goal region (8 cm from the goal), but its body
    (midpoint of nodes 1 and 2) is 13 cm away, so step 3 still counts; after step 3 the body is in. (The numpy
    kernels; the compiled ones are held equal to them in test_kernels.py.)"""
    from footstep_gym.planners.walks import trim_at_goal

    def check(body):
        return np.isinf(NUMPY.walks_survival(body, start, [(nodes, headings)], [period], 3, goal, radius)[0])
    start = make_start(RIGHT, 0.0)
    nodes = np.array([[[0.0, 0.0], [0.1, 0.0], [0.2, 0.0], [0.3, 0.0], [0.3, 0.0]]])
    headings = np.zeros((1, 5))
    goal, radius, period = np.array([0.28, 0.0]), 0.1, 0.5
    assert np.linalg.norm(nodes[0, 2] - goal) <= radius < np.linalg.norm(0.5 * (nodes[0, 1] + nodes[0, 2]) - goal)
    during_step_3 = BlocksDuring(2 * period + 0.01, 3 * period - 0.01)
    after_step_3 = BlocksDuring(3 * period + 0.01, 4 * period)
    assert not check(during_step_3)[0]
    assert check(after_step_3)[0]
    np.testing.assert_array_equal(trim_at_goal(nodes[0], goal, radius), nodes[0, :4])
    # several walks at once: the step that brings each body in (the walk's own length if none does)
    from footstep_gym.planners.walks import steps_to_goal
    short = nodes.copy()
    short[0, 2:] = nodes[0, 1]  # stops at node 1: its body never gets within the radius
    np.testing.assert_array_equal(steps_to_goal(np.concatenate([nodes, short]), goal, radius), [3, 4])
    np.testing.assert_array_equal(trim_at_goal(nodes[0, :1], goal, radius), nodes[0, :1])  # the start alone
