"""Training agents through rl_zoo3 and shipping them in the zoo's layout with a manifest.

The training itself is rl_zoo3's (``python -m rl_zoo3.train``, hyperparameters in
``configs/rl/<algo>.yml``, one entry per env id). This module adds what the zoo does not:
several training seeds in a row with one torch thread each, the run's progress on the
console while it trains (its full output goes to a log file), an evaluation at the end of
a run shorter than the evaluation period, the wall time, CPU time, machine and throughput of each run,
shipping: a copy of the run's small files under ``<agents>/<agent>/<EnvId>_<seed>/``
(``<agent>``: the registry's folder of the agent, :class:`~footstep_gym.rl.registry.AgentEntry`;
the algorithm's name by default; model ``.zip``,
``<EnvId>/{config.yml,args.yml,command.txt,vecnormalize.pkl}``, ``evaluations.npz``) with a
``manifest.json``, which does not replace a longer or better shipped agent unless forced,
and learning curves.

Nothing here imports torch: training runs in a subprocess (:func:`ppo_throughput` excepted).
"""

from __future__ import annotations

import csv
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import yaml

from footstep_gym.config import config_dir
from footstep_gym.errors import FootstepGymError
from footstep_gym.rl.registry import default_agent_folder

#: The zoo's files of a run that ship with an agent (small: no replay buffer, no checkpoints).
SHIPPED_IN_ENV_FOLDER = ("config.yml", "args.yml", "command.txt", "vecnormalize.pkl")


#: Algorithms that collect whole rollouts of ``n_steps`` per env between updates (SB3's defaults).
ON_POLICY_N_STEPS = {"ppo": 2048, "a2c": 5}

#: Algorithms that train through :mod:`footstep_gym.rl.zoo_sbx` (sbx's JAX classes registered in rl_zoo3) rather
#: than ``rl_zoo3.train``: the same command line and saved layout, the run's ``args.yml`` names the algorithm.
ZOO_MODULE = {"sac_sbx": "footstep_gym.rl.zoo_sbx", "td3_sbx": "footstep_gym.rl.zoo_sbx"}


class ShipRefused(FootstepGymError):
    """Shipping would replace a shipped agent with a shorter or worse run (``force`` not given)."""


def conf_path(algo: str, conf_file: str | Path | None = None) -> Path:
    """The hyperparameter file: ``conf_file``, else ``configs/rl/<algo>.yml``."""
    return Path(conf_file) if conf_file is not None else config_dir() / "rl" / f"{algo}.yml"


def zoo_command(algo: str, env_id: str, seed: int, log_folder: str | Path, *, conf_file: str | Path | None = None,
                timesteps: int | None = None, eval_freq: int = 25_000, eval_episodes: int = 20,
                threads: int = 1, log_interval: int | None = None, python: str = sys.executable,
                eval_env_kwargs: dict[str, Any] | str | None = None) -> list[str]:
    """The rl_zoo3 command line that trains ``algo`` on ``env_id`` with ``seed`` into ``log_folder``.

    ``python -m rl_zoo3.train``, or for the sbx algorithms (:data:`ZOO_MODULE`) ``python -m
    footstep_gym.rl.zoo_sbx`` with the same arguments. ``eval_env_kwargs``: the env options
    of the zoo's evaluation env (``--eval-env-kwargs``), which otherwise gets none of the
    config's ``env_kwargs`` (an rl_zoo3 quirk: it evaluates on the env's defaults);
    ``"training"``: the config entry's own ``env_kwargs``, i.e. evaluate on the training
    distribution.

    ``conf_file`` defaults to ``configs/rl/<algo>.yml``; ``eval_freq`` (env steps, all envs
    together; the zoo divides it by ``n_envs``) and ``eval_episodes`` set the zoo's
    EvalCallback, whose success rate (from ``info["is_success"]``) makes the learning
    curve; ``timesteps`` overrides the file's. ``log_interval`` (default: every rollout of
    an on-policy algorithm, every 10 episodes of an off-policy one) paces the progress
    tables in the log.
    """
    if log_interval is None:
        log_interval = 1 if algo in ON_POLICY_N_STEPS else 10
    cmd = [python, "-m", ZOO_MODULE.get(algo, "rl_zoo3.train"), "--algo", algo, "--env", env_id, "--gym-packages", "footstep_gym",
           "--conf-file", str(conf_path(algo, conf_file)), "--num-threads", str(threads), "--seed", str(seed),
           "-f", str(log_folder), "--eval-freq", str(eval_freq), "--eval-episodes", str(eval_episodes),
           "--log-interval", str(log_interval)]
    if timesteps is not None:
        cmd += ["-n", str(timesteps)]
    if eval_env_kwargs == "training":
        eval_env_kwargs = dict(zoo_entry(algo, env_id, conf_file).get("env_kwargs") or {})
    elif isinstance(eval_env_kwargs, str):
        raise ValueError(f"eval_env_kwargs: a dict or 'training', not {eval_env_kwargs!r}")
    if eval_env_kwargs:
        # The zoo's StoreDict: key:value with the value evaluated as Python.
        cmd += ["--eval-env-kwargs", *(f"{k}:{_plain(v)!r}" for k, v in eval_env_kwargs.items())]
    return cmd


def planned_timesteps(algo: str, env_id: str, timesteps: int | None = None,
                      conf_file: str | Path | None = None) -> int:
    """The env steps a run will be asked for: ``timesteps``, else the config's ``n_timesteps``."""
    if timesteps is not None:
        return int(timesteps)
    return int(float(zoo_entry(algo, env_id, conf_file)["n_timesteps"]))


def callback_calls(algo: str, entry: dict[str, Any], timesteps: int) -> int:
    """How many times the zoo's callbacks run in a training of ``timesteps`` env steps (at least).

    A callback runs once per vectorised step, i.e. per ``n_envs`` env steps, and SB3 stops
    at the first whole collection past ``timesteps``: a rollout of ``n_steps`` per env for an
    on-policy algorithm, ``train_freq`` steps per env for an off-policy one (exact for both;
    a ``train_freq`` counted in episodes gives the lower bound ``ceil(timesteps / n_envs)``).
    """
    n_envs = int(entry.get("n_envs", 1))
    if algo in ON_POLICY_N_STEPS:
        chunk = int(entry.get("n_steps", ON_POLICY_N_STEPS[algo]))
    else:
        freq = entry.get("train_freq", 1)
        chunk = int(freq) if isinstance(freq, (int, float)) else 1
    return -(-int(timesteps) // (chunk * n_envs)) * chunk


def run_eval_freq(algo: str, env_id: str, eval_freq: int, timesteps: int | None = None,
                  conf_file: str | Path | None = None) -> int:
    """The ``--eval-freq`` to give the zoo so that a run evaluates at least once, at its end if it is short.

    The zoo evaluates every ``eval_freq // n_envs`` callback calls; a run with fewer calls
    than that would never evaluate (no learning curve, no final success in the manifest).
    Then the period becomes the run's own length, so the one evaluation is at its end.
    Otherwise ``eval_freq`` is kept.
    """
    entry = zoo_entry(algo, env_id, conf_file)
    n_envs = int(entry.get("n_envs", 1))
    calls = callback_calls(algo, entry, planned_timesteps(algo, env_id, timesteps, conf_file))
    if max(eval_freq // n_envs, 1) <= calls:
        return int(eval_freq)
    return calls * n_envs


def latest_run(log_folder: str | Path, algo: str, env_id: str) -> Path:
    """The zoo's newest run folder ``<log_folder>/<algo>/<env_id>_<k>`` (largest k)."""
    runs = [p for p in (Path(log_folder) / algo).glob(f"{env_id}_*") if p.name.rsplit("_", 1)[-1].isdigit()]
    if not runs:
        raise FileNotFoundError(f"no run of {algo} on {env_id} under {log_folder}")
    return max(runs, key=lambda p: int(p.name.rsplit("_", 1)[-1]))


#: A line of SB3's progress table with the env steps done so far, and the EvalCallback's report lines.
_TIMESTEPS_LINE = re.compile(r"^\|\s*total_timesteps\s*\|\s*(\d+)")
_EVAL_LINE = re.compile(r"^Eval num_timesteps=(\d+), episode_reward=(\S+)")
_SUCCESS_LINE = re.compile(r"^Success rate: ([\d.]+)%")


def train(algo: str, env_id: str, seed: int, log_folder: str | Path, log_file: str | Path | None = None,
          progress: bool | None = None, **kwargs: Any) -> tuple[Path, float]:
    """Train one agent with rl_zoo3 in a subprocess; ``(run folder, wall time [s])``.

    The zoo's output goes to ``log_file`` (default: ``<log_folder>/<algo>_<env_id>_<seed>.log``);
    the console (stderr) gets where the log is, a progress bar of the env steps (``progress``:
    None shows it on a terminal only) and one line per periodic evaluation. ``kwargs`` go to
    :func:`zoo_command`; its ``eval_freq`` is first fitted to the run (:func:`run_eval_freq`).
    """
    from tqdm import tqdm

    log_folder = Path(log_folder)
    log_folder.mkdir(parents=True, exist_ok=True)
    log_file = Path(log_file) if log_file else log_folder / f"{algo}_{env_id}_{seed}.log"
    total = planned_timesteps(algo, env_id, kwargs.get("timesteps"), kwargs.get("conf_file"))
    if "eval_freq" in kwargs:
        asked = kwargs["eval_freq"]
        kwargs["eval_freq"] = run_eval_freq(algo, env_id, asked, kwargs.get("timesteps"), kwargs.get("conf_file"))
    cmd = zoo_command(algo, env_id, seed, log_folder, **kwargs)
    name = f"{algo} on {env_id}, seed {seed}"
    note = ""
    if "eval_freq" in kwargs and kwargs["eval_freq"] != asked:
        note = f"; the run is shorter than --eval-freq {asked}: one evaluation, at its end"
    print(f"{name}: {total:,} env steps; log {log_file}{note}", file=sys.stderr, flush=True)
    env = dict(os.environ, PYTHONUNBUFFERED="1")  # the zoo's lines as they are printed
    t0, cpu0 = time.perf_counter(), _children_cpu_s()
    evaluation: list[str] = []
    with open(log_file, "w", encoding="utf-8") as fh, \
            tqdm(total=total, desc=f"{algo}/{env_id}/{seed}", unit="step", file=sys.stderr, dynamic_ncols=True,
                 disable=None if progress is None else not progress) as bar:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                encoding="utf-8", errors="replace", env=env)
        assert proc.stdout is not None
        for line in proc.stdout:
            fh.write(line)
            if m := _TIMESTEPS_LINE.match(line):
                bar.update(min(int(m.group(1)), total) - bar.n)
            elif m := _EVAL_LINE.match(line):
                evaluation = [f"evaluation at {int(m.group(1)):,} steps: return {m.group(2)}"]
            elif (m := _SUCCESS_LINE.match(line)) and evaluation:
                evaluation.append(f"success {float(m.group(1)) / 100:.2f}")
                bar.write(f"  {name}: " + ", ".join(evaluation), file=sys.stderr)
                evaluation = []
        returncode = proc.wait()
    wall, cpu = time.perf_counter() - t0, _children_cpu_s() - cpu0
    if returncode != 0:
        raise RuntimeError(f"rl_zoo3 training of {name} failed with exit code {returncode}; see {log_file}")
    run = latest_run(log_folder, algo, env_id)
    cost = {"wall_time_s": round(wall, 1), "cpu_time_s": round(cpu, 1), "hardware": hardware()}
    (run / COST_FILE).write_text(json.dumps(cost, indent=2) + "\n", encoding="utf-8")
    return run, wall


#: What :func:`train` measured of a run's cost (wall and CPU time, the machine), written in the run folder.
COST_FILE = "cost.json"


def _children_cpu_s() -> float:
    """User + system CPU time [s] of this process's finished (waited-for) child processes, all threads."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def hardware() -> dict[str, Any]:
    """The machine a run trained on: its CPU model (``/proc/cpuinfo``'s model name where there is one), logical
    CPUs, architecture, operating system and the 1-minute load average (a shared machine's) when asked."""
    model = platform.processor() or None
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            model = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), model)
    except OSError:  # no /proc (not Linux): platform.processor()'s answer stands
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    return {"cpu_model": model, "logical_cpus": os.cpu_count(), "machine": platform.machine(),
            "system": platform.system(), "load_average_1min": None if load is None else round(load, 2)}


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


#: The validation curve a run's ``ValidationCallback`` writes (footstep_gym/rl/callbacks.py), shipped with it.
VALIDATION_CURVE = "validation.csv"
#: A curve of at most this many points is drawn with a marker on each (one point alone is no line).
SHORT_CURVE = 5


def validation_curve(run: Path) -> dict[str, list[float]]:
    """A run's success on the validation split as it trained (``validation.csv``; empty lists without one):
    timesteps, training wall time [s] and success rate per evaluation."""
    path = run / VALIDATION_CURVE
    if not path.is_file():
        return {"timesteps": [], "wall_time_s": [], "success": [], "episodes": 0}
    with open(path, encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    return {"timesteps": [int(r["timesteps"]) for r in rows], "wall_time_s": [float(r["wall_time_s"]) for r in rows],
            "success": [float(r["success_rate"]) for r in rows], "episodes": int(rows[-1]["episodes"]) if rows else 0}


def success_curve(run: Path) -> dict[str, list[float]]:
    """A run's learning curve, ``{"timesteps", "success"}``: its validation curve (:func:`validation_curve`) if it
    has one, else the zoo's periodic evaluation (:func:`eval_curve`)."""
    curve = validation_curve(run)
    return curve if curve["success"] else eval_curve(run)


def replace_problem(dest: str | Path, timesteps: int, success: float | None = None,
                    check_success: bool = True) -> str | None:
    """Why a run of ``timesteps`` env steps ending at evaluation success ``success`` must not
    replace the agent shipped at ``dest`` (one line), or None if it may (or nothing is there).

    A run may not replace a longer one (more timesteps), nor one whose final evaluation
    succeeded more often (a run with no evaluation counts as worse than one with one), nor a
    folder that is not a shipped agent (no ``manifest.json``). ``check_success=False``: the
    timesteps only (before training, when the success is not known yet).
    """
    dest = Path(dest)
    if not dest.exists():
        return None
    hint = "not replaced (--force replaces it)"
    path = dest / "manifest.json"
    if not path.is_file():
        return f"{dest} exists and is not a shipped agent (no manifest.json); {hint}"
    old = json.loads(path.read_text(encoding="utf-8"))
    old_timesteps = int(old.get("timesteps") or 0)
    if timesteps < old_timesteps:
        return f"{dest} holds a longer run ({old_timesteps:,} env steps) than this one ({timesteps:,}); {hint}"
    old_success = old.get("final_eval_success")
    if check_success and old_success is not None and (success is None or success < old_success):
        now = "none recorded" if success is None else f"{success:.2f}"
        return f"{dest} holds a better run (final evaluation success {old_success:.2f}, this one {now}); {hint}"
    return None


def ship(run: str | Path, agents_dir: str | Path, wall_time_s: float, seed: int | None = None,
         force: bool = False, agent: str | None = None) -> Path:
    """Copy a finished zoo run's small files to ``<agents_dir>/<agent>/<EnvId>_<seed>/`` and write its manifest.

    ``agent``: the shipped folder, the agent's :attr:`AgentEntry.folder
    <footstep_gym.rl.registry.AgentEntry.folder>` (e.g. ``ppo-fixed-period`` for a PPO run of
    ``configs/rl/ppo-fixed-period.yml``); default :func:`default_agent_folder` of the run's algorithm
    (``ppo``; ``sac`` for an sbx ``sac_sbx`` run). A shipped agent of another algorithm is never replaced.
    The manifest records the agent's folder, the algorithm, env id and kwargs (the env
    options the agent was trained with, e.g. ``fixed_period``), timesteps, seed, ``n_envs``,
    the wall time and the training throughput (env steps per second of wall time, start-up
    and periodic evaluations included), the CPU time of the training process and its children and the
    machine (:func:`hardware`) where :func:`train` recorded them (``cost.json``, shipped too; None
    otherwise), the final evaluation's success rate and the versions.
    An agent already there is replaced only by a run at least as long and as good
    (:func:`replace_problem`), or with ``force``; else :class:`ShipRefused` is raised before
    anything is written. The new agent is put together beside the old one and swapped in.
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
    agent = agent or default_agent_folder(algo)
    if not agent or Path(agent).name != agent or agent.startswith("."):
        raise ValueError(f"agent folder {agent!r}: one plain folder name expected (e.g. {algo!r})")
    dest = Path(agents_dir) / agent / f"{env_id}_{seed}"
    timesteps = int(args.get("n_timesteps") or -1)
    if timesteps <= 0:
        timesteps = int(float(config["n_timesteps"]))
    curve = eval_curve(run)
    final_success = curve["success"][-1] if curve["success"] else None
    final_episodes, final_on = int(args.get("eval_episodes", 0)), "the zoo's eval env"
    cost_path = run / COST_FILE
    cost = json.loads(cost_path.read_text(encoding="utf-8")) if cost_path.is_file() else {}
    validation = validation_curve(run)
    if validation["success"]:  # the validation split's seeds (callbacks.ValidationCallback) over the zoo's eval
        final_success, final_episodes, final_on = validation["success"][-1], validation["episodes"], "validation split"
    problem = None if force else replace_problem(dest, timesteps, final_success)
    old_manifest = dest / "manifest.json"
    if old_manifest.is_file():  # not even with force: another algorithm's agent is another agent
        old_algo = json.loads(old_manifest.read_text(encoding="utf-8")).get("algorithm")
        if old_algo != algo:
            raise ShipRefused(f"{dest} holds a {old_algo} agent, this run is {algo}: not replaced (ship it as "
                              f"another agent, --agent)")
    if problem:
        raise ShipRefused(problem)

    def version(dist: str) -> str | None:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return None

    manifest = {
        "agent": agent,
        "algorithm": algo,
        "env_id": env_id,
        "env_kwargs": _plain(config.get("env_kwargs", {})),
        "n_envs": int(config.get("n_envs", 1)),
        "timesteps": timesteps,
        "seed": seed,
        "wall_time_s": round(wall_time_s, 1),
        "env_steps_per_s": round(timesteps / wall_time_s, 1),
        "cpu_time_s": cost.get("cpu_time_s"),
        "torch_threads": int(args.get("num_threads", -1)),
        "final_eval_success": final_success,
        "final_eval_episodes": final_episodes,
        "final_eval_on": final_on,
        "command": (folder / "command.txt").read_text(encoding="utf-8").strip()
        if (folder / "command.txt").is_file() else None,
        "versions": {d: version(d) for d in ("footstep_gym", "stable_baselines3", "rl_zoo3", "torch", "gymnasium")},
        "python": platform.python_version(),
        "machine": platform.machine(),
        "hardware": cost.get("hardware"),  # None: the run was not trained by train() (its machine is not known)
    }
    dest.parent.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=f".{dest.name}.", suffix=".partial", dir=dest.parent))
    umask = os.umask(0)
    os.umask(umask)
    stage.chmod(0o777 & ~umask)  # as a folder made by mkdir (mkdtemp makes it private)
    try:
        (stage / env_id).mkdir()
        shutil.copy2(model, stage / model.name)
        for name in SHIPPED_IN_ENV_FOLDER:
            if (folder / name).is_file():
                shutil.copy2(folder / name, stage / env_id / name)
        for name in ("evaluations.npz", VALIDATION_CURVE, COST_FILE):
            if (run / name).is_file():
                shutil.copy2(run / name, stage / name)
        (stage / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
        if dest.exists():
            old = stage.with_suffix(".old")
            os.replace(dest, old)
            os.replace(stage, dest)
            shutil.rmtree(old)
        else:
            os.replace(stage, dest)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return dest


def learning_curves(runs: Sequence[str | Path], out: str | Path, title: str,
                    reference: dict[str, float] | None = None) -> Path:
    """A PNG of the success rate against env steps (:func:`success_curve`): each run thin, their mean thick.

    ``reference``: horizontal lines (label -> success rate), e.g. the planners' success on
    the same env.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    curves = [(Path(r), success_curve(Path(r))) for r in runs]
    curves = [(r, c) for r, c in curves if c["success"]]
    if not curves:
        raise ValueError(f"no evaluation successes recorded in {[str(r) for r in runs]}")
    for run, c in curves:
        ax.plot(np.array(c["timesteps"]) / 1e3, c["success"], lw=0.8, alpha=0.6, label=run.name,
                marker="o" if len(c["success"]) <= SHORT_CURVE else None)
    n = min(len(c["success"]) for _, c in curves)
    if len(curves) > 1 and n:
        mean = np.mean([c["success"][:n] for _, c in curves], axis=0)
        ax.plot(np.array(curves[0][1]["timesteps"][:n]) / 1e3, mean, lw=2.2, color="black", label="mean of runs",
                marker="o" if n <= SHORT_CURVE else None)
    for (label, rate), style in zip((reference or {}).items(), ("--", ":", "-.", (0, (5, 1)))):
        ax.axhline(rate, ls=style, color="tab:red", lw=1.2, label=f"{label} ({rate:.2f})")
    return save_success_figure(fig, ax, out, title, "success rate (deterministic evaluation)", legend_size=7, dpi=110)


def save_success_figure(fig: Any, ax: Any, out: str | Path, title: str, ylabel: str, legend_size: int,
                        dpi: float | None = None) -> Path:
    """Frame a success-against-env-steps plot (x in thousands of env steps, y in [0, 1] with a margin, grid,
    title, legend lower right), write it to ``out`` (its folder made) and close it; ``out``."""
    import matplotlib.pyplot as plt

    ax.set_xlabel("env steps (thousands)")
    ax.set_ylabel(ylabel)
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=legend_size, loc="lower right")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, **({} if dpi is None else {"dpi": dpi}))
    plt.close(fig)
    return out


def zoo_policy_kwargs(entry: dict[str, Any]) -> dict[str, Any]:
    """The ``policy_kwargs`` of a zoo entry (:func:`zoo_entry`): rl_zoo3 writes them as a Python expression
    string (``"dict(log_std_init=-0.5, net_arch=...)"``), evaluated as the zoo does; ``{}`` when absent."""
    kwargs = entry.get("policy_kwargs")
    return eval(kwargs) if isinstance(kwargs, str) else {}  # the zoo's own format, read as rl_zoo3 reads it


def zoo_entry(algo: str, env_id: str, conf_file: str | Path | None = None) -> dict[str, Any]:
    """The hyperparameter entry of ``env_id`` in ``configs/rl/<algo>.yml`` (or ``conf_file``), anchors resolved."""
    path = conf_path(algo, conf_file)
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    if env_id not in data:
        shown = f"configs/rl/{path.name}" if path.parent == config_dir() / "rl" else str(path)
        raise KeyError(f"{shown} has no entry for {env_id}")
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
    entry = zoo_entry("ppo", hyperparams_of or env_id)
    env_kwargs = entry.get("env_kwargs", {}) if hyperparams_of is None else {}
    discrete = isinstance(gym.make(env_id).action_space, gym.spaces.Discrete)

    def wrap(env: gym.Env) -> gym.Env:
        if discrete:
            return env
        box = env.action_space  # bounds in the box's dtype: Python floats make Gymnasium warn about float64
        return gym.wrappers.RescaleAction(env, np.full(box.shape, -1.0, box.dtype), np.full(box.shape, 1.0, box.dtype))

    venv = VecNormalize(make_vec_env(env_id, n_envs=n_envs, seed=0, env_kwargs=env_kwargs, wrapper_class=wrap),
                        norm_obs=True, norm_reward=False)
    keys = ("n_steps", "batch_size", "n_epochs", "gamma", "gae_lambda", "learning_rate", "clip_range", "ent_coef")
    kwargs = {k: entry[k] for k in keys if k in entry}
    policy_kwargs = zoo_policy_kwargs(entry)
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
