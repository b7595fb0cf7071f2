"""The reactive and classical baselines (docs/benchmark.md §3): registered like the nulls, the policy interface,
deterministic under a seed, reading only the sensing snapshot, and sensible on closed-form cases: an empty scene
(every one reaches the goal), an obstacle crossing the straight path (wait-until-clear waits, then goes), one
standing on it (straight-stop stops), ORCA's new velocity against pyrvo's own agent and its period rule."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym
from footstep_gym import make_policy
from footstep_gym.planners.registry import POLICIES
from footstep_gym.sensing import ObstacleView

BASELINES = ("wait-until-clear", "straight-stop", "orca-robot", "dwa")
#: A crowd scene with its one member 30 m away and still: nothing within reach (the goal 3 m ahead).
EMPTY = dict(crowd_size=1, ring_radius=30.0, crowd_speed=0.0)


def _env(**kwargs):
    env = gym.make("FootstepCrowd-v0", **(kwargs or EMPTY))
    env.reset(seed=10000)
    return env


def _circle(name: str, position: tuple[float, float], velocity: tuple[float, float], radius: float = 0.1
            ) -> ObstacleView:
    return ObstacleView(name, "circle", False, position, 0.0, velocity, 0.0, radius, (0.0, 0.0), (0.0, 0.0))


def _with(snapshot, *views: ObstacleView):
    return dataclasses.replace(snapshot, obstacles=tuple(views))


@pytest.mark.parametrize("name", BASELINES)
def test_registered_with_the_interface_and_reaching_the_goal_of_an_empty_scene(name):
    assert name in POLICIES and POLICIES[name].description
    env = _env()
    robot = env.unwrapped.robot
    policy = make_policy(name, robot, seed=3)
    policy.reset(seed=3)
    with pytest.raises(ValueError, match="reads the sensing snapshot"):
        policy.act(None, None)
    steps, commands = 0, []
    while True:
        command = policy.act(None, env.unwrapped.sensing())  # the observation is not read
        assert command.shape == (5,) and np.all(np.isfinite(command))
        assert np.all(command >= robot.command_low - 1e-12) and np.all(command <= robot.command_high + 1e-12)
        assert policy.last_info["policy"] == name
        commands.append(command)
        _, _, terminated, truncated, info = env.step(command)
        steps += 1
        if terminated or truncated:
            break
    assert info["termination"] == "goal", (name, info["termination"], steps)


@pytest.mark.parametrize("name", BASELINES)
def test_deterministic_under_a_seed(name):
    def run() -> list[np.ndarray]:
        env = gym.make("FootstepCrossing-v0", tier="train", tier_cell="train")
        obs, _ = env.reset(seed=10001)
        policy = make_policy(name, env.unwrapped.robot, seed=10001)
        policy.reset(seed=10001)
        out = []
        for _ in range(6):
            out.append(policy.act(obs, env.unwrapped.sensing()))
            obs, _, terminated, truncated, _ = env.step(out[-1])
            if terminated or truncated:
                break
        return out

    a, b = run(), run()
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


def test_wait_until_clear_waits_while_a_crossing_obstacle_blocks_then_goes():
    env = _env()
    snap = env.unwrapped.sensing()  # centre (0, 0), goal (3, 0): the path is the x axis
    policy = make_policy("wait-until-clear", env.unwrapped.robot, seed=0)
    policy.reset(seed=0)
    stride = policy.walk["stride"]
    # 0.8 m to the side of the path 0.2 m ahead, crossing it at 0.5 m/s: on the path within 1.6 s < 3 x 0.8 s.
    coming = _with(snap, _circle("c", (0.2, -0.8), (0.0, 0.5)))
    command = policy.act(None, coming)
    assert policy.last_info["waiting"] and command[0] == 0.0
    # The same obstacle once it has crossed and walks away: the path is clear, it walks the nominal stride.
    gone = _with(snap, _circle("c", (0.2, 0.8), (0.0, 0.5)))
    command = policy.act(None, gone)
    assert not policy.last_info["waiting"] and command[0] == pytest.approx(stride)
    # Crossing well after the horizon (8 s away): no wait; a static one beside the path is no crossing either.
    assert not (policy.act(None, _with(snap, _circle("c", (0.2, -4.0), (0.0, 0.5)))) is None
                or policy.last_info["waiting"])
    beside = dataclasses.replace(_circle("w", (0.2, 0.25), (0.0, 0.0)), static=True)
    policy.act(None, _with(snap, beside))
    assert not policy.last_info["waiting"]


def test_straight_stop_stops_for_predicted_contact_only():
    env = _env()
    snap = env.unwrapped.sensing()
    policy = make_policy("straight-stop", env.unwrapped.robot, seed=0)
    policy.reset(seed=0)
    # Standing on the path 0.3 m ahead: walking on touches it within 3 footsteps.
    policy.act(None, _with(snap, _circle("c", (0.3, 0.0), (0.0, 0.0))))
    assert policy.last_info["waiting"]
    # Walking ahead of the robot faster than it, on its path: no contact at the same instant, it walks.
    policy.act(None, _with(snap, _circle("c", (0.6, 0.0), (0.5, 0.0))))
    assert not policy.last_info["waiting"]


def test_the_orca_robot_is_pyrvos_agent_and_its_period_rule():
    import pyrvo

    env = _env()
    snap = env.unwrapped.sensing()
    policy = make_policy("orca-robot", env.unwrapped.robot, seed=0)
    policy.reset(seed=0)
    p = policy.params
    # The period rule: clip(0.10 m / speed, 0.4 s, 0.8 s).
    assert policy.period_for(0.25) == pytest.approx(0.4) and policy.period_for(0.2) == pytest.approx(0.5)
    assert policy.period_for(0.1) == pytest.approx(0.8) and policy.period_for(0.0) == pytest.approx(0.8)
    # Alone: the preferred velocity, straight at the goal at max_speed.
    vx, vy = policy.orca_velocity(snap, 0.8)
    assert (vx, vy) == pytest.approx((p["max_speed"], 0.0), abs=1e-6)
    # A pedestrian coming head-on: the velocity is RVO2's for the same two agents, built here by hand.
    other = _circle("c", (1.0, 0.02), (-0.2, 0.0), 0.1)
    got = policy.orca_velocity(_with(snap, other), 0.8)
    sim = pyrvo.RVOSimulator(0.8, p["neighbor_dist"], int(p["max_neighbors"]), p["time_horizon"],
                             p["time_horizon_obst"], 0.1, p["max_speed"])
    sim.add_agent(tuple(snap.centre), p["neighbor_dist"], int(p["max_neighbors"]), p["time_horizon"],
                  p["time_horizon_obst"], env.unwrapped.robot.body_radius + p["safety_space"], p["max_speed"],
                  tuple(snap.com_vel))
    sim.add_agent((1.0, 0.02), 0.0, 0, p["time_horizon"], p["time_horizon_obst"], 0.1, 1.0e3, (-0.2, 0.0))
    sim.set_agent_pref_velocity(1, (-0.2, 0.0))
    sim.set_agent_pref_velocity(0, (p["max_speed"], 0.0))
    sim.do_step()
    assert got == sim.get_agent_velocity(0).to_tuple()
    assert abs(got[1]) > 1e-3  # it steps aside


def test_dwa_keeps_clear_of_an_obstacle_on_its_way():
    env = _env()
    snap = _with(env.unwrapped.sensing(), _circle("c", (0.29, 0.0), (0.0, 0.0)))  # 9 cm from the body
    policy = make_policy("dwa", env.unwrapped.robot, seed=0)
    policy.reset(seed=0)
    command = policy.act(None, snap)
    assert policy.last_info["admissible"] > 0 and policy.last_info["gap"] > policy.walk["margin"]
    # Without the obstacle it takes the longest stride towards the goal at the quickest period.
    policy.act(None, env.unwrapped.sensing())
    free = policy.last_info["command"]
    assert free[0] == pytest.approx(env.unwrapped.robot.stride_front[1]) and free[2] == pytest.approx(0.0, abs=0.07)
    assert not np.array_equal(command, free)
    assert math.isfinite(policy.last_info["score"])
