"""The ``lookahead`` planner: its rollouts against the env, a case where one-step greed fails, and replays."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import make_policy
from footstep_gym.errors import ConfigError
from footstep_gym.planners.lookahead import SwayTable, roll_out
from footstep_gym.planners.params import load_planner_config
from footstep_gym.planners.prediction import ObstaclePredictor, sway_band
from footstep_gym.sensing import ObstacleView
from planner_helpers import play


def _free_snapshot():
    """The door scene's start, its obstacles taken away, the goal 1.5 m straight ahead."""
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=3)
    snap = env.unwrapped.sensing()
    x, y = snap.centre
    return env, dataclasses.replace(snap, obstacles=(), goal=(x + 1.5, y), goal_tolerance=0.05)


def _crossing(snap, ahead: float, cross_t: float, speed: float = 0.3):
    """A pedestrian (radius 6 cm) crossing the robot's straight path ``ahead`` [m] in front, at ``cross_t`` [s]."""
    x, y = snap.centre
    ped = ObstacleView(name="ped", kind="circle", static=False, position=(x + ahead, y - speed * cross_t), angle=0.0,
                       velocity=(0.0, speed), angular_velocity=0.0, radius=0.06, a=(0.0, 0.0), b=(0.0, 0.0))
    return dataclasses.replace(snap, obstacles=(ped,))


FORWARD = np.array([0.08, 0.08, 0.0, 0.6, 0.2])
WAIT = np.array([0.0, 0.08, 0.0, 0.6, 0.2])


def test_rollouts_end_where_the_env_walks_the_same_commands():
    """The rollout's carried LIPM state and footstep placement agree with the env stepping the same sequence."""
    env, snap = _free_snapshot()
    robot = env.unwrapped.robot
    policy = make_policy("lookahead", robot, seed=0)
    rng = np.random.default_rng(1)
    seqs = np.stack([np.stack([FORWARD] * 4), np.stack([WAIT, FORWARD, FORWARD, WAIT]),
                     np.column_stack([rng.uniform(0.0, 0.06, 4), np.full(4, 0.08), rng.uniform(-0.05, 0.05, 4),
                                      rng.uniform(0.3, 0.6, 4), np.full(4, 0.2)])])
    roll = roll_out(robot, policy.params, snap, ObstaclePredictor(snap), seqs, policy.safe_distance, SwayTable(robot),
                    policy.speed, 3)
    assert (roll.survived == 4).all() and roll.first_feasible.all()
    for i, seq in enumerate(seqs):
        env.reset(seed=3)
        for command in seq:
            _, _, terminated, truncated, info = env.step(command.astype(np.float32))
            assert not (terminated or truncated)
        centre = np.asarray(env.unwrapped.sensing().centre)
        assert np.allclose(centre, roll.end_centre[i], atol=1e-6)  # the env reads the command in float32
        assert info["time"] == pytest.approx(roll.time[i], abs=1e-6)
    env.close()


def test_the_sway_table_interpolates_the_closed_form():
    robot = make_policy("period-aware").robot
    table = SwayTable(robot)
    for period in (0.31, 0.45, 0.62, 0.8, 0.87):
        assert table(np.array([period]))[0] == pytest.approx(max(sway_band(robot, period)), abs=2e-3)


def test_one_step_greed_walks_into_a_crossing_that_four_steps_see():
    """A pedestrian crosses 0.3 m ahead 2.4 s from now. Judged one step ahead, walking on is best; judged four steps
    ahead, it collides on the third step while waiting first stays clear, and the planner's plan does not collide."""
    env, free = _free_snapshot()
    robot = env.unwrapped.robot
    snap = _crossing(free, ahead=0.3, cross_t=2.4)
    policy = make_policy("lookahead", robot, seed=0, lookahead={"greedy_seed": False})
    args = (ObstaclePredictor(snap), policy.safe_distance, SwayTable(robot), policy.speed, 3)
    go_on, wait_first = np.stack([FORWARD] * 4), np.stack([WAIT, WAIT, WAIT, FORWARD])
    four = roll_out(robot, policy.params, snap, args[0], np.stack([go_on, wait_first]), *args[1:])
    assert list(four.survived) == [2, 4]
    assert four.cost[1] < four.cost[0]
    one = roll_out(robot, dataclasses.replace(policy.params, horizon_steps=1, dwell_s=0.0), snap, args[0],
                   np.stack([go_on[:1], wait_first[:1]]), *args[1:])
    assert list(one.survived) == [1, 1] and one.cost[0] < one.cost[1]  # greed prefers walking on
    for seed in range(3):
        policy.reset(seed=seed)
        command = policy.act(None, snap)
        assert policy.last_info["lookahead_cost"] < policy.params.collision_penalty / policy.params.horizon_steps
        assert command[0] < FORWARD[0]  # it does not stride on at full length into the pedestrian's path
    env.close()


def test_the_greedy_command_is_kept_when_its_plan_holds():
    env, snap = _free_snapshot()
    policy = make_policy("lookahead", env.unwrapped.robot, seed=0)
    greedy = make_policy("period-aware", env.unwrapped.robot, seed=0)
    policy.reset(seed=0)
    greedy.reset(seed=0)
    command = policy.act(None, snap)
    assert policy.last_info["lookahead_kept_greedy"] is True
    assert np.array_equal(command, greedy.act(None, snap))
    env.close()


def test_lookahead_episodes_replay_exactly():
    env = gym.make("FootstepDoor-v0", tier="structure", tier_cell="any_phase")
    policy = make_policy("lookahead", env.unwrapped.robot, seed=0)
    runs = [play(env, policy, seed=10001, policy_seed=4) for _ in range(2)]
    assert np.array_equal(runs[0][0], runs[1][0]) and runs[0][1] == runs[1][1]
    env.close()


def test_bad_lookahead_settings_are_named():
    with pytest.raises(ConfigError, match="lookahead.elites"):
        load_planner_config({"lookahead": {"elites": 100, "samples": 64}})
    with pytest.raises(ConfigError, match="lookahead.samples"):
        load_planner_config({"lookahead": {"samples": 4, "elites": 2}})
