"""The ``lattice`` planner: its transition set, its A* against a brute-force search, and its episodes."""

from __future__ import annotations

import dataclasses
import itertools

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import footstep, lipm, make_policy
from footstep_gym.errors import ConfigError
from footstep_gym.planners.lattice import LatticeSearch, centre_speed_bound, transition_set
from footstep_gym.planners.params import load_planner_config
from footstep_gym.planners.prediction import ObstaclePredictor, sway_band
from planner_helpers import play


def _snapshot(env_id: str = "FootstepDoor-v0", seed: int = 3, goal_ahead: float | None = None):
    env = gym.make(env_id)
    env.reset(seed=seed)
    snap = env.unwrapped.sensing()
    robot = env.unwrapped.robot
    env.close()
    if goal_ahead is not None:
        x, y = snap.centre
        yaw = snap.heading
        snap = dataclasses.replace(snap, goal=(x + goal_ahead * np.cos(yaw), y + goal_ahead * np.sin(yaw)),
                                   goal_tolerance=0.05)
    return snap, robot


def test_the_transition_set_is_the_product_of_its_axes_and_each_side_keeps_its_turn_limits():
    config = load_planner_config({"lattice": {"strides": [0.0, 0.05], "side_strides": [0.08, 0.1],
                                                 "turns": [-0.3, 0.0, 0.3], "periods": [0.5, 0.8]}})
    robot = make_policy("period-aware").robot
    commands = transition_set(robot, config.lattice)
    assert commands.shape == (2 * 2 * 3 * 2, 5)
    assert np.allclose(commands[:, 4], robot.nominal_t_ds)
    assert set(np.round(commands[:, 3] + commands[:, 4], 9)) == {0.5, 0.8}
    search = LatticeSearch(robot, config.lattice, 0.1, 5)
    for side in (footstep.LEFT, footstep.RIGHT):
        lo, hi = footstep.turn_bounds(side, robot)
        kept = commands[search.by_side[side], 2]
        assert ((kept >= lo) & (kept <= hi)).all()
        assert len(kept) == 16  # the turn of 0.3 rad is outer on one side only
    with pytest.raises(ConfigError, match="lattice.turns"):
        load_planner_config({"lattice": {"turns": []}})
    with pytest.raises(ConfigError, match="lattice.heuristic_weight"):
        load_planner_config({"lattice": {"heuristic_weight": 0.5}})


def test_the_speed_bound_holds_for_every_step_of_random_walks():
    """No step of the set moves the robot centre faster than the heuristic's speed (h stays admissible)."""
    config = load_planner_config({"lattice": {"turns": [0.0]}})
    robot = make_policy("period-aware").robot
    commands = transition_set(robot, config.lattice)
    bound = centre_speed_bound(robot, commands)
    rng = np.random.default_rng(0)
    a, b, side = (0.0, 0.0, 0.0), (0.0, 0.08, 0.0), footstep.RIGHT  # support (right) and swing (left) feet
    for _ in range(400):
        cmd = commands[rng.integers(len(commands))]
        new = footstep.place_foot(a, side, *cmd[:3])
        moved = 0.5 * np.hypot(new[0] - b[0], new[1] - b[1])
        assert moved <= bound * (cmd[3] + cmd[4]) + 1e-12
        a, b, side = new, a, -side


def _clear(search: LatticeSearch, predictor, com_start, com_end, t_start: float, period: float) -> bool:
    """One CoM path clear: its clearance reaches the safe distance plus the LIPM's sway at ``period``."""
    clearance = search.body_clearance(predictor, com_start, com_end[None], t_start, np.array([period]))[0]
    return clearance >= search.safe + max(sway_band(search.robot, round(float(period), 4)))


def _brute_force_time(search: LatticeSearch, snap, predictor, depth: int) -> float:
    """The shortest walking time to the goal over every command sequence of at most ``depth`` steps (inf: none)."""
    goal = np.asarray(snap.goal)
    best = np.inf
    commands = search.commands
    for n in range(1, depth + 1):
        for seq in itertools.product(range(len(commands)), repeat=n):
            support, side = tuple(snap.support_foot), int(snap.support_side)
            com, vel = np.asarray(snap.com_local, float), np.asarray(snap.vel_local, float)
            t = 0.0
            for k, i in enumerate(seq):
                cmd = commands[i]
                lo, hi = footstep.turn_bounds(side, search.robot)
                if not lo - 1e-9 <= cmd[2] <= hi + 1e-9:
                    break
                res = lipm.check_steps(search.robot, com, vel, cmd[None], side)
                if not res.feasible[0]:
                    break
                new = footstep.place_foot(support, side, *cmd[:3])
                start_com = footstep.local_to_world(support, com)
                end_com = footstep.local_to_world(new, res.end_com[0])
                period = cmd[3] + cmd[4]
                if not _clear(search, predictor, start_com, end_com, t, period):
                    break
                centre = 0.5 * (np.asarray(support[:2]) + np.asarray(new[:2]))
                t += period
                support, side, com, vel = new, -side, res.end_com[0], res.end_vel[0]
                if np.hypot(*(centre - goal)) <= snap.goal_tolerance:
                    best = min(best, t)
                    break
                if k == n - 1:
                    break
    return best


@pytest.mark.parametrize("goal_ahead", [0.12, 0.2])
def test_a_star_finds_the_brute_force_optimum_on_a_tiny_transition_set(goal_ahead):
    snap, robot = _snapshot(goal_ahead=goal_ahead)
    config = load_planner_config({"lattice": {
        "strides": [0.0, 0.05, 0.09], "side_strides": [0.08], "turns": [0.0], "periods": [0.5, 0.8],
        "max_expansions": 100000, "max_depth": 4, "xy_resolution_m": 1e-6, "yaw_resolution_rad": 1e-6,
        "time_resolution_s": 1e-6}})
    search = LatticeSearch(robot, config.lattice, robot.body_radius + config.prediction.safety_margin_m,
                           config.prediction.edge_samples)
    predictor = ObstaclePredictor(snap, horizon=config.prediction.horizon_s)
    result = search.search(snap, predictor)
    best = _brute_force_time(search, snap, predictor, depth=4)
    assert np.isfinite(best)
    assert result.reached_goal
    assert result.plan_time_s == pytest.approx(best, abs=1e-9)


def test_a_wall_across_the_way_is_never_stepped_into():
    """A static wall predicted between the robot and the goal: every plan's first step keeps the body clear."""
    snap, robot = _snapshot(goal_ahead=0.6)
    x, y = snap.centre
    wall = footstep_gym.sensing.ObstacleView(
        name="wall", kind="segment", static=True, position=(x + 0.25, y), velocity=(0.0, 0.0), angle=np.pi / 2,
        angular_velocity=0.0, a=(-0.3, 0.0), b=(0.3, 0.0), radius=0.01)
    snap = dataclasses.replace(snap, obstacles=(wall,))
    policy = make_policy("lattice", robot, seed=0)
    policy.reset(seed=0)
    command = policy.act(None, snap)
    predictor = ObstaclePredictor(snap)
    side = int(snap.support_side)
    new = footstep.place_foot(snap.support_foot, side, *command[:3])
    res = lipm.check_steps(robot, snap.com_local, snap.vel_local, command[None], side)
    assert res.feasible[0]
    end = footstep.local_to_world(new, res.end_com[0])[None]
    assert _clear(policy.search, predictor, np.asarray(snap.com), end[0], 0.0, command[3] + command[4])


def test_lattice_episodes_replay_exactly_and_cross_the_crossing():
    env = gym.make("FootstepCrossing-v0")
    policy = make_policy("lattice", env.unwrapped.robot, seed=0)
    runs = [play(env, policy, seed=10000, policy_seed=0) for _ in range(2)]
    assert np.array_equal(runs[0][0], runs[1][0])
    assert runs[0][1] == "goal"
    assert {"lattice_expanded", "lattice_generated", "lattice_depth", "plan_time_ms"} <= set(policy.last_info)
    env.close()
