"""Null baselines (footstep_gym/planners/null.py): blind policies made by name, whose commands owe nothing to what
the env shows them."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym
from footstep_gym import make_policy
from footstep_gym.planners import POLICIES
from footstep_gym.planners.null import NULL_POLICIES, WALKER_PERIODS, WALKER_STRIDES, is_null, walker_name
from footstep_gym.registry import resolve
from footstep_gym.robot import load_robot


def test_every_null_baseline_is_registered_and_described():
    assert len(NULL_POLICIES) == len(WALKER_STRIDES) * len(WALKER_PERIODS) + 2
    for name in NULL_POLICIES:
        assert name in POLICIES and is_null(name) and not resolve(name).reads_truth
        description = resolve(name).description
        assert description.startswith("null baseline") or "steps in place" in description
    assert not any(is_null(name) for name in POLICIES if name not in NULL_POLICIES)


@pytest.mark.parametrize("stride, period", [(s, t) for s in WALKER_STRIDES for t in WALKER_PERIODS])
def test_a_constant_walker_sends_its_command_whatever_it_is_shown(stride, period):
    robot = load_robot()
    policy = make_policy(walker_name(stride, period), robot, seed=0)
    want = [stride, robot.nominal_side_stride, 0.0, period - robot.nominal_t_ds, robot.nominal_t_ds]
    env = gym.make("FootstepCrowd-v0")
    obs, _ = env.reset(seed=1)
    policy.reset(seed=1)
    for garbage in (obs, None, np.full_like(obs, np.nan)):
        np.testing.assert_array_equal(policy.act(garbage, None), want)
    np.testing.assert_array_equal(policy.act(obs, env.unwrapped.sensing()), want)
    assert sum(want[3:]) == pytest.approx(period)


def test_random_commands_fill_the_box_and_replay_from_the_seed():
    robot = load_robot()
    policy = make_policy("null-random", robot, seed=3)
    draws = np.array([policy.act(None, None) for _ in range(500)])
    assert np.all(draws >= robot.command_low) and np.all(draws <= robot.command_high)
    span = (draws.max(axis=0) - draws.min(axis=0)) / (robot.command_high - robot.command_low)
    assert np.all(span > 0.95)  # uniform over the whole box
    policy.reset(seed=3)
    again = np.array([policy.act(None, None) for _ in range(500)])
    np.testing.assert_array_equal(draws, again)
    policy.reset(seed=4)
    assert not np.array_equal(policy.act(None, None), draws[0])


def test_standing_steps_in_place_and_stays_put():
    env = gym.make("FootstepDoor-v0")
    robot = env.unwrapped.robot
    policy = make_policy("null-stand", robot, seed=0)
    obs, _ = env.reset(seed=0)
    start = env.unwrapped.sensing().centre
    for _ in range(10):
        command = policy.act(obs, None)
        np.testing.assert_array_equal(command, robot.nominal_command)
        obs, *_ = env.step(command)
    assert np.linalg.norm(np.asarray(env.unwrapped.sensing().centre) - np.asarray(start)) < 0.01


def test_a_walker_outside_the_robots_box_is_refused_by_name():
    from footstep_gym.planners.null import walker

    slow = walker(0.05, 2.0)
    with pytest.raises(ValueError, match="command box"):
        slow(load_robot(), None, 0, "null-walk-5cm-2s")


def test_a_null_baseline_runs_an_episode_through_the_evaluation():
    from footstep_gym.evaluation.runner import Cell, Task, run_episode

    cell = Cell(footstep_gym.ENV_IDS["crossing"], "crossing", "null-walk-10cm-0.4s")
    result = run_episode(Task(0, cell, 10000))
    assert result.outcome in ("goal", "collision", "fall", "timeout") and result.steps > 0
