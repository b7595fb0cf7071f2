"""The learning curve on the validation split (footstep_gym.rl.callbacks) and the agents' report (rl.report).

One short zoo run (a few hundred steps) with the callback in its hyperparameter file; its last
figure is checked against the evaluation runner playing the saved agent on the same seeds.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

from footstep_gym.evaluation.runner import Cell, Task, run_episode
from footstep_gym.evaluation.splits import split_seeds
from footstep_gym.rl import ZooAgent, callbacks, report, training
from footstep_gym.robot import load_robot

REPO = Path(__file__).resolve().parents[1]
KWARGS = {"tier": "train"}  # the crossing's train tier: one cell, car and arrival speeds drawn per episode


@pytest.fixture(scope="module")
def zoo_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("cb")
    conf = {"FootstepCrossing-v0": {
        "env_wrapper": [{"gymnasium.wrappers.RescaleAction": {"min_action": -1.0, "max_action": 1.0}}],
        "normalize": "{'norm_obs': True, 'norm_reward': False}", "n_envs": 2, "policy": "MlpPolicy",
        "n_steps": 64, "batch_size": 64, "n_timesteps": 600, "env_kwargs": KWARGS,
        "callback": [{"footstep_gym.rl.callbacks.ValidationCallback": {"eval_freq": 256, "episodes": 3}}]}}
    (root / "conf.yml").write_text(yaml.safe_dump(conf))
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "FootstepCrossing-v0", "--gym-packages",
           "footstep_gym", "--conf-file", str(root / "conf.yml"), "--num-threads", "1", "--seed", "3",
           "-f", str(root / "logs"), "--eval-freq", "-1"]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return root / "logs" / "ppo" / "FootstepCrossing-v0_1"


def test_the_callback_writes_the_validation_curve_at_its_frequency_and_at_the_end(zoo_run):
    curve = training.validation_curve(zoo_run)
    # 2 envs x 64 steps a rollout: 640 steps in all; evaluations at 256 and 512, and at the end.
    assert curve["timesteps"] == [256, 512, 640]
    assert np.all(np.diff(curve["wall_time_s"]) >= 0) and curve["wall_time_s"][0] >= 0
    assert curve["episodes"] == 3
    assert all(s in (0.0, 1 / 3, 2 / 3, 1.0) or abs(s * 3 - round(s * 3)) < 1e-3 for s in curve["success"])


def test_the_callbacks_episodes_are_the_evaluation_runners(zoo_run):
    """Independent of the callback's loop: the runner plays the saved model (ZooAgent) on the same env and seeds,
    footstep for footstep; and the curve's last figure is the saved model's success there."""
    seeds = split_seeds("validation", 3)
    runner = []
    for seed in seeds:
        result = run_episode(Task(0, Cell("FootstepCrossing-v0", "crossing", "ppo", tuple(KWARGS.items()),
                                          run=str(zoo_run)), seed))
        runner.append((result.outcome == "goal", result.steps))
    agent = ZooAgent(zoo_run, load_robot())
    env = gym.wrappers.RescaleAction(gym.make("FootstepCrossing-v0", **KWARGS), -np.ones(5, np.float32),
                                     np.ones(5, np.float32))
    assert callbacks.play(agent.model, env, seeds, agent.normalizer) == runner
    assert min(steps for _, steps in runner) >= 1
    assert training.validation_curve(zoo_run)["success"][-1] == pytest.approx(
        sum(win for win, _ in runner) / 3, abs=1e-4)


def test_the_report_reads_validation_curves_and_manifests(zoo_run, tmp_path):
    agents = tmp_path / "agents"
    training.ship(zoo_run, agents, wall_time_s=12.0, agent="ppo")
    shipped = agents / "ppo" / "FootstepCrossing-v0_3"
    manifest = json.loads((shipped / "manifest.json").read_text())
    assert manifest["final_eval_on"] == "validation split" and manifest["final_eval_episodes"] == 3
    assert manifest["final_eval_success"] == training.validation_curve(zoo_run)["success"][-1]
    curve, source = report.run_curve(shipped, manifest)
    assert source == "validation" and curve["timesteps"].tolist() == [256, 512, 640]
    rows = report.cost_rows(agents)
    assert [(r["agent"], r["env_id"], r["seeds"], r["timesteps"]) for r in rows] == \
        [("ppo", "FootstepCrossing-v0", 1, 600)]  # the planned budget (the zoo ends the last rollout at 640)
    assert rows[0]["env_steps_per_s"] == pytest.approx(600 / 12.0, abs=0.1)
    assert "| ppo | ppo | FootstepCrossing-v0 | 1 | 600 |" in report.cost_table(agents)
    (pngs,) = [report.scene_curves(agents, tmp_path / "curves")]
    assert [p.name for p in pngs] == ["scene_FootstepCrossing-v0.png"] and pngs[0].stat().st_size > 1000


def test_a_run_without_a_monitor_file_warns_and_measures_nothing(tmp_path, monkeypatch):
    """rl_zoo3's -optimize trials get the config's callbacks but no run folder: the callback must not fail the trial
    (optuna would count it as pruned) and writes nothing."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    monkeypatch.chdir(tmp_path)
    venv = make_vec_env("FootstepCrossing-v0", n_envs=1, env_kwargs=KWARGS)  # a Monitor that writes no file
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=64, seed=0, device="cpu")
    callback = callbacks.ValidationCallback(eval_freq=32, episodes=2)
    with pytest.warns(UserWarning, match="no validation curve"):
        model.learn(128, callback=callback)
    assert callback.path is None and model.num_timesteps == 128 and list(tmp_path.iterdir()) == []
