"""The policies of :mod:`footstep_gym.planners.reference` end to end, and their registry."""

from __future__ import annotations

import gymnasium as gym
import pytest

import footstep_gym  # noqa: F401  (registers the envs)

# ====================================================================== the policies end to end
def run_policy(name: str, env_id: str, seed: int, **env_kwargs) -> dict:
    """One episode of policy ``name`` on ``env_id``; the final step's info."""
    from footstep_gym.planners import make_policy

    env = gym.make(env_id, **env_kwargs)
    policy = make_policy(name, env.unwrapped.robot, seed=seed)
    obs, info = env.reset(seed=seed)
    policy.reset(seed=seed)
    while True:
        obs, _, terminated, truncated, info = env.step(policy.act(obs, env.unwrapped.sensing()))
        if terminated or truncated:
            env.close()
            return info


@pytest.mark.parametrize("env_id, kwargs", [
    ("FootstepDoor-v0", {"door_speed": 17.0}),
    ("FootstepCrossing-v0", {}),
    ("FootstepCrowd-v0", {}),
])
def test_period_aware_planner_reaches_the_goal_in_each_env(env_id, kwargs):
    info = run_policy("period-aware", env_id, 0, **kwargs)
    assert info["termination"] == "goal" and info["is_success"], info["termination"]


@pytest.mark.parametrize("door_speed, outcome", [(5.0, "goal"), (14.0, "collision")])
def test_fixed_period_planner_passes_a_slow_door_and_not_a_fast_one(door_speed, outcome):
    """The paper's Fig. 8 in one seed: at T_n the robot cannot cross the disc at 14 deg/s."""
    info = run_policy("fixed-period", "FootstepDoor-v0", 0, door_speed=door_speed)
    assert info["termination"] == outcome
    assert info["period"] == pytest.approx(0.8)
