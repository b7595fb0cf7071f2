"""A recurrent agent (sb3-contrib's RecurrentPPO, rl_zoo3's ``ppo_lstm``) as a footstep policy: its LSTM state
is carried from footstep to footstep and starts afresh with each episode."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

from footstep_gym.config import config_dir
from footstep_gym.evaluation.runner import Cell, Task, run_episode
from footstep_gym.rl import ZooAgent, callbacks
from footstep_gym.robot import load_robot

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def lstm_run(tmp_path_factory):
    """configs/rl/ppo-lstm.yml's door entry, trained for one short rollout."""
    root = tmp_path_factory.mktemp("lstm")
    with open(config_dir() / "rl" / "ppo-lstm.yml", encoding="utf-8") as fh:
        entry = yaml.load(fh, Loader=yaml.UnsafeLoader)["FootstepDoor-v0"]
    entry.update(n_timesteps=256, n_steps=64, batch_size=64, n_envs=2)
    entry.pop("callback")
    (root / "conf.yml").write_text(yaml.safe_dump({"FootstepDoor-v0": entry}))
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo_lstm", "--env", "FootstepDoor-v0",
           "--gym-packages", "footstep_gym", "--conf-file", str(root / "conf.yml"), "--num-threads", "1",
           "--seed", "2", "-f", str(root / "logs"), "--eval-freq", "-1"]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return root / "logs" / "ppo_lstm" / "FootstepDoor-v0_1", entry["env_kwargs"]


def test_the_lstm_state_is_carried_within_an_episode_and_reset_between(lstm_run):
    run, kwargs = lstm_run
    agent = ZooAgent(run, load_robot())
    assert agent.algo == "ppo_lstm" and type(agent.model).__name__ == "RecurrentPPO"
    env = gym.make("FootstepDoor-v0", **kwargs)
    obs, _ = env.reset(seed=10000)
    agent.reset(seed=10000)
    first = agent.act(obs).copy()
    again = agent.act(obs).copy()  # same observation, the state moved on
    agent.reset(seed=10000)
    assert np.array_equal(agent.act(obs), first)
    assert not np.array_equal(again, first)


def test_a_recurrent_agent_plays_in_the_runner_as_in_its_own_loop(lstm_run):
    """The evaluation runner (ZooAgent, reset per episode) and the training callback's loop over the raw model
    play the same episodes footstep for footstep."""
    run, kwargs = lstm_run
    seeds = [10000, 10001]
    runner = []
    for seed in seeds:
        cell = Cell("FootstepDoor-v0", "door", "ppo-lstm", (("tier", "noise"), ("tier_cell", "train")), run=str(run))
        result = run_episode(Task(0, cell, seed))
        runner.append((result.outcome == "goal", result.steps))
    agent = ZooAgent(run, load_robot())
    env = gym.wrappers.RescaleAction(gym.make("FootstepDoor-v0", tier="noise", tier_cell="train"),
                                     -np.ones(5, np.float32), np.ones(5, np.float32))
    assert callbacks.play(agent.model, env, seeds, agent.normalizer) == runner
