"""The RL leg: training through rl_zoo3's CLI, shipping, loading agents, evaluating them beside the planners.

Training itself stays out of the suite: one run of a few thousand steps checks the
pipeline (the real ``baselines/train_rl.py`` -> ``rl_zoo3.train`` in a subprocess), not
what the agent learns.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym
from footstep_gym import make_policy
from footstep_gym.evaluation.runner import Cell, Task, run_episode
from footstep_gym.policy import Policy
from footstep_gym.rl import AGENTS, ZooAgent, agent_runs
from footstep_gym.robot import load_robot
from script_helpers import load_script

REPO = Path(__file__).resolve().parents[1]
SHIPPED = REPO / "baselines" / "agents"
#: The agents the project ships: (policy name, env id) -> at least this many training runs.
EXPECTED = {("ppo", "FootstepDoor-v0"): 3, ("ppo", "FootstepCrossing-v0"): 3, ("ppo", "FootstepCrowd-v0"): 3,
            ("ppo-all", "FootstepDoor-v0"): 1, ("sac-sb3", "FootstepDoor-v0"): 1, ("sac", "FootstepDoor-v0"): 3,
            ("sac", "FootstepCrossing-v0"): 3, ("sac", "FootstepCrowd-v0"): 3, ("td3", "FootstepDoor-v0"): 3,
            ("td3", "FootstepCrossing-v0"): 3, ("td3", "FootstepCrowd-v0"): 3, ("td3-b2048", "FootstepDoor-v0"): 1,
            ("ppo-fixed-period", "FootstepDoor-v0"): 3, ("ppo-fixed-period", "FootstepCrossing-v0"): 3,
            ("ppo-fixed-period", "FootstepCrowd-v0"): 3, ("ppo-wide", "FootstepDoor-v0"): 3,
            ("ppo-wide", "FootstepCrossing-v0"): 3, ("ppo-wide", "FootstepCrowd-v0"): 3,
            ("ppo-noisy", "FootstepDoor-v0"): 3, ("ppo-noisy", "FootstepCrossing-v0"): 3,
            ("ppo-noisy", "FootstepCrowd-v0"): 3, ("ppo-lstm", "FootstepDoor-v0"): 3,
            ("ppo-lstm", "FootstepCrossing-v0"): 3, ("ppo-lstm", "FootstepCrowd-v0"): 3}


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """A PPO trained for one rollout through the real CLI, shipped into a temporary agents folder."""
    root = tmp_path_factory.mktemp("rl")
    # --timesteps below the default --eval-freq (25000): the run must still be evaluated, at its end.
    cmd = [sys.executable, str(REPO / "baselines" / "train_rl.py"), "--algo", "ppo", "--env", "door", "--seeds", "7",
           "--timesteps", "600", "--eval-episodes", "2", "--log-folder", str(root / "logs"), "--ship",
           "--agents-dir", str(root / "agents"), "--curves-dir", str(root / "curves"),
           "--reference", str(root / "none.json")]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    (root / "stderr.txt").write_text(proc.stderr)
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
    # Both figures are rounded to 0.1 (the rate from the unrounded wall time): the rate lies within what the
    # rounded wall time allows, whatever the machine's speed.
    wall, rate = m["wall_time_s"], m["env_steps_per_s"]
    assert wall > 0 and 600 / (wall + 0.05) - 0.05 <= rate <= 600 / max(wall - 0.05, 1e-9) + 0.05
    assert m["torch_threads"] == 1 and "rl_zoo3.train" in m["command"]
    assert 0.0 <= m["final_eval_success"] <= 1.0
    # One rollout of 4 envs x 512 steps: the one evaluation is at its end (the zoo divides eval_freq by n_envs).
    assert np.load(run / "evaluations.npz")["timesteps"].tolist() == [2048]
    assert (trained / "curves" / "ppo_FootstepDoor-v0.png").stat().st_size > 10_000
    # The console says where the log is and reports the evaluation while training.
    log = trained / "logs" / "seed7" / "ppo_FootstepDoor-v0_7.log"
    console = (trained / "stderr.txt").read_text()
    assert f"log {log}" in console and "Eval num_timesteps=2048" in log.read_text()
    assert "evaluation at 2,048 steps" in console
    # No replay buffers, checkpoints or monitor logs ship.
    assert not list(run.rglob("*replay_buffer*")) and not list(run.glob("*.monitor.csv"))


def test_a_trained_agent_loads_and_plays_an_episode(trained):
    run = trained / "agents" / "ppo" / "FootstepDoor-v0_7"
    result = run_episode(Task(0, Cell("FootstepDoor-v0", "door", "ppo", (("door_speed", 8.0),), run=str(run)), 3))
    assert result.outcome in ("goal", "collision", "fall", "timeout") and result.steps >= 1
    assert len(result.plan_ms) == result.steps


def test_a_run_is_loaded_once_per_process_and_anew_when_its_files_change(trained, tmp_path):
    """Agents of one run share its loaded model (an evaluation makes one per episode); a re-saved run is read again,
    and an agent of the shared model acts as one loaded on its own."""
    import shutil

    from footstep_gym.rl import agents

    run = tmp_path / "ppo" / "FootstepDoor-v0_7"
    shutil.copytree(trained / "agents" / "ppo" / "FootstepDoor-v0_7", run)
    robot = load_robot()
    first, second = ZooAgent(run, robot), ZooAgent(run, robot)
    assert second.model is first.model and second.normalizer is first.normalizer
    obs, _ = gym.make("FootstepDoor-v0").reset(seed=3)
    agents._load_run.cache_clear()
    alone = ZooAgent(run, robot)
    assert alone.model is not first.model
    assert first.act(obs).tolist() == alone.act(obs).tolist()
    model = run / "FootstepDoor-v0.zip"
    stat = model.stat()
    os.utime(model, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))  # as a re-save leaves it
    assert ZooAgent(run, robot).model is not alone.model


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
    from footstep_gym.evaluation.splits import split_seeds

    assert records[0]["seeds"] == records[1]["seeds"] == split_seeds("validation", 2)  # the default split's first
    assert records[1]["plan_ms_median"] > 0  # the agent's inference time per footstep


def test_unknown_agent_policies_are_refused():
    with pytest.raises(ValueError, match="pass run="):
        make_policy("ppo", load_robot(), seed=0)
    with pytest.raises(FileNotFoundError, match="not a zoo run folder"):
        ZooAgent(REPO / "no_such_agent", load_robot())
    with pytest.raises(ValueError, match="unknown policy 'teleport'"):
        make_policy("teleport")


def shipped_runs() -> list[tuple[str, Path]]:
    """Every shipped run (a manifest under baselines/agents) with the registered agent it belongs to."""
    out = []
    for manifest in sorted(SHIPPED.glob("*/*/manifest.json")):
        m = json.loads(manifest.read_text())
        run = manifest.parent
        names = [name for name, e in AGENTS.items() if e.folder == run.parent.name and e.algo == m["algorithm"]
                 and (e.trained_on is None or e.trained_on == m["env_id"])
                 and (e.trained_on is not None or m["env_id"] in footstep_gym.ENV_IDS.values())]
        assert len(names) == 1, f"{run}: registered as {names or 'no agent'}"
        out.append((names[0], run))
    return out


def scenes_of(env_id: str) -> list[str]:
    """The scene env ids an agent trained on ``env_id`` plays: the mix's three, or the env itself."""
    return sorted(footstep_gym.ENV_IDS.values()) if env_id == footstep_gym.MIX_ENV_ID else [env_id]


def test_every_shipped_agent_is_registered_with_its_manifest():
    found = {(name, env_id): len(agent_runs(name, env_id, SHIPPED)) for name, env_id in EXPECTED}
    assert all(found[k] >= n for k, n in EXPECTED.items()), found
    for name, run in shipped_runs():
        m = json.loads((run / "manifest.json").read_text())
        entry = AGENTS[name]
        assert m["algorithm"] == entry.algo and run.parent.name == entry.folder
        assert run in agent_runs(name, scenes_of(m["env_id"])[0], SHIPPED)
        assert m["wall_time_s"] > 0 and m["timesteps"] > 0 and m["final_eval_success"] is not None
        # The env options it trained with: the fixed-period agent's action was [S, L, theta].
        assert m["env_kwargs"].get("fixed_period", False) is (name == "ppo-fixed-period"), run


@pytest.mark.parametrize("name, run", shipped_runs(), ids=lambda v: v if isinstance(v, str) else
                         f"{v.parent.name}/{v.name}")
def test_every_shipped_agent_loads_and_plays_each_scene_it_was_trained_for(name, run):
    m = json.loads((run / "manifest.json").read_text())
    robot = load_robot()
    agent = make_policy(name, robot, seed=0, run=run)
    assert isinstance(agent, Policy) and isinstance(agent, ZooAgent) and agent.name == name
    assert agent.fixed_period is (name == "ppo-fixed-period")
    nominal = tuple(robot.nominal_command[3:].tolist())
    for env_id in scenes_of(m["env_id"]):
        scenario = next(k for k, v in footstep_gym.ENV_IDS.items() if v == env_id)
        result = run_episode(Task(0, Cell(env_id, scenario, name, run=str(run)), 12345))
        assert result.steps >= 1 and result.outcome in ("goal", "collision", "fall", "timeout")
        if agent.fixed_period:  # the ordinary five-field env, the period always nominal
            env = gym.make(env_id)
            obs, _ = env.reset(seed=12345)
            while True:
                obs, _, terminated, truncated, info = env.step(agent.act(obs, None))
                assert info["command"][3:] == nominal
                if terminated or truncated:
                    break
            assert info["steps"] == result.steps


# ppo-jax and its recurrent twin train in JAX, not by resuming a zoo model (their loading: tests/test_ppo_jax.py,
# tests/test_ppo_jax_rnn.py).
@pytest.mark.parametrize("name, run", [(n, r) for n, r in shipped_runs()
                                       if AGENTS[n].algo not in ("ppo_jax", "ppo_jax_rnn")],
                         ids=lambda v: v if isinstance(v, str) else f"{v.parent.name}/{v.name}")
def test_every_shipped_model_loads_with_the_env_it_trains_on(name, run):
    """Resuming training: ``<Algo>.load(zip, env=...)`` checks the spaces against the env's (finite observation
    bounds since the env got them; the models were re-saved with them), directly and through the zoo's
    ``VecNormalize`` (which keeps its own copy of the space)."""
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from footstep_gym.rl.agents import algorithm_class, training_env

    m = json.loads((run / "manifest.json").read_text())
    cls = algorithm_class(m["algorithm"])  # SB3's, or sbx's for sac_sbx / td3_sbx
    zip_path = run / f"{m['env_id']}.zip"
    env = training_env(run)
    if m["env_id"] != footstep_gym.MIX_ENV_ID:
        assert env.unwrapped.spec.id == m["env_id"]
    assert env.action_space.shape == ((3,) if m["env_kwargs"].get("fixed_period") else (5,))
    model = cls.load(zip_path, env=env, device="cpu")
    assert model.observation_space == gym.make(m["env_id"]).observation_space
    venv = VecNormalize.load(str(run / m["env_id"] / "vecnormalize.pkl"), DummyVecEnv([lambda: training_env(run)]))
    cls.load(zip_path, env=venv, device="cpu")


def test_the_fixed_period_agent_in_the_full_env_replays_the_fixed_period_env_exactly():
    """The design choice: a fixed-period agent is evaluated in the ordinary env like every other policy; its
    command there (float64, nominal period appended, rounded limits pinned) is the command the fixed-period env
    applies to the agent's float32 action, bit for bit: same commands, observations, rewards and ends."""
    robot = load_robot()
    for env_id in footstep_gym.ENV_IDS.values():
        run = agent_runs("ppo-fixed-period", env_id, SHIPPED)[0]
        agent = ZooAgent(run, robot)
        full, fixed = gym.make(env_id), gym.make(env_id, fixed_period=True)
        for seed in (0, 1):
            o1, _ = full.reset(seed=seed)
            o2, _ = fixed.reset(seed=seed)
            while True:
                command = agent.act(o1)
                assert command.dtype == np.float64 and command.shape == (5,)
                x = np.asarray(o2, dtype=np.float32).reshape(1, -1)
                action, _ = agent.model.predict(agent.normalizer.normalize_obs(x), deterministic=True)
                r1 = full.step(command)
                r2 = fixed.step(agent._to_command(np.asarray(action, dtype=np.float32).reshape(-1)))
                assert r1[4]["command"] == r2[4]["command"] and r1[4]["clipped"] == r2[4]["clipped"]
                assert r1[4]["command"][3:] == (robot.nominal_t_ss, robot.nominal_t_ds)
                np.testing.assert_array_equal(r1[0], r2[0])
                assert r1[1:4] == r2[1:4]
                o1, o2 = r1[0], r2[0]
                if r1[2] or r1[3]:
                    break


def test_the_fixed_period_agent_pins_float32_limits_as_the_env_does(monkeypatch):
    """At the corners of its [-1, 1] box the agent's S, L, theta are the robot's limits (float64; exactly where the
    rescaled float32 value is the float32-rounded limit, else the float32 value RescaleAction's rounding gave), as
    the fixed-period env reads the float32 values SB3 sends; T_SS, T_DS are the nominal ones."""
    robot = load_robot()
    agent = ZooAgent(agent_runs("ppo-fixed-period", "FootstepDoor-v0", SHIPPED)[0], robot)
    fixed = gym.make("FootstepDoor-v0", fixed_period=True)
    pinned = 0
    for corner in (-1.0, 1.0):
        # monkeypatch restores it: the model is the process's loaded run, shared with every agent of the run
        monkeypatch.setattr(agent.model, "predict", lambda x, c=corner, **kw: (np.full((1, 3), c, np.float32), None))
        command = agent.act(np.zeros(42, np.float32))
        limit = robot.command_high if corner > 0 else robot.command_low
        rescaled = agent._to_command(np.full(3, corner, np.float32))
        for i in range(3):
            if rescaled[i] == np.float32(limit[i]):
                assert command[i] == limit[i]  # exactly the robot's limit, not its float32 rounding
                pinned += 1
            else:
                assert command[i] == float(rescaled[i]) and abs(command[i] - limit[i]) < 2e-7
        assert command[3:].tolist() == [robot.nominal_t_ss, robot.nominal_t_ds]
        fixed.reset(seed=0)
        _, _, _, _, info = fixed.step(rescaled)
        assert list(info["command"]) == command.tolist()
    assert pinned >= 3  # most corners land on the rounded limit


def test_a_training_grid_runs_as_ray_tasks_and_ships_every_run(tmp_path):
    pytest.importorskip("ray")
    cmd = [sys.executable, str(REPO / "baselines" / "train_rl.py"), "--algo", "ppo", "--env", "crossing", "crowd",
           "--seeds", "3", "--timesteps", "300", "--eval-freq", "100000", "--eval-episodes", "1", "--ship",
           "--backend", "ray", "--workers", "2", "--log-folder", str(tmp_path / "logs"),
           "--agents-dir", str(tmp_path / "agents"), "--curves-dir", str(tmp_path / "curves"),
           "--reference", str(tmp_path / "none.json")]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for env_id in ("FootstepCrossing-v0", "FootstepCrowd-v0"):
        m = json.loads((tmp_path / "agents" / "ppo" / f"{env_id}_3" / "manifest.json").read_text())
        assert (m["env_id"], m["seed"], m["timesteps"]) == (env_id, 3, 300)


def test_ppo_throughput_is_measured_inside_learn():
    from footstep_gym.rl.training import ppo_throughput

    rate = ppo_throughput("FootstepCrossing-v0", 1, timesteps=512)
    assert 10 < rate < 100_000


# ---------------------------------------------------------------- nothing a user made is lost
TRAIN_SCRIPT = REPO / "baselines" / "train_rl.py"


def fake_run(root: Path, timesteps: int, success: float | None, seed: int = 1,
             env_id: str = "FootstepDoor-v0") -> Path:
    """A finished zoo run's folder (what shipping reads; the model is not loaded) with a final evaluation."""
    k = 1 + len(list((root / "ppo").glob(f"{env_id}_*")))  # the zoo numbers a log folder's runs
    run = root / "ppo" / f"{env_id}_{k}"
    (run / env_id).mkdir(parents=True)
    (run / f"{env_id}.zip").write_bytes(f"model of {timesteps} steps".encode())
    (run / env_id / "args.yml").write_text(f"algo: ppo\nseed: {seed}\nn_timesteps: {timesteps}\nnum_threads: 1\n"
                                           "eval_episodes: 4\n")
    (run / env_id / "config.yml").write_text(f"n_envs: 4\nn_timesteps: {timesteps}\n")
    (run / env_id / "command.txt").write_text("python -m rl_zoo3.train ...\n")
    if success is not None:
        np.savez(run / "evaluations.npz", timesteps=np.array([timesteps]), results=np.zeros((1, 4)),
                 ep_lengths=np.ones((1, 4)), successes=np.array([[1.0] * round(4 * success) +
                                                                 [0.0] * (4 - round(4 * success))]))
    return run


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_ship_does_not_replace_a_longer_or_better_agent_without_force(tmp_path):
    from footstep_gym.rl import training

    agents = tmp_path / "agents"
    dest = training.ship(fake_run(tmp_path / "long", 600_000, 1.0), agents, 100.0)
    before = snapshot(agents)
    with pytest.raises(training.ShipRefused, match=r"holds a longer run \(600,000 env steps\) than this one \(8,192\)"):
        training.ship(fake_run(tmp_path / "short", 8192, 1.0), agents, 10.0)
    with pytest.raises(training.ShipRefused, match=r"better run \(final evaluation success 1.00, this one 0.50\)"):
        training.ship(fake_run(tmp_path / "worse", 600_000, 0.5), agents, 100.0)
    with pytest.raises(training.ShipRefused, match="this one none recorded"):
        training.ship(fake_run(tmp_path / "unevaluated", 600_000, None), agents, 100.0)
    assert snapshot(agents) == before  # nothing written
    assert training.ship(fake_run(tmp_path / "as_good", 600_000, 1.0), agents, 90.0) == dest  # no worse: replaced
    assert json.loads((dest / "manifest.json").read_text())["wall_time_s"] == 90.0
    training.ship(fake_run(tmp_path / "short", 8192, 0.25), agents, 10.0, force=True)
    m = json.loads((dest / "manifest.json").read_text())
    assert (m["timesteps"], m["final_eval_success"]) == (8192, 0.25)
    assert (dest / "FootstepDoor-v0.zip").read_bytes() == b"model of 8192 steps"
    assert sorted(p.name for p in (agents / "ppo").iterdir()) == ["FootstepDoor-v0_1"]  # no staging folder left
    (agents / "ppo" / "FootstepDoor-v0_2").mkdir()
    with pytest.raises(training.ShipRefused, match="not a shipped agent"):
        training.ship(fake_run(tmp_path / "other", 8192, 1.0, seed=2), agents, 10.0)


def test_an_agent_ships_into_its_registered_folder_with_its_env_options(tmp_path, capsys):
    """ppo-fixed-period is a PPO (the zoo's algorithm) with a folder of its own; the manifest keeps fixed_period."""
    from footstep_gym.rl import training

    agents = tmp_path / "agents"
    run = fake_run(tmp_path / "runs", 8192, 1.0, seed=2)
    (run / "FootstepDoor-v0" / "config.yml").write_text(
        "n_envs: 4\nn_timesteps: 8192\nenv_kwargs:\n  fixed_period: true\n  randomize: {door_speed: [5.0, 20.0]}\n")
    main = load_script("train_rl").main
    assert main(["--ship", str(run), "--wall-time", "12", "--agent", "ppo-fixed-period", "--agents-dir", str(agents),
                 "--curves-dir", str(tmp_path / "curves"), "--reference", str(tmp_path / "none.json")]) == 0
    dest = agents / "ppo-fixed-period" / "FootstepDoor-v0_2"
    m = json.loads((dest / "manifest.json").read_text())
    assert (m["agent"], m["algorithm"], m["seed"], m["wall_time_s"]) == ("ppo-fixed-period", "ppo", 2, 12.0)
    assert m["env_kwargs"] == {"fixed_period": True, "randomize": {"door_speed": [5.0, 20.0]}}
    assert agent_runs("ppo-fixed-period", "FootstepDoor-v0", agents) == [dest]
    assert agent_runs("ppo", "FootstepDoor-v0", agents) == []  # not mixed with the PPO of the full action
    assert (tmp_path / "curves" / "ppo-fixed-period_FootstepDoor-v0.png").is_file()
    with pytest.raises(SystemExit):
        main(["--agent", "ppo-fixed-period", "--algo", "ppo", "--env", "door"])  # an agent's config or an algorithm's
    assert "not both" in capsys.readouterr().err
    with pytest.raises(ValueError, match="one plain folder name"):
        training.ship(run, agents, 1.0, agent="../elsewhere")


def test_the_agents_folder_is_an_argument_a_variable_the_working_directory_or_the_checkout(tmp_path, monkeypatch):
    """Run elsewhere, the checkout the package is imported from gives its agents; a non-editable install (no
    checkout) has none unless pointed at some, and says so in one line, as for a missing folder or an unknown env."""
    from footstep_gym.rl import registry
    from footstep_gym.rl.registry import AGENTS_DIR_ENV_VAR, default_agents_dir, missing_agents_note

    monkeypatch.delenv(AGENTS_DIR_ENV_VAR, raising=False)
    monkeypatch.chdir(REPO)
    assert default_agents_dir() == SHIPPED and len(agent_runs("ppo", "FootstepDoor-v0")) == 3
    monkeypatch.chdir(tmp_path)  # elsewhere: the checkout's agents, not an empty list
    assert default_agents_dir() == SHIPPED and len(agent_runs("ppo", "FootstepDoor-v0")) == 3
    assert agent_runs("ppo", "door") == agent_runs("ppo", "FootstepDoor-v0")  # a scene's name, as eval_planner's
    installed = tmp_path / "site-packages" / "footstep_gym" / "rl" / "registry.py"  # an install: no checkout above
    monkeypatch.setattr(registry, "__file__", str(installed))
    assert default_agents_dir() == tmp_path / "baselines" / "agents"
    with pytest.raises(FileNotFoundError) as err:
        agent_runs("ppo", "FootstepDoor-v0")
    message = str(err.value)
    assert len(message.splitlines()) == 1 and f"agents folder {tmp_path / 'baselines' / 'agents'} does not exist" in \
        message and AGENTS_DIR_ENV_VAR in message
    note = missing_agents_note({"ppo": ["FootstepDoor-v0"]})
    assert len(note.splitlines()) == 1 and AGENTS_DIR_ENV_VAR in note and "ppo on FootstepDoor-v0" in note
    assert len(agent_runs("ppo", "FootstepDoor-v0", SHIPPED)) == 3  # the argument
    with pytest.raises(FileNotFoundError, match=r"agents folder .*nowhere does not exist \(agents_dir\)"):
        agent_runs("ppo", "FootstepDoor-v0", tmp_path / "nowhere")
    monkeypatch.setenv(AGENTS_DIR_ENV_VAR, str(SHIPPED))  # the variable
    assert default_agents_dir() == SHIPPED and len(agent_runs("ppo", "FootstepDoor-v0")) == 3
    assert agent_runs("ppo", "FootstepDoor-v0", tmp_path) == []  # the argument wins; a folder without ppo's runs
    monkeypatch.setenv(AGENTS_DIR_ENV_VAR, str(tmp_path / "gone"))
    with pytest.raises(FileNotFoundError, match=rf"gone does not exist \(\${AGENTS_DIR_ENV_VAR}\)"):
        agent_runs("ppo", "FootstepDoor-v0")
    with pytest.raises(ValueError, match="unknown agent 'teleport'; registered: ppo, "):
        agent_runs("teleport", "FootstepDoor-v0")
    with pytest.raises(ValueError, match="unknown env 'FootstepLift-v0'; choose from door, "):
        agent_runs("ppo", "FootstepLift-v0", SHIPPED)


def test_ship_cli_refuses_with_one_line_and_exit_status_2(tmp_path):
    from footstep_gym.rl import training

    agents = tmp_path / "agents"
    training.ship(fake_run(tmp_path / "long", 600_000, 1.0), agents, 100.0)
    before = snapshot(agents)
    proc = subprocess.run([sys.executable, str(TRAIN_SCRIPT), "--ship", str(fake_run(tmp_path / "short", 8192, 1.0)),
                           "--wall-time", "10", "--agents-dir", str(agents), "--curves-dir", str(tmp_path / "curves"),
                           "--reference", str(tmp_path / "none.json")], cwd=REPO, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.splitlines() == [f"train_rl.py: error: {agents / 'ppo' / 'FootstepDoor-v0_1'} holds a longer "
                                        "run (600,000 env steps) than this one (8,192); not replaced (--force "
                                        "replaces it)"]
    assert snapshot(agents) == before and not (tmp_path / "curves").exists()


@pytest.fixture
def fake_training(tmp_path, monkeypatch):
    """train_rl.py's main with rl_zoo3 replaced by a fake run of the asked length (success 0.5)."""
    from footstep_gym.rl import training

    calls = []

    def train(algo, env_id, seed, log_folder, timesteps=None, **kwargs):
        calls.append((algo, env_id, seed, timesteps))
        options.append({"log_folder": Path(log_folder), **kwargs})
        return fake_run(Path(log_folder), timesteps or 8192, 0.5, seed=seed, env_id=env_id), 12.0

    options: list[dict] = []
    train.options = options

    monkeypatch.setattr(training, "train", train)
    args = ["--log-folder", str(tmp_path / "runs"), "--agents-dir", str(tmp_path / "agents"),
            "--curves-dir", str(tmp_path / "curves"), "--reference", str(tmp_path / "none.json")]
    main = load_script("train_rl").main
    main.options = options  # what each fake training was given beside (algo, env, seed, timesteps)
    return main, args, calls


def test_training_writes_under_runs_and_ships_nothing_by_default(tmp_path, fake_training, capsys):
    """A user's first short try used to replace the shipped agent and redraw the README's learning curve."""
    main, common, calls = fake_training
    assert main(["--algo", "ppo", "--env", "door", "--seeds", "1", "--timesteps", "8192", *common]) == 0
    assert calls == [("ppo", "FootstepDoor-v0", 1, 8192)]
    assert not (tmp_path / "agents").exists() and not (tmp_path / "curves").exists()
    assert (tmp_path / "runs" / "learning_curves" / "ppo_FootstepDoor-v0.png").is_file()  # the run's own curve
    err = capsys.readouterr().err
    assert "nothing is shipped" in err and "--ship " in err


def test_training_with_ship_refuses_a_shorter_run_before_training(tmp_path, fake_training, capsys):
    from footstep_gym.rl import training

    main, common, calls = fake_training
    training.ship(fake_run(tmp_path / "long", 600_000, 1.0), tmp_path / "agents", 100.0)
    before = snapshot(tmp_path / "agents")
    code = main(["--algo", "ppo", "--env", "door", "--seeds", "1", "--timesteps", "8192", "--ship", *common])
    assert code == 2 and calls == []  # refused before any training
    assert capsys.readouterr().err.splitlines()[-1].endswith("not replaced (--force replaces it)")
    assert snapshot(tmp_path / "agents") == before and not (tmp_path / "curves").exists()
    # The same length but a worse final evaluation (0.5 < 1.0): trained, then not shipped, exit 2.
    code = main(["--algo", "ppo", "--env", "door", "--seeds", "1", "--timesteps", "600000", "--ship", *common])
    assert code == 2 and len(calls) == 1
    assert "holds a better run" in capsys.readouterr().err
    assert snapshot(tmp_path / "agents") == before and not (tmp_path / "curves").exists()
    # --force replaces it and redraws the curve.
    code = main(["--algo", "ppo", "--env", "door", "--seeds", "1", "--timesteps", "8192", "--ship", "--force",
                 *common])
    assert code == 0
    assert json.loads((tmp_path / "agents" / "ppo" / "FootstepDoor-v0_1" / "manifest.json").read_text())[
        "timesteps"] == 8192
    assert (tmp_path / "curves" / "ppo_FootstepDoor-v0.png").is_file()


@pytest.mark.parametrize("name, envs, conf, eval_freq, like_training", [
    ("ppo-wide", ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"], "ppo-wide.yml", -1, False),
    ("ppo-all", ["FootstepMix-v0"], "ppo.yml", 25_000, False),
    ("sac", ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"], "sac_sbx.yml", 10_000, True),
    ("ppo-lstm", ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"], "ppo-lstm.yml", -1, False),
])
def test_a_shipped_agent_is_trained_by_its_name_as_it_was_shipped(tmp_path, fake_training, name, envs, conf,
                                                                   eval_freq, like_training):
    """Its config, its envs and evaluation as its manifest's command has them; into runs/<agent>/, nothing shipped."""
    from footstep_gym.rl import AGENTS

    main, common, calls = fake_training
    assert main(["--agent", name, "--seeds", "1", "2", *common]) == 0
    assert calls == [(AGENTS[name].algo, env, seed, None) for env in envs for seed in (1, 2)]
    for options in main.options:
        assert options["conf_file"].name == conf and options["eval_freq"] == eval_freq
        assert options.get("eval_env_kwargs") == ("training" if like_training else None)
        assert options["log_folder"].parent == tmp_path / "runs" / name
    manifests = sorted(SHIPPED.glob(f"{AGENTS[name].folder}/*/manifest.json"))
    shipped = [json.loads(m.read_text())["command"] for m in manifests]
    assert any(f"--conf-file {conf}" in c or f"/{conf}" in c for c in shipped), shipped
    assert not (tmp_path / "agents").exists()


def test_a_shipped_agent_trained_by_name_ships_to_its_own_folder(tmp_path, fake_training):
    main, common, calls = fake_training
    assert main(["--agent", "ppo-fixed-period", "--env", "door", "--seeds", "3", "--ship", *common]) == 0
    assert calls == [("ppo", "FootstepDoor-v0", 3, None)]
    assert (tmp_path / "agents" / "ppo-fixed-period" / "FootstepDoor-v0_3" / "manifest.json").is_file()
    assert not (tmp_path / "agents" / "ppo").exists()  # never into another agent's folder


@pytest.mark.parametrize("args, message", [
    (["--agent", "ppo", "--seeds", "-1"], "a training seed is a whole number >= 0, got -1"),
    (["--algo", "ppo", "--env", "door", "--seeds", "1", "1"], "a seed given twice"),
    (["--agent", "td3-b2048"], "td3-b2048 cannot be trained by name: its hyperparameters are the tuner's"),
    (["--agent", "teleport"], "--agent teleport: unknown agent"),
    (["--agent", "ppo-all", "--env", "door"], "ppo-all is trained on FootstepMix-v0, not FootstepDoor-v0"),
    (["--agent", "sac-sb3", "--env", "crowd"], "sac-sb3: configs/rl/sac.yml has no entry for FootstepCrowd-v0"),
    (["--agent", "ppo", "--algo", "ppo", "--env", "door"], "not both"),
])
def test_bad_training_options_are_one_line_before_anything_runs(tmp_path, fake_training, capsys, args, message):
    main, common, calls = fake_training
    with pytest.raises(SystemExit) as exit_:
        main([*args, *common])
    assert exit_.value.code == 2 and calls == []
    err = capsys.readouterr().err
    assert message in err.strip().splitlines()[-1], err
    assert not (tmp_path / "runs").exists()


def test_a_run_shorter_than_eval_freq_is_evaluated_at_its_end():
    """The zoo evaluates every eval_freq // n_envs callback calls; a shorter run used to evaluate never."""
    from footstep_gym.rl.training import run_eval_freq

    # PPO on the door: 4 envs x 512 steps a rollout; whole rollouts.
    assert run_eval_freq("ppo", "FootstepDoor-v0", 25_000, 600) == 2048
    assert run_eval_freq("ppo", "FootstepDoor-v0", 25_000, 8192) == 8192
    assert run_eval_freq("ppo", "FootstepDoor-v0", 25_000, 20_000) == 20_480
    assert run_eval_freq("ppo", "FootstepDoor-v0", 25_000) == 25_000  # 600k steps: unchanged
    assert run_eval_freq("ppo", "FootstepDoor-v0", 1000, 8192) == 1000
    # SAC: one env, train_freq 8 steps.
    assert run_eval_freq("sac", "FootstepDoor-v0", 25_000, 600) == 600
    assert run_eval_freq("sac", "FootstepDoor-v0", 25_000, 601) == 608


# ---------------------------------------------------------------- what a user sees
def test_loading_an_agent_raises_no_box_precision_warning(trained):
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ZooAgent(trained / "agents" / "ppo" / "FootstepDoor-v0_7", load_robot())
    assert not [w for w in caught if "precision lowered" in str(w.message)], [str(w.message) for w in caught]
