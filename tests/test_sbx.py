"""sbx's (JAX) SAC and TD3 through rl_zoo3 (footstep_gym.rl.zoo_sbx): trained, saved, shipped and loaded.

One short run per algorithm through the real command line (``python -m footstep_gym.rl.zoo_sbx``,
what :func:`footstep_gym.rl.training.train` runs): the pipeline, not what the agent learns.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sbx")

from footstep_gym import make_policy  # noqa: E402
from footstep_gym.evaluation.runner import Cell, Task, run_episode  # noqa: E402
from footstep_gym.rl import AGENTS, ZooAgent, agent_runs, training  # noqa: E402
from footstep_gym.rl.agents import ALGORITHMS, algorithm_class, check_run  # noqa: E402
from footstep_gym.robot import load_robot  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SBX = {"sac_sbx": ("SAC", "sac"), "td3_sbx": ("TD3", "td3")}  # algorithm -> (sbx class, registered agent)


@pytest.fixture(scope="module", params=sorted(SBX))
def sbx_run(request, tmp_path_factory):
    """(algorithm, a 300-step zoo run of it on the door, its wall time), trained through training.train."""
    algo = request.param
    root = tmp_path_factory.mktemp(algo)
    run, wall = training.train(algo, "FootstepDoor-v0", 5, root / "logs", timesteps=300, eval_freq=25_000,
                               eval_episodes=2, eval_env_kwargs="training", progress=False)
    return algo, run, wall


def test_the_sbx_algorithms_train_through_the_zoo_wrapper():
    cmd = training.zoo_command("sac_sbx", "FootstepDoor-v0", 1, "runs/x")
    assert cmd[1:3] == ["-m", "footstep_gym.rl.zoo_sbx"] and cmd[cmd.index("--algo") + 1] == "sac_sbx"
    assert cmd[cmd.index("--conf-file") + 1].endswith("sac_sbx.yml")
    assert training.zoo_command("sac", "FootstepDoor-v0", 1, "runs/x")[1:3] == ["-m", "rl_zoo3.train"]
    # The zoo's eval env gets no env_kwargs unless told: "training" gives it the config entry's.
    cmd = training.zoo_command("td3_sbx", "FootstepDoor-v0", 1, "runs/x", eval_env_kwargs="training")
    assert cmd[cmd.index("--eval-env-kwargs") + 1:] == ["randomize:{'door_speed': [5.0, 20.0]}"]


def test_registering_puts_the_sbx_classes_in_the_zoos_tables():
    import sbx
    from rl_zoo3 import hyperparams_opt, utils

    from footstep_gym.rl import zoo_sbx

    zoo_sbx.register()
    zoo_sbx.register()  # idempotent
    for algo, (cls, _) in SBX.items():
        assert utils.ALGOS[algo] is getattr(sbx, cls) and algorithm_class(algo) is getattr(sbx, cls)
        assert hyperparams_opt.HYPERPARAMS_SAMPLER[algo] is hyperparams_opt.HYPERPARAMS_SAMPLER[algo[:3]]
    assert utils.ALGOS["sac"].__module__.startswith("stable_baselines3")  # SB3's SAC keeps its name


def test_an_sbx_run_names_its_algorithm_and_loads_as_a_footstep_policy(sbx_run):
    algo, run, wall = sbx_run
    assert run.parent.name == algo and wall > 0
    args = training.zoo_yaml(run / "FootstepDoor-v0" / "args.yml")
    assert args["algo"] == algo and args["eval_env_kwargs"] == {"randomize": {"door_speed": [5.0, 20.0]}}
    assert check_run(run)[2] == algo  # read back from args.yml
    agent = ZooAgent(run, load_robot())
    assert type(agent.model) is algorithm_class(algo) and type(agent.model).__module__.startswith("sbx")
    command = agent.act(np.zeros(agent.model.observation_space.shape, dtype=np.float32))
    assert command.shape == (5,) and command.dtype == np.float32
    result = run_episode(Task(0, Cell("FootstepDoor-v0", "door", SBX[algo][1], (("door_speed", 8.0),), run=str(run)), 3))
    assert result.outcome in ("goal", "collision", "fall", "timeout") and result.steps >= 1
    # Evaluated once, at its end: the first whole train_freq past 300 steps.
    calls = training.callback_calls(algo, training.zoo_entry(algo, "FootstepDoor-v0"), 300)
    assert np.load(run / "evaluations.npz")["timesteps"].tolist() == [calls]


def test_an_sbx_run_ships_as_its_registered_agent_without_replay_buffer(sbx_run, tmp_path):
    algo, run, wall = sbx_run
    name = SBX[algo][1]
    assert AGENTS[name].algo == algo and AGENTS[name].folder == name
    agents = tmp_path / "agents"
    dest = training.ship(run, agents, wall)  # default folder: the registered agent's, not the algorithm's name
    assert dest == agents / name / "FootstepDoor-v0_5"
    m = json.loads((dest / "manifest.json").read_text())
    assert (m["agent"], m["algorithm"], m["timesteps"]) == (name, algo, 300)
    assert "footstep_gym.rl.zoo_sbx" in m["command"]
    assert not list(dest.rglob("*replay_buffer*"))
    assert agent_runs(name, "FootstepDoor-v0", agents) == [dest]
    policy = make_policy(name, load_robot(), seed=0, run=dest)
    assert isinstance(policy, ZooAgent) and policy.algo == algo


def test_ship_never_replaces_an_agent_of_another_algorithm(sbx_run, tmp_path):
    algo, run, wall = sbx_run
    agents = tmp_path / "agents"
    dest = training.ship(run, agents, wall, agent="other")
    manifest = dest / "manifest.json"
    manifest.write_text(manifest.read_text().replace(f'"algorithm": "{algo}"', '"algorithm": "sac"'))
    with pytest.raises(training.ShipRefused, match=f"holds a sac agent, this run is {algo}"):
        training.ship(run, agents, wall, agent="other", force=True)


def test_the_sb3_sac_ships_to_its_own_folder_and_the_loader_says_how_to_get_sbx(monkeypatch):
    assert training.default_agent_folder("sac") == "sac-sb3" and AGENTS["sac-sb3"].algo == "sac"
    assert training.default_agent_folder("ppo") == "ppo"
    # Two registered TD3 agents: runs go to `td3`; `td3-b2048` takes one only when named.
    assert training.default_agent_folder("td3_sbx") == "td3" and AGENTS["td3-b2048"].algo == "td3_sbx"
    assert set(SBX) <= set(ALGORITHMS)
    monkeypatch.setitem(sys.modules, "sbx", None)  # as if not installed
    with pytest.raises(ImportError, match=r"pip install 'footstep_gym\[sbx\]'"):
        algorithm_class("sac_sbx")


def test_the_wrapper_runs_as_a_module_with_the_zoos_command_line():
    proc = subprocess.run([sys.executable, "-m", "footstep_gym.rl.zoo_sbx", "--help"], cwd=REPO,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and "sac_sbx" in proc.stdout and "td3_sbx" in proc.stdout


def test_train_rl_trains_the_sbx_algorithms_evaluated_on_the_training_scenes(monkeypatch):
    from script_helpers import load_script

    script = load_script("train_rl")
    args = script.build_parser().parse_args(["--algo", "sac_sbx", "td3_sbx", "--env", "door", "--eval-like-training"])
    assert args.algo == ["sac_sbx", "td3_sbx"] and args.eval_like_training
    seen = {}
    monkeypatch.setattr(script, "run_jobs", lambda jobs, options, *rest: seen.update(options=options, jobs=jobs) or [])
    assert script.main(["--algo", "td3_sbx", "--env", "crowd", "--eval-like-training", "--log-folder", "/tmp/x"]) == 0
    assert seen["options"]["eval_env_kwargs"] == "training" and seen["jobs"][0].algo == "td3_sbx"
    cmd = training.zoo_command("td3_sbx", "FootstepCrowd-v0", 1, "x", eval_env_kwargs="training")
    assert cmd[-2:] == ["--eval-env-kwargs", "randomize:{'crowd_speed': [0.12, 0.22]}"]
    with pytest.raises(ValueError, match="a dict or 'training'"):
        training.zoo_command("td3_sbx", "FootstepCrowd-v0", 1, "x", eval_env_kwargs="validation")
