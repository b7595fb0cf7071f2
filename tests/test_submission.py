"""A way in for any method without editing the package: ``--policy module:attr``, plain stable-baselines3 ``.zip``
files with ``--algo``, per-scene ``--agent SCENE=PATH``, and ``footstep_gym.benchmark.evaluate`` for any callable.

Policies of one's own are written here as a user would, in a module of their own beside the run (a temporary
folder as the working directory); a torch policy written without SB3 and a flax policy each get a complete
benchmark row with 2 workers, and the two (the same command computed by two frameworks) agree episode for
episode. Bad input is one error line, exit status 2, nothing written.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from footstep_gym.evaluation import benchmark
from footstep_gym.evaluation.splits import split_seeds
from footstep_gym.evaluation.submission import SubmissionError, parse_agents, runs_by_env

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "baselines" / "eval_planner.py"
#: A blind walker's command [S, L, theta, T_SS, T_DS]: a 4 cm stride at the default robot's nominal period.
COMMAND = (0.04, 0.08, 0.0, 0.6, 0.2)
#: One cheap cell per scene for the command-line checks (the paper tier: one cell per scene).
QUICK = ("--benchmark", "--episodes", "1", "--tier", "paper")

WALKER = f'''
import numpy as np
from footstep_gym.policy import Policy


class Walker(Policy):
    """A blind walker: one command, every footstep."""

    def __init__(self, robot, seed=None):
        super().__init__()
        self.command = np.array({COMMAND!r})

    def reset(self, seed=None):
        self.last_info = {{}}

    def act(self, observation, snapshot):
        return self.command


def make_walker(robot, seed):
    return Walker(robot, seed)


class ThreeFields(Walker):
    def act(self, observation, snapshot):
        return self.command[:3]


class Stumbles(Walker):
    """Fails at its third footstep of an episode."""

    def reset(self, seed=None):
        self.steps = 0

    def act(self, observation, snapshot):
        self.steps += 1
        if self.steps == 3:
            raise RuntimeError("lost my footing")
        return self.command


class NoRobot(Walker):
    def __init__(self):
        super().__init__(None)


class NotAPolicy:
    pass


ANSWER = 42
'''


def run_cli(*args: str, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture
def users_folder(tmp_path):
    """A user's working directory holding their policy module ``my_walker.py``."""
    (tmp_path / "my_walker.py").write_text(WALKER)
    return tmp_path


# ---------------------------------------------------------------- --policy module:attr
@pytest.mark.parametrize("attr", ["Walker", "make_walker"])
def test_a_policy_of_ones_own_by_import_path(users_folder, attr):
    """A Policy subclass built as (robot, seed), or a factory: imported in every worker (2), recorded in run.json."""
    proc = run_cli(*QUICK, "--env", "crossing", "--env", "door", "--policy", f"my_walker:{attr}", "--workers", "2",
                   "--out", "out", cwd=users_folder)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((users_folder / "out" / "benchmark.json").read_text())
    assert doc["policy"] == f"my_walker:{attr}" and not doc["upper_bound"]
    assert [r["cell"] for r in doc["records"]] == ["default", "default"]
    assert all(r["episodes"] == 1 for r in doc["records"])
    run = json.loads((users_folder / "out" / "run.json").read_text())
    source = run["policy_source"]
    assert source["import_path"] == f"my_walker:{attr}"
    assert source["file"] == "<outside>/my_walker.py"  # outside the repository: no machine's folder in a row
    assert source["sha256"] == hashlib.sha256((users_folder / "my_walker.py").read_bytes()).hexdigest()


def test_a_policy_of_ones_own_on_ray(users_folder):
    """Ray's workers import the module the same way (the working directory, as in the driver)."""
    pytest.importorskip("ray")
    proc = run_cli(*QUICK, "--env", "crossing", "--policy", "my_walker:Walker", "--workers", "1", "--backend", "ray",
                   "--out", "ray", cwd=users_folder)
    assert proc.returncode == 0, proc.stderr
    local = run_cli(*QUICK, "--env", "crossing", "--policy", "my_walker:Walker", "--workers", "1", "--out", "local",
                    cwd=users_folder)
    assert local.returncode == 0, local.stderr
    outcomes = [[r["outcomes"] for r in json.loads((users_folder / f / "benchmark.json").read_text())["records"]]
                for f in ("ray", "local")]
    assert outcomes[0] == outcomes[1]


@pytest.mark.parametrize("policy, message", [
    ("nowhere:Walker", "--policy nowhere:Walker: no module named 'nowhere'"),
    ("my_walker:Walkr", "--policy my_walker:Walkr: module my_walker"),
    ("my_walker:NotAPolicy", "my_walker.NotAPolicy is not a footstep_gym.policy.Policy subclass"),
    ("my_walker:ANSWER", "--policy my_walker:ANSWER: a int, not a Policy subclass"),
    ("my_walker:ThreeFields", "policy my_walker:ThreeFields: act returned shape (3,), expected (5,)"),
    ("my_walker:NoRobot", "--policy my_walker:NoRobot: the class failed when called as my_walker:NoRobot(robot, seed)"),
])
def test_a_bad_policy_is_one_line_and_exit_2_before_anything_runs(users_folder, policy, message):
    proc = run_cli(*QUICK, "--policy", policy, "--out", "out", cwd=users_folder, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and message in errors[0], proc.stderr
    assert not (users_folder / "out").exists()


def test_a_policy_failing_midway_is_one_line_naming_it(users_folder):
    proc = run_cli(*QUICK, "--env", "crossing", "--policy", "my_walker:Stumbles", "--workers", "2", "--out", "out",
                   cwd=users_folder)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr
    last = proc.stderr.strip().splitlines()[-1]
    assert re.search(r"policy my_walker:Stumbles failed \((warm-up act|act at footstep) 3\) on env=FootstepCrossing-v0 "
                     rf".* seed={split_seeds('validation', 1)[0]}: RuntimeError: lost my footing$", last), last
    assert not (users_folder / "out").exists()


# ---------------------------------------------------------------- --agent: plain .zip, per scene
def test_agent_arguments_name_their_scene_and_refuse_what_is_wrong(tmp_path):
    zips = {}
    for scene in ("door", "crossing", "crowd"):
        zips[scene] = tmp_path / f"{scene}.zip"
        zips[scene].write_bytes(b"PK")
    zoo_run = tmp_path / "FootstepDoor-v0_1"
    zoo_run.mkdir()
    (zoo_run / "FootstepDoor-v0.zip").write_bytes(b"PK")
    (tmp_path / "x.zip").write_bytes(b"PK")
    agents = parse_agents([f"{s}={p}" for s, p in zips.items()] + [str(zoo_run), f"crowd={tmp_path / 'x.zip'}"],
                          "ppo")
    assert [a.scene for a in agents] == ["door", "crossing", "crowd", "door", "crowd"]  # a zoo run names its env
    assert all(a.algo == "ppo" for a in agents)
    env_ids = ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"]
    runs = runs_by_env(agents, env_ids)
    assert [len(runs[e]) for e in env_ids] == [2, 1, 2]  # never scored on another scene
    for values, message in [
        ([f"door={zips['door']}", f"crossing={zips['crossing']}"], "no agent for the crowd scene"),
        ([f"door={zips['door']}", f"crowd={zips['door']}"], "given twice"),
        ([f"kitchen={zips['door']}"], "unknown scene 'kitchen'"),
        ([str(tmp_path / "missing.zip")], "no such file or folder"),
    ]:
        with pytest.raises(SubmissionError, match=message):
            runs_by_env(parse_agents(values, "ppo"), env_ids)
    with pytest.raises(SubmissionError, match="--algo teleport: one of"):
        parse_agents([str(zips["door"])], "teleport")
    with pytest.raises(SubmissionError, match="one file per --agent"):
        parse_agents([str(zips["door"]), str(zips["crowd"])], "ppo", [str(zips["door"])])


def test_per_scene_agents_from_the_command_line_refuse_a_missing_scene(tmp_path):
    for scene in ("door", "crossing"):
        (tmp_path / f"{scene}.zip").write_bytes(b"PK")
    proc = run_cli("--benchmark", "--agent", "door=door.zip", "--agent", "crossing=crossing.zip", "--algo", "ppo",
                   "--out", "out", cwd=tmp_path, timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "no agent for the crowd scene" in proc.stderr.strip().splitlines()[-1]
    proc = run_cli("--benchmark", "--agent", "door=door.zip", "--agent", "crowd=door.zip", "--algo", "ppo",
                   "--out", "out", cwd=tmp_path, timeout=120)
    assert proc.returncode == 2 and "given twice" in proc.stderr.strip().splitlines()[-1]
    assert not (tmp_path / "out").exists()


def _plain_ppo_zip(folder: Path, scene: str) -> tuple[Path, Path]:
    """A stable-baselines3 PPO saved as a plain .zip (no zoo files) on ``scene``'s env with RescaleAction(-1, 1) and
    a VecNormalize saved apart, as a user's own training script would leave them."""
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    import footstep_gym

    def make():
        env = gym.make(footstep_gym.ENV_IDS[scene])
        box = env.action_space
        return gym.wrappers.RescaleAction(env, np.full(box.shape, -1.0, box.dtype), np.full(box.shape, 1.0, box.dtype))

    venv = VecNormalize(DummyVecEnv([make]), norm_reward=False)
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(64)
    model.save(folder / f"{scene}_model.zip")
    venv.save(folder / f"{scene}_stats.pkl")
    return folder / f"{scene}_model.zip", folder / f"{scene}_stats.pkl"


def test_plain_sb3_zips_one_per_scene_make_a_row(tmp_path):
    pytest.importorskip("stable_baselines3")
    args = []
    norms = []
    for scene in ("door", "crossing", "crowd"):
        model, stats = _plain_ppo_zip(tmp_path, scene)
        args += ["--agent", f"{scene}={model.name}"]
        norms += ["--vecnormalize", stats.name]
    no_algo = run_cli(*QUICK, *args, "--out", "out", cwd=tmp_path, timeout=120)
    assert no_algo.returncode == 2 and "give its algorithm (--algo" in no_algo.stderr, no_algo.stderr
    proc = run_cli(*QUICK, *args, *norms, "--algo", "ppo", "--name", "mine", "--workers", "2", "--out", "out",
                   cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((tmp_path / "out" / "benchmark.json").read_text())
    assert doc["policy"] == "agent:mine"
    for record in doc["records"]:  # each scene scored with its own agent, and only with it
        assert record["run"] == f"{record['scene']}_model.zip", record


# ---------------------------------------------------------------- the library: any callable
def make_torch_policy(scene: str, seed: int):
    """A tiny torch policy written without SB3: a linear layer whose output is the walker's command."""
    import torch

    net = torch.nn.Linear(42, 5)
    with torch.no_grad():
        net.weight.zero_()
        net.bias.copy_(torch.tensor(COMMAND))

    def act(observation):
        with torch.no_grad():
            return net(torch.as_tensor(observation, dtype=torch.float32))

    return act


def make_flax_policy(scene: str, seed: int):
    """A tiny flax (JAX) policy: a Dense layer with the walker's command as its bias, jitted."""
    import flax.linen as nn
    import jax
    import jax.numpy as jnp

    model = nn.Dense(5)
    params = model.init(jax.random.PRNGKey(seed), jnp.zeros(42))
    params = jax.tree_util.tree_map(jnp.zeros_like, params)
    params["params"]["bias"] = jnp.asarray(COMMAND, dtype=jnp.float32)
    apply = jax.jit(model.apply)
    return lambda observation: apply(params, jnp.asarray(observation, dtype=jnp.float32))


def test_a_torch_and_a_flax_policy_each_get_a_complete_row_with_2_workers(tmp_path):
    pytest.importorskip("torch")
    pytest.importorskip("flax")
    from footstep_gym.benchmark import evaluate

    docs = {}
    for name, fn in (("tiny-torch", make_torch_policy), ("tiny-flax", make_flax_policy)):
        docs[name] = evaluate(fn, name=name, out=tmp_path / name, episodes=1, workers=2)
        doc = docs[name]
        assert doc["complete"] and doc["policy"] == name and not doc["upper_bound"]
        assert [f"{r['scene']}/{r['tier']}/{r['cell']}" for r in doc["records"]] == [
            c.label for c in benchmark.benchmark_cells()]
        assert {a["tier"] for a in doc["aggregates"]} == set(doc["protocol"]["tiers"])
        assert "| " + name + " |" in (tmp_path / name / "benchmark.md").read_text()
        run = json.loads((tmp_path / name / "run.json").read_text())
        assert run["workers"] == 2 and run["policy_source"]["callable"] == name
    # the same command from two frameworks (both float32): the same episodes
    torch_eps, flax_eps = ([(r["outcomes"], r["mean_time"]) for r in docs[n]["records"]] for n in docs)
    assert torch_eps == flax_eps


def test_evaluate_checks_the_callable_before_anything_runs(tmp_path):
    from footstep_gym.benchmark import evaluate

    with pytest.raises(ValueError, match=r"act returned shape \(3,\), expected \(5,\)"):
        evaluate(lambda scene, seed: (lambda obs: np.zeros(3)), name="short", out=tmp_path / "x", episodes=1,
                 scenes=["crossing"], tiers=["paper"], workers=1)
    with pytest.raises(ValueError, match="ZeroDivisionError"):
        evaluate(lambda scene, seed: 1 / 0, name="broken", out=tmp_path / "x", episodes=1, scenes=["crossing"],
                 tiers=["paper"], workers=1)
    with pytest.raises(ValueError, match="name 'ppo' is a registered policy's"):
        evaluate(make_torch_policy, name="ppo", out=tmp_path / "x")
    with pytest.raises(ValueError, match="unknown benchmark tier"):
        evaluate(make_torch_policy, name="x", out=tmp_path / "x", tiers=["impossible"])
    assert not (tmp_path / "x").exists()


def test_evaluate_passes_the_snapshot_when_asked(tmp_path):
    from footstep_gym.benchmark import evaluate

    def make(scene, seed):
        def act(observation, snapshot):
            assert snapshot.obstacles is not None and observation.shape == (42,)
            return np.array(COMMAND)
        return act

    doc = evaluate(make, name="sees", out=tmp_path / "sees", snapshot=True, episodes=1, scenes=["crossing"],
                   tiers=["paper"], workers=1)
    assert not doc["complete"] and doc["records"][0]["episodes"] == 1


@pytest.mark.parametrize("fn, options, message", [
    (None, {"workers": 0}, "evaluate: workers must be a whole number >= 1 (worker processes), got 0"),
    (None, {"workers": 1.5}, "evaluate: workers must be a whole number >= 1 (worker processes), got 1.5"),
    (None, {"episodes": 0}, "evaluate: episodes must be a whole number >= 1 (seeds per cell), got 0"),
    (None, {"episodes": -2}, "evaluate: episodes must be a whole number >= 1 (seeds per cell), got -2"),
    (lambda obs: np.zeros(5), {}, "evaluate: make_policy_fn must take (scene, seed) and return a policy"),
    (np.zeros(5), {}, "evaluate: make_policy_fn must be a function (scene, seed) -> policy, got a ndarray"),
])
def test_evaluate_names_a_bad_argument_in_one_line_before_anything_is_written(tmp_path, fn, options, message):
    """workers=0 (which the command line refuses too), episodes=0, and an observation -> action function given in
    place of make_policy_fn(scene, seed): each a one-line ValueError naming the argument, nothing written."""
    from footstep_gym.benchmark import evaluate

    fn = fn if fn is not None else (lambda scene, seed: (lambda obs: np.zeros(5)))
    with pytest.raises(ValueError) as exc:
        evaluate(fn, name="mine", out=tmp_path / "x", **{"episodes": 1, "scenes": ["crossing"], "tiers": ["paper"],
                                                         **options})
    assert str(exc.value).startswith(message) and "\n" not in str(exc.value), exc.value
    assert "got n=" not in str(exc.value) and "offset" not in str(exc.value)  # not split_seeds's words
    assert list(tmp_path.iterdir()) == []
