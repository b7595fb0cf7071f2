"""The example submission (baselines/examples/cleanrl_ppo.py) runs end to end as docs/benchmark.md shows it: a
CleanRL-style PPO trains briefly on a scene's train tier, is saved, loaded into a fresh network with its observation
statistics, and submitted through ``footstep_gym.benchmark.evaluate`` on validation seeds (never the test split)."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from footstep_gym.evaluation.splits import split_seeds

torch = pytest.importorskip("torch")

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "baselines" / "examples" / "cleanrl_ppo.py"


def test_the_cleanrl_example_trains_saves_loads_and_submits_on_validation_seeds(tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, str(EXAMPLE), "--env", "door", "--total-timesteps", "128",
                           "--num-envs", "2", "--num-steps", "64", "--update-epochs", "1", "--episodes", "2",
                           "--out", str(tmp_path / "out")], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "iteration 1/1: 128 steps" in done.stdout

    ckpt = torch.load(tmp_path / "out" / "model.pt", weights_only=False)
    assert ckpt["env_id"] == "FootstepDoor-v0" and ckpt["obs_mean"].shape == (42,)
    assert np.all(ckpt["obs_var"] > 0) and not np.allclose(ckpt["obs_mean"], 0.0)  # statistics were gathered

    doc = json.loads((tmp_path / "out" / "bench" / "benchmark.json").read_text(encoding="utf-8"))
    assert doc["policy"] == "cleanrl-ppo" and doc["complete"] is False  # a try: no leaderboard row
    assert doc["protocol"]["split"] == "validation" and doc["protocol"]["seeds"] == split_seeds("validation", 2)
    assert {r["tier"] for r in doc["records"]} == {"paper"} and {r["scene"] for r in doc["records"]} == {"door"}
    assert sum(r["episodes"] for r in doc["records"]) == 2
    assert "**Development run** (validation seeds" in (tmp_path / "out" / "bench" / "benchmark.md").read_text("utf-8")


def test_the_loaded_policy_maps_its_action_into_the_command_box(tmp_path):
    """What the submission sends: the saved network's mean action, from [-1, 1] onto the env's command box."""
    spec = importlib.util.spec_from_file_location("cleanrl_ppo", EXAMPLE)
    cleanrl_ppo = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cleanrl_ppo)
    agent = cleanrl_ppo.Agent(42, 5)
    with torch.no_grad():
        agent.actor_mean[-1].weight.zero_()
        agent.actor_mean[-1].bias.copy_(torch.tensor([-1.0, 1.0, 0.0, 5.0, -5.0]))  # the last two beyond the box
    low, high = np.array([-0.1, 0.0, -0.4, 0.1, 0.1]), np.array([0.1, 0.2, 0.4, 1.0, 0.5])
    cleanrl_ppo.save({"agent": agent.state_dict(), "obs_dim": 42, "act_dim": 5, "env_id": "FootstepDoor-v0",
                      "obs_mean": np.zeros(42), "obs_var": np.ones(42), "action_low": low, "action_high": high},
                     tmp_path / "model.pt")
    act = cleanrl_ppo.load_policy(tmp_path / "model.pt")
    np.testing.assert_allclose(act(np.zeros(42, dtype=np.float32)), [-0.1, 0.2, 0.0, 1.0, 0.1], rtol=0, atol=1e-7)
