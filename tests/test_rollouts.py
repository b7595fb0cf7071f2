"""The walks of stage 1 (:mod:`footstep_gym.planners.rollouts`): the committed plan among the goal rollouts,
waiting rollouts, and the paper's one-step fan of next nodes (Fig. 2), with body checks written here.
"""

from __future__ import annotations

import math

import numpy as np

from footstep_gym.planners.rollouts import GoalRollouts, NextNodeFan
from footstep_gym.planners.walks import CommittedPlan
from planner_helpers import LEFT, RIGHT, AlwaysFree, angle_limits, make_start, robot  # noqa: F401

class Blocks:
    """Body check blocking points with ``y > y0`` at times ``t > after`` (a stub of BodyModel.free)."""

    def __init__(self, y0, after=-np.inf):
        self.y0, self.after = y0, after

    def free(self, points, times, normals, period):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        t = np.asarray(times, dtype=float).reshape(-1)
        return ~((p[:, 1] > self.y0) & (t > self.after))


#: A walk off to the left of the way to the goal: it ends farther from the goal than any rollout.
DETOUR = np.array([[0.0, 0.0], [0.05, 0.05], [0.1, 0.1], [0.15, 0.15]])
DETOUR_HEADINGS = np.array([0.0, math.pi / 4, math.pi / 4, math.pi / 4])


def make_rollouts(robot, body, committed=None, wait_steps=(0,), horizon=3.2, lanes=(-0.065, 0.0, 0.065)):
    return GoalRollouts(body, robot, make_start(RIGHT, 0.0), (2.0, 0.0), 0.1, horizon=horizon, step_size=0.1,
                        lane_offsets=lanes, stride_fractions=(0.7, 1.0), lookahead=0.3, edge_samples=3,
                        wait_steps=wait_steps, committed=committed)


def padded(walk, n):
    """The walk standing at its last node up to ``n`` nodes."""
    return walk[np.minimum(np.arange(n), len(walk) - 1)]


def test_committed_walk_that_is_free_leads_the_free_walks(robot):
    period = 0.8
    plain = make_rollouts(robot, AlwaysFree())
    assert not plain.committed_free(period)  # no commitment: nothing to keep
    others = plain.free_walks(period)
    assert others
    goal = np.array([2.0, 0.0])
    # every rollout ends nearer the goal than the detour does: only the commitment can put it first
    assert all(np.linalg.norm(w[-1] - goal) < np.linalg.norm(DETOUR[-1] - goal) - 0.1 for w in others)

    rollouts = make_rollouts(robot, AlwaysFree(), committed=CommittedPlan(DETOUR, DETOUR_HEADINGS, 0.8))
    assert rollouts.committed_free(period)
    assert not rollouts(period)  # the period does not collide
    walks = rollouts.free_walks(period)
    first = walks[0]
    assert len(first) >= len(DETOUR)
    np.testing.assert_array_equal(first, padded(DETOUR, len(first)))
    assert len(walks) == len(others) + 1
    for w in walks[1:]:
        assert any(np.array_equal(w, o) for o in others)


def test_committed_walk_blocked_is_neither_free_nor_first(robot):
    """A stub blocks everything left of y = 0.04: the detour's body passes (0.075, 0.075) after two steps."""
    period = 0.8
    rollouts = make_rollouts(robot, Blocks(0.04), committed=CommittedPlan(DETOUR, DETOUR_HEADINGS, 0.8), lanes=(0.0,))
    assert not rollouts.committed_free(period)
    assert not rollouts(period)  # the straight lane is still free
    walks = rollouts.free_walks(period)
    assert walks
    assert not any(np.array_equal(w[: len(DETOUR)], DETOUR) for w in walks)
    assert np.all(np.abs(walks[0][:, 1]) < 1e-12)  # the straight rollout leads instead


def test_committed_walk_is_checked_at_its_own_period(robot):
    """The block starts at t = 1 s: at 0.3 s per step the three-step detour is done by 0.9 s, at 0.8 s it is not."""
    rollouts = make_rollouts(robot, Blocks(0.04, after=1.0), committed=CommittedPlan(DETOUR, DETOUR_HEADINGS, 0.8), lanes=(0.0,))
    assert rollouts.committed_free(0.3)
    assert not rollouts.committed_free(0.8)
    # too short a walk to commit to: nothing to keep
    single = make_rollouts(robot, AlwaysFree(), committed=CommittedPlan(DETOUR[:1], DETOUR_HEADINGS[:1], 0.8))
    assert not single.committed_free(0.8)


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
