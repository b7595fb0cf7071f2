"""Training agents through rl_zoo3 and shipping them in the zoo's layout with a manifest.

The training itself is rl_zoo3's (``python -m rl_zoo3.train``, hyperparameters in
``configs/rl/<algo>.yml``, one entry per env id). This module adds what the zoo does not:
several training seeds in a row with one torch thread each, the wall time and throughput
of each run, a copy of the run's small files under ``baselines/agents/<algo>/<EnvId>_<seed>/``
(model ``.zip``, ``<EnvId>/{config.yml,args.yml,command.txt,vecnormalize.pkl}``,
``evaluations.npz``) with a ``manifest.json``, and learning curves.

Nothing here imports torch: training runs in a subprocess.
"""

from __future__ import annotations

import json
import platform
import shutil
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import yaml

from footstep_gym.config import config_dir

#: The zoo's files of a run that ship with an agent (small: no replay buffer, no checkpoints).
SHIPPED_IN_ENV_FOLDER = ("config.yml", "args.yml", "command.txt", "vecnormalize.pkl")


def zoo_command(algo: str, env_id: str, seed: int, log_folder: str | Path, *, conf_file: str | Path | None = None,
                timesteps: int | None = None, eval_freq: int = 25_000, eval_episodes: int = 20,
                threads: int = 1, python: str = sys.executable) -> list[str]:
    """The rl_zoo3 command line that trains ``algo`` on ``env_id`` with ``seed`` into ``log_folder``.

    ``conf_file`` defaults to ``configs/rl/<algo>.yml``; ``eval_freq`` (env steps, all envs
    together) and ``eval_episodes`` set the zoo's EvalCallback, whose success rate (from
    ``info["is_success"]``) makes the learning curve; ``timesteps`` overrides the file's.
    """
    conf = Path(conf_file) if conf_file is not None else config_dir() / "rl" / f"{algo}.yml"
    cmd = [python, "-m", "rl_zoo3.train", "--algo", algo, "--env", env_id, "--gym-packages", "footstep_gym",
           "--conf-file", str(conf), "--num-threads", str(threads), "--seed", str(seed), "-f", str(log_folder),
           "--eval-freq", str(eval_freq), "--eval-episodes", str(eval_episodes), "--log-interval", "10"]
    if timesteps is not None:
        cmd += ["-n", str(timesteps)]
    return cmd


def latest_run(log_folder: str | Path, algo: str, env_id: str) -> Path:
    """The zoo's newest run folder ``<log_folder>/<algo>/<env_id>_<k>`` (largest k)."""
    runs = [p for p in (Path(log_folder) / algo).glob(f"{env_id}_*") if p.name.rsplit("_", 1)[-1].isdigit()]
    if not runs:
        raise FileNotFoundError(f"no run of {algo} on {env_id} under {log_folder}")
    return max(runs, key=lambda p: int(p.name.rsplit("_", 1)[-1]))


def train(algo: str, env_id: str, seed: int, log_folder: str | Path, log_file: str | Path | None = None,
          **kwargs: Any) -> tuple[Path, float]:
    """Train one agent with rl_zoo3 in a subprocess; ``(run folder, wall time [s])``.

    The zoo's output goes to ``log_file`` (default: ``<log_folder>/<algo>_<env_id>_<seed>.log``).
    """
    log_folder = Path(log_folder)
    log_folder.mkdir(parents=True, exist_ok=True)
    log_file = Path(log_file) if log_file else log_folder / f"{algo}_{env_id}_{seed}.log"
    cmd = zoo_command(algo, env_id, seed, log_folder, **kwargs)
    t0 = time.perf_counter()
    with open(log_file, "w", encoding="utf-8") as fh:
        proc = subprocess.run(cmd, stdout=fh, stderr=subprocess.STDOUT)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"rl_zoo3 training of {algo} on {env_id} (seed {seed}) failed with exit code "
                           f"{proc.returncode}; see {log_file}")
    return latest_run(log_folder, algo, env_id), wall


def zoo_yaml(path: Path) -> dict[str, Any]:
    """A YAML file rl_zoo3 wrote (``config.yml`` is a list of [key, value] pairs, ``args.yml`` a mapping) as a dict."""
    data = yaml.load(path.read_text(encoding="utf-8"), Loader=yaml.UnsafeLoader)  # the zoo writes python tags
    return dict(data) if isinstance(data, list) else dict(data or {})


def _plain(value: Any) -> Any:
    """A YAML/JSON-safe copy (the zoo stores dicts as OrderedDicts and some values as strings)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def eval_curve(run: Path) -> dict[str, list[float]]:
    """The EvalCallback's curve of a run: timesteps, success rate and mean return per evaluation."""
    path = run / "evaluations.npz"
    if not path.is_file():
        return {"timesteps": [], "success": [], "return": []}
    data = np.load(path)
    succ = data["successes"] if "successes" in data.files and data["successes"].size else None
    return {
        "timesteps": [int(t) for t in data["timesteps"]],
        "success": [float(v) for v in succ.mean(axis=1)] if succ is not None else [],
        "return": [float(v) for v in data["results"].mean(axis=1)],
    }


def ship(run: str | Path, agents_dir: str | Path, wall_time_s: float, seed: int | None = None) -> Path:
    """Copy a finished zoo run's small files to ``<agents_dir>/<algo>/<EnvId>_<seed>/`` and write its manifest.

    The manifest records the algorithm, env id and kwargs, timesteps, seed, ``n_envs``,
    the wall time and the training throughput (env steps per second of wall time, start-up
    and periodic evaluations included), the final evaluation's success rate and the versions.
    """
    run = Path(run)
    env_id = run.name.rsplit("_", 1)[0]
    model = run / f"{env_id}.zip"
    folder = run / env_id
    if not model.is_file() or not folder.is_dir():
        raise FileNotFoundError(f"{run} is not a finished zoo run (no {model.name} and {env_id}/)")
    args = zoo_yaml(folder / "args.yml")
    config = zoo_yaml(folder / "config.yml")
    algo = args["algo"]
    seed = int(args["seed"] if seed is None else seed)
    dest = Path(agents_dir) / algo / f"{env_id}_{seed}"
    if dest.exists():
        shutil.rmtree(dest)
    (dest / env_id).mkdir(parents=True)
    shutil.copy2(model, dest / model.name)
    for name in SHIPPED_IN_ENV_FOLDER:
        if (folder / name).is_file():
            shutil.copy2(folder / name, dest / env_id / name)
    if (run / "evaluations.npz").is_file():
        shutil.copy2(run / "evaluations.npz", dest / "evaluations.npz")
    timesteps = int(args.get("n_timesteps") or -1)
    if timesteps <= 0:
        timesteps = int(float(config["n_timesteps"]))
    curve = eval_curve(run)

    def version(dist: str) -> str | None:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return None

    manifest = {
        "algorithm": algo,
        "env_id": env_id,
        "env_kwargs": _plain(config.get("env_kwargs", {})),
        "n_envs": int(config.get("n_envs", 1)),
        "timesteps": timesteps,
        "seed": seed,
        "wall_time_s": round(wall_time_s, 1),
        "env_steps_per_s": round(timesteps / wall_time_s, 1),
        "torch_threads": int(args.get("num_threads", -1)),
        "final_eval_success": curve["success"][-1] if curve["success"] else None,
        "final_eval_episodes": int(args.get("eval_episodes", 0)),
        "command": (folder / "command.txt").read_text(encoding="utf-8").strip()
        if (folder / "command.txt").is_file() else None,
        "versions": {d: version(d) for d in ("footstep_gym", "stable_baselines3", "rl_zoo3", "torch", "gymnasium")},
        "python": platform.python_version(),
        "machine": platform.machine(),
    }
    (dest / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return dest


def learning_curves(runs: Sequence[str | Path], out: str | Path, title: str,
                    reference: dict[str, float] | None = None) -> Path:
    """A PNG of the evaluation success rate against env steps: each run thin, their mean thick.

    ``reference``: horizontal lines (label -> success rate), e.g. the planners' success on
    the same env.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    curves = [(Path(r), eval_curve(Path(r))) for r in runs]
    curves = [(r, c) for r, c in curves if c["success"]]
    if not curves:
        raise ValueError(f"no evaluation successes recorded in {[str(r) for r in runs]}")
    for run, c in curves:
        ax.plot(np.array(c["timesteps"]) / 1e3, c["success"], lw=0.8, alpha=0.6, label=run.name)
    n = min(len(c["success"]) for _, c in curves)
    if len(curves) > 1 and n:
        mean = np.mean([c["success"][:n] for _, c in curves], axis=0)
        ax.plot(np.array(curves[0][1]["timesteps"][:n]) / 1e3, mean, lw=2.2, color="black", label="mean of runs")
    for (label, rate), style in zip((reference or {}).items(), ("--", ":", "-.", (0, (5, 1)))):
        ax.axhline(rate, ls=style, color="tab:red", lw=1.2, label=f"{label} ({rate:.2f})")
    ax.set_xlabel("env steps (thousands)")
    ax.set_ylabel("success rate (deterministic evaluation)")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7, loc="lower right")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def _zoo_entry(algo: str, env_id: str) -> dict[str, Any]:
    """The hyperparameter entry of ``env_id`` in ``configs/rl/<algo>.yml``, anchors resolved."""
    data = yaml.safe_load((config_dir() / "rl" / f"{algo}.yml").read_text(encoding="utf-8"))
    if env_id not in data:
        raise KeyError(f"configs/rl/{algo}.yml has no entry for {env_id}")
    return dict(data[env_id])


def ppo_throughput(env_id: str, n_envs: int, timesteps: int = 8192, hyperparams_of: str | None = None) -> float:
    """Env steps per second inside ``PPO.learn`` (rollouts and updates), one torch thread.

    The model, wrappers and normalisation are those of ``configs/rl/ppo.yml``'s entry for
    ``hyperparams_of`` (default ``env_id``) with ``n_envs`` envs in a ``DummyVecEnv``; a
    first short ``learn`` warms up before the timed one. For an env with a discrete action
    space (CartPole, the ceiling) the action rescaling is left out.
    """
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(1)
    entry = _zoo_entry("ppo", hyperparams_of or env_id)
    env_kwargs = entry.get("env_kwargs", {}) if hyperparams_of is None else {}
    discrete = isinstance(gym.make(env_id).action_space, gym.spaces.Discrete)

    def wrap(env: gym.Env) -> gym.Env:
        return env if discrete else gym.wrappers.RescaleAction(env, -1.0, 1.0)

    venv = VecNormalize(make_vec_env(env_id, n_envs=n_envs, seed=0, env_kwargs=env_kwargs, wrapper_class=wrap),
                        norm_obs=True, norm_reward=False)
    keys = ("n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "learning_rate", "clip_range", "ent_coef")
    kwargs = {k: entry[k] for k in keys if k in entry}
    policy_kwargs = eval(entry["policy_kwargs"]) if isinstance(entry.get("policy_kwargs"), str) else {}  # zoo format
    if discrete:
        policy_kwargs.pop("log_std_init", None)
    model = PPO(entry.get("policy", "MlpPolicy"), venv, policy_kwargs=policy_kwargs, seed=0, device="cpu", **kwargs)
    model.learn(kwargs.get("n_steps", 512) * n_envs)  # warm-up: imports, first allocations
    t0 = time.perf_counter()
    model.learn(timesteps, reset_num_timesteps=False)
    wall = time.perf_counter() - t0
    done = model.num_timesteps - kwargs.get("n_steps", 512) * n_envs
    venv.close()
    return done / wall
