"""The RL leg: training through rl_zoo3's CLI, shipping, loading agents, evaluating them beside the planners.

Training itself stays out of the suite: one run of a few thousand steps checks the
pipeline (the real ``baselines/train_rl.py`` -> ``rl_zoo3.train`` in a subprocess), not
what the agent learns.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from footstep_gym.evaluation import policies as registry
from footstep_gym.evaluation.agents import ZooAgent
from footstep_gym.evaluation.runner import Cell, Task, run_episode
from footstep_gym.robot import load_robot

REPO = Path(__file__).resolve().parents[1]
SHIPPED = REPO / "baselines" / "agents"
#: The agents the project ships: (policy name, env id) -> at least this many training runs.
EXPECTED = {("ppo", "FootstepDoor-v0"): 3, ("ppo", "FootstepCrossing-v0"): 3, ("ppo", "FootstepCrowd-v0"): 3,
            ("ppo-all", "FootstepDoor-v0"): 1, ("sac", "FootstepDoor-v0"): 1}


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A PPO trained for one rollout through the real CLI, shipped into a temporary agents folder."""
    root = tmp_path_factory.mktemp("rl")
    cmd = [sys.executable, str(REPO / "baselines" / "train_rl.py"), "--algo", "ppo", "--env", "door", "--seeds", "7",
           "--timesteps", "600", "--eval-freq", "1024", "--eval-episodes", "2", "--log-folder", str(root / "logs"),
           "--agents-dir", str(root / "agents"), "--curves-dir", str(root / "curves"),
           "--reference", str(root / "none.json")]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return root


def test_training_cli_ships_a_zoo_run_with_a_manifest(trained):
    run = trained / "agents" / "ppo" / "FootstepDoor-v0_7"
    for rel in ("FootstepDoor-v0.zip", "FootstepDoor-v0/config.yml", "FootstepDoor-v0/args.yml",
                "FootstepDoor-v0/command.txt", "FootstepDoor-v0/vecnormalize.pkl", "manifest.json",
                "evaluations.npz"):
        assert (run / rel).is_file(), rel
    m = json.loads((run / "manifest.json").read_text())
    assert (m["algorithm"], m["env_id"], m["seed"], m["timesteps"], m["n_envs"]) == ("ppo", "FootstepDoor-v0", 7,
                                                                                     600, 4)
    assert m["env_kwargs"]["randomize"]["door_speed"] == [5.0, 20.0]  # trained on a range of door speeds
    assert m["wall_time_s"] > 0 and m["env_steps_per_s"] == pytest.approx(600 / m["wall_time_s"], rel=0.01)
    assert m["torch_threads"] == 1 and "rl_zoo3.train" in m["command"]
    assert 0.0 <= m["final_eval_success"] <= 1.0
    assert (trained / "curves" / "ppo_FootstepDoor-v0.png").stat().st_size > 10_000
    # No replay buffers, checkpoints or monitor logs ship.
    assert not list(run.rglob("*replay_buffer*")) and not list(run.glob("*.monitor.csv"))


def test_a_trained_agent_loads_and_plays_an_episode(trained):
    run = trained / "agents" / "ppo" / "FootstepDoor-v0_7"
    result = run_episode(Task(0, Cell("FootstepDoor-v0", "door", "ppo", (("door_speed", 8.0),), run=str(run)), 3))
    assert result.outcome in ("goal", "collision", "fall", "timeout") and result.steps >= 1
    assert len(result.plan_ms) == result.steps


def test_agent_actions_at_the_box_corners_are_the_robot_limits(trained):
    """The agent's [-1, 1] maps onto the env's box (to float32 rounding), as RescaleAction did in training."""
    robot = load_robot()
    agent = ZooAgent(trained / "agents" / "ppo" / "FootstepDoor-v0_7", robot)
    for corner in (-1.0, 1.0):
        command = agent._to_command(np.full(5, corner, dtype=np.float32))
        assert command.dtype == np.float32
        limit = robot.command_high if corner > 0 else robot.command_low
        np.testing.assert_allclose(command, limit, rtol=0, atol=2e-7)
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    high_period = np.array(robot.nominal_command, dtype=np.float32)
    high_period[3] = agent._to_command(np.ones(5, dtype=np.float32))[3]  # T_SS at +1: float32(0.6)
    _, _, _, _, info = env.step(high_period)
    # float32(0.6) or the float32 just above it (RescaleAction's rounding): the robot's 0.6 s exactly, no fall.
    assert info["feasible"] and info["command"][3] == robot.command_high[3]


def test_evaluation_of_an_agent_uses_the_planners_seeds(trained, tmp_path):
    run = trained / "agents" / "ppo" / "FootstepDoor-v0_7"
    out = tmp_path / "eval"
    proc = subprocess.run([sys.executable, str(REPO / "baselines" / "eval_planner.py"), "--env", "door",
                           "--door-speed", "8", "--policy", "fixed-period", "--agent", str(run), "--episodes", "2",
                           "--no-figures", "--workers", "1", "--out", str(out)],
                          cwd=REPO, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    records = json.loads((out / "results.json").read_text())
    assert [r["policy"] for r in records] == ["fixed-period", "agent:FootstepDoor-v0_7"]
    assert records[0]["seeds"] == records[1]["seeds"] == [20000, 20001]  # the test split's first seeds
    assert records[1]["plan_ms_median"] > 0  # the agent's inference time per footstep


def test_unknown_agent_policies_are_refused():
    with pytest.raises(ValueError, match="pass run="):
        registry.make_policy("ppo", load_robot(), seed=0)
    with pytest.raises(FileNotFoundError, match="not a zoo run folder"):
        ZooAgent(REPO / "no_such_agent", load_robot())
    with pytest.raises(ValueError, match="unknown policy 'teleport'"):
        registry.make_policy("teleport")


def test_every_shipped_agent_is_registered_and_plays_one_episode():
    found = {}
    for (name, env_id), n in EXPECTED.items():
        runs = registry.agent_runs(name, env_id, SHIPPED)
        assert len(runs) >= n, f"{name} on {env_id}: {len(runs)} shipped runs, expected >= {n}"
        found[(name, env_id)] = runs
    for (name, env_id), runs in found.items():
        for run in runs:
            m = json.loads((run / "manifest.json").read_text())
            assert m["algorithm"] == registry.AGENTS[name].algo
            assert m["env_id"] == (registry.AGENTS[name].trained_on or env_id)
            scenario = next(k for k, v in __import__("footstep_gym").ENV_IDS.items() if v == env_id)
            result = run_episode(Task(0, Cell(env_id, scenario, name, run=str(run)), 12345))
            assert result.steps >= 1 and result.outcome in ("goal", "collision", "fall", "timeout")


def test_a_training_grid_runs_as_ray_tasks_and_ships_every_run(tmp_path):
    pytest.importorskip("ray")
    cmd = [sys.executable, str(REPO / "baselines" / "train_rl.py"), "--algo", "ppo", "--env", "crossing", "crowd",
           "--seeds", "3", "--timesteps", "300", "--eval-freq", "100000", "--eval-episodes", "1",
           "--backend", "ray", "--workers", "2", "--log-folder", str(tmp_path / "logs"),
           "--agents-dir", str(tmp_path / "agents"), "--curves-dir", str(tmp_path / "curves"),
           "--reference", str(tmp_path / "none.json")]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for env_id in ("FootstepCrossing-v0", "FootstepCrowd-v0"):
        m = json.loads((tmp_path / "agents" / "ppo" / f"{env_id}_3" / "manifest.json").read_text())
        assert (m["env_id"], m["seed"], m["timesteps"]) == (env_id, 3, 300)


def test_ppo_throughput_is_measured_inside_learn():
    from footstep_gym.training import ppo_throughput

    rate = ppo_throughput("FootstepCrossing-v0", 1, timesteps=512)
    assert 10 < rate < 100_000
