"""How an episode ends (footstep_gym/env.py): the goal, truncation, the rewards summed over an episode,
and a step after the end, which raises ``ResetNeeded`` naming how the episode ended.

References are the YAML files read directly and the geometry of the feet the env reports.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym
from env_helpers import FREE, NOMINAL, read_yaml, strides


# ------------------------------------------------------------------ episode end
def walk_to_goal(env, max_steps=60):
    infos = []
    for action in strides(0.02, 0.04, 0.06, 0.08) + strides(*([0.10] * max_steps)):
        _, reward, terminated, truncated, info = env.step(action)
        infos.append(info)
        if terminated or truncated:
            return infos, reward, terminated, truncated
    return infos, reward, terminated, truncated


def test_walking_straight_reaches_the_goal():
    cfg = read_yaml("scenarios/crossing.yaml")
    env = gym.make("FootstepCrossing-v0", **FREE)
    _, info0 = env.reset(seed=0)
    infos, reward, terminated, truncated = walk_to_goal(env)
    info = infos[-1]
    assert terminated and not truncated
    assert info["termination"] == "goal" and info["is_success"] is True
    assert info["rewards"]["goal"] > 0
    # The robot centre (midpoint of the last two feet) is within the tolerance of the goal...
    centre = np.mean([infos[-1]["foot_pose"][:2], infos[-2]["foot_pose"][:2]], axis=0)
    assert np.hypot(*(centre - cfg["goal"])) <= cfg["goal_tolerance"]
    # ... and was not one step earlier.
    before = np.mean([infos[-2]["foot_pose"][:2], infos[-3]["foot_pose"][:2]], axis=0)
    assert np.hypot(*(before - cfg["goal"])) > cfg["goal_tolerance"]
    # About 1.9 m at up to 10 cm per step (the paper: 20 steps).
    assert 18 <= len(infos) <= 24
    assert not any(i["is_success"] for i in infos[:-1])


def test_goal_close_to_the_start():
    cfg = read_yaml("scenarios/door.yaml")
    goal = [cfg["start"][0] + 0.12, cfg["start"][1]]
    env = gym.make("FootstepDoor-v0", goal=goal, start_jitter=0.0)
    env.reset(seed=0)
    infos, _, terminated, _ = walk_to_goal(env)
    assert terminated and infos[-1]["termination"] == "goal" and infos[-1]["is_success"]
    assert len(infos) <= 5


def test_truncation_at_max_steps():
    env = gym.make("FootstepCrossing-v0", max_steps=3, **FREE)
    env.reset(seed=0)
    flags = [env.step(NOMINAL)[2:4] for _ in range(3)]
    assert flags == [(False, False), (False, False), (False, True)]


def test_truncation_at_time_limit():
    env = gym.make("FootstepCrossing-v0", time_limit=2.0, **FREE)
    env.reset(seed=0)
    flags = [env.step(NOMINAL)[2:4] for _ in range(3)]  # 0.8, 1.6, 2.4 s
    assert flags == [(False, False), (False, False), (False, True)]


def test_rewards_progress_term_measures_distance_gained():
    env_cfg = read_yaml("env.yaml")
    cfg = read_yaml("scenarios/crossing.yaml")
    env = gym.make("FootstepCrossing-v0", start_jitter=0.0, **FREE)
    env.reset(seed=0)
    infos, _, _, _ = walk_to_goal(env)
    total = sum(i["rewards"]["progress"] for i in infos)
    centre = np.mean([infos[-1]["foot_pose"][:2], infos[-2]["foot_pose"][:2]], axis=0)
    gained = math.dist(cfg["start"], cfg["goal"]) - math.dist(centre, cfg["goal"])
    assert total == pytest.approx(env_cfg["reward_progress"] * gained, abs=1e-9)
    assert sum(i["rewards"]["step"] for i in infos) == pytest.approx(env_cfg["reward_step"] * len(infos))
    assert sum(i["rewards"]["time"] for i in infos) == pytest.approx(env_cfg["reward_time"] * infos[-1]["time"])


# ------------------------------------------------------------------ stepping after the end
def end_episode(env, how):
    """Step ``env`` (reset at seed 0) until its episode ends the way ``how`` names; the last step's flags."""
    if how == "fall":  # -0.3 rad turns the left foot towards the right one: beyond turn_inner (0.2)
        actions = [np.array([0.0, 0.10, -0.3, 0.6, 0.2])]
    elif how == "collision":  # stepping in place while the car's side passes 8 cm from the CoM
        actions = [NOMINAL] * 10
    elif how == "goal":
        actions = strides(0.02, 0.04, 0.06, 0.08) + strides(*([0.10] * 30))
    else:
        actions = [NOMINAL] * 10
    env.reset(seed=0)
    for n, action in enumerate(actions, start=1):
        _, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            return n, terminated, truncated, info
    raise AssertionError(f"the episode did not end by {how}")


END_SETTINGS = {
    "fall": ({}, "fall"),
    "collision": (dict(crossing_x=0.2, timing_jitter=0.0), "collision"),
    "goal": ({}, "goal"),
    "max_steps": (dict(max_steps=3), "truncated: max_steps=3 reached"),
    "time_limit": (dict(time_limit=2.0), "truncated: time_limit=2.0 s reached"),
}


@pytest.mark.parametrize("how", list(END_SETTINGS))
def test_step_after_the_episode_ended_raises_reset_needed(how):
    kwargs, words = END_SETTINGS[how]
    env = gym.make("FootstepCrossing-v0", **{**FREE, **kwargs})
    n, terminated, truncated, info = end_episode(env, how)
    assert (terminated, truncated) == ((False, True) if how in ("max_steps", "time_limit") else (True, False))
    if terminated:
        assert info["termination"] == how
    state = (env.unwrapped.time, env.unwrapped.steps, env.unwrapped.com)
    for action in (NOMINAL, np.array([0.0, 0.10, -0.3, 0.6, 0.2])):
        with pytest.raises(gym.error.ResetNeeded) as exc:
            env.step(action)
        message = str(exc.value)
        assert f"episode ended ({words}) at step {n}" in message and "reset()" in message
        assert message.startswith("FootstepCrossing-v0:")
    assert (env.unwrapped.time, env.unwrapped.steps, env.unwrapped.com) == state  # nothing moved on
    env.reset(seed=1)  # a reset starts a new episode that steps as usual
    _, _, _, _, info = env.step(NOMINAL)
    assert info["steps"] == 1 and info["time"] > 0.0


def test_step_after_the_end_raises_on_the_unwrapped_env_and_its_sensing_still_works():
    env = gym.make("FootstepDoor-v0").unwrapped
    n, *_ = end_episode(env, "fall")
    with pytest.raises(gym.error.ResetNeeded, match=r"FootstepDoor-v0: episode ended \(fall\) at step 1"):
        env.step(NOMINAL)
    assert env.sensing().time == 0.0  # what a planner reads after the end is still there
    direct = footstep_gym.env.FootstepEnv(scenario="crowd")
    with pytest.raises(gym.error.ResetNeeded, match=r"FootstepEnv\(scenario='crowd'\): call reset\(\) before step"):
        direct.step(NOMINAL)
