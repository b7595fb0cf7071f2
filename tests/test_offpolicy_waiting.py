"""``baselines/offpolicy_waiting.py``: the critic it reads is the agent's own at the command the agent plays, and an
episode's discounted return is the sum it says."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from script_helpers import load_script

from footstep_gym.rl.agents import ZooAgent
from footstep_gym.rl.registry import agent_runs
from footstep_gym.robot import load_robot

pytest.importorskip("sbx")


def test_the_critic_is_read_at_the_command_the_agent_plays():
    script = load_script("offpolicy_waiting")
    (run, *_) = agent_runs("sac", script.ENV_ID)
    agent = ZooAgent(run, load_robot(None))
    obs, _ = gym.make(script.ENV_ID).reset(seed=10000)
    agent.reset(10000)
    command = agent.act(obs)
    x = agent.normalizer.normalize_obs(np.asarray(obs, np.float32).reshape(1, -1))
    action, _ = agent.model.predict(x, deterministic=True)  # the model's own [-1, 1] action
    policy = agent.model.policy
    want = float(np.min(np.asarray(policy.qf.apply(policy.qf_state.params, x, action.reshape(1, -1)))))
    assert script.critic(agent, obs, command) == pytest.approx(want, rel=1e-4, abs=1e-4)
    assert script.critic(agent, obs, load_robot(None).nominal_command) != pytest.approx(want, abs=1e-6)


def test_an_episode_and_its_discounted_return():
    script = load_script("offpolicy_waiting")
    (run, *_) = agent_runs("td3", script.ENV_ID)
    agent = ZooAgent(run, load_robot(None))
    row = script.play(agent, 10000, gamma=0.0)  # gamma 0: the return-to-go is each footstep's own reward
    assert row["ending"] in ("goal", "timeout", "collision", "fall") and row["steps"] >= 1
    assert row["return_to_go"] == pytest.approx(row["reward_per_step"])


def test_episodes_below_one_are_refused(capsys):
    with pytest.raises(SystemExit) as exc:
        load_script("offpolicy_waiting").main(["--episodes", "0"])
    assert exc.value.code == 2 and "--episodes must be >= 1" in capsys.readouterr().err
