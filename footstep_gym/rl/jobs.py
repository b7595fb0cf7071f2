"""Training runs as jobs: a grid of (algorithm, env, seed) trained and shipped one after the other or as
Ray tasks, and the learning curves of runs and of shipped agents.

* :class:`Job`, :func:`train_and_ship` (one run through :func:`~footstep_gym.rl.training.train`, shipped
  with :func:`~footstep_gym.rl.training.ship` when asked) and :func:`run_jobs` (local or Ray);
* :func:`shipped_longer`: a shipped agent a grid's shorter run may not replace, checked before training;
* :func:`grid`: the jobs of a grid of algorithms' configs, checked; :func:`agent_grid`: the jobs that train
  registered agents again as they were shipped (their config, their evaluation, their folder);
* :func:`draw_curves`, :func:`draw_shipped_curves`, :func:`draw_run_curves` and :func:`planner_reference` (the planners' success on the
  same env, the curves' reference lines); :func:`throughput_table`: PPO's env steps/s.

``baselines/train_rl.py`` is the command line of this module.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import footstep_gym
from footstep_gym.rl import training
from footstep_gym.rl.registry import AGENTS, AgentEntry

REFERENCE_PLANNERS = ("period-aware", "fixed-period")


def planner_reference(results: Path, env_id: str) -> dict[str, float]:
    """Each reference planner's success rate on ``env_id`` pooled over the settings of an evaluation."""
    if not results.is_file():
        return {}
    records = json.loads(results.read_text(encoding="utf-8"))
    envs = set(footstep_gym.ENV_IDS.values()) if env_id == footstep_gym.MIX_ENV_ID else {env_id}
    out = {}
    for planner in REFERENCE_PLANNERS:
        rows = [r for r in records if r["env"] in envs and r["policy"] == planner]
        if rows:
            n = sum(r["episodes"] for r in rows)
            out[f"{planner} (test split)"] = sum(r["successes"] for r in rows) / n
    return out


def draw_curves(agents_dir: Path, out_dir: Path, reference: Path, only: tuple[str, str] | None = None) -> list[Path]:
    """One learning-curve PNG per (agent folder, env) of the shipped agents: ``<folder>_<EnvId>.png``
    (the folder is the algorithm's name unless the agent has its own, e.g. ``ppo-fixed-period``)."""
    groups: dict[tuple[str, str], list[Path]] = {}
    algos: dict[str, str] = {}
    for manifest in sorted(agents_dir.glob("*/*/manifest.json")):
        m = json.loads(manifest.read_text(encoding="utf-8"))
        folder = manifest.parent.parent.name
        algos[folder] = m["algorithm"]
        groups.setdefault((folder, m["env_id"]), []).append(manifest.parent)
    written = []
    for (folder, env_id), runs in sorted(groups.items()):
        if only is not None and (folder, env_id) != only:
            continue
        runs = [r for r in runs if training.success_curve(r)["success"]]
        if not runs:
            print(f"no evaluation recorded for {folder} on {env_id} (training shorter than --eval-freq): no curve",
                  file=sys.stderr)
            continue
        name = algos[folder].upper() + ("" if folder == algos[folder] else f" ({folder})")
        title = f"{name} on {env_id}: success while training ({len(runs)} training seed(s))"
        written.append(training.learning_curves(runs, out_dir / f"{folder}_{env_id}.png", title,
                                                planner_reference(reference, env_id)))
    return written


def throughput_table(timesteps: int, rounds: int = 3) -> str:
    """Median over ``rounds`` of PPO's env steps/s with 1 and 2 envs (configs/rl/ppo.yml hyperparameters)."""
    import statistics

    envs = [(e, None) for e in footstep_gym.ENV_IDS.values()] + [("CartPole-v1", "FootstepDoor-v0")]
    lines = ["| env | PPO steps/s, 1 env | PPO steps/s, 2 envs |", "|---|---:|---:|"]
    for env_id, hyper in envs:
        cells = []
        for n in (1, 2):
            rates = [training.ppo_throughput(env_id, n, timesteps, hyperparams_of=hyper) for _ in range(rounds)]
            cells.append(f"{statistics.median(rates):.0f} ({min(rates):.0f}-{max(rates):.0f})")
        name = env_id + (" (door's hyperparameters; the ceiling)" if hyper else "")
        lines.append(f"| {name} | {cells[0]} | {cells[1]} |")
        print(lines[-1], file=sys.stderr)
    return "\n".join(lines)


@dataclass(frozen=True)
class Job:
    """One training run of the grid: ``algo`` on ``env_id`` with ``seed``; ``agent``: the registered agent it
    trains (its config, evaluation options and shipped folder), None for the algorithm's own config."""

    algo: str
    env_id: str
    seed: int
    agent: str | None = None

    @property
    def entry(self) -> AgentEntry | None:
        return AGENTS[self.agent] if self.agent else None

    @property
    def conf_file(self) -> Path | None:
        """The agent's hyperparameter file (None: ``configs/rl/<algo>.yml``)."""
        entry = self.entry
        return training.conf_path(entry.config) if entry is not None and entry.config else None

    @property
    def folder(self) -> str:
        """The folder under the agents folder the run ships to."""
        return self.entry.folder if self.entry is not None else training.default_agent_folder(self.algo)

    @property
    def name(self) -> str:
        return self.agent or self.algo


def grid(algos: Sequence[str], env_ids: Sequence[str], seeds: Sequence[int]) -> list[Job]:
    """The jobs of a grid, algorithms x envs x seeds in that order; a KeyError (its one argument says why) for
    an algorithm with no hyperparameters for an env (:func:`~footstep_gym.rl.training.zoo_entry`)."""
    for algo in algos:
        for env_id in env_ids:
            training.zoo_entry(algo, env_id)
    return [Job(algo, env_id, seed) for algo in algos for env_id in env_ids for seed in seeds]


def agent_envs(name: str) -> list[str]:
    """The env ids registered agent ``name`` was shipped for: its ``trained_on``, else every scene's env its config
    has an entry for."""
    entry = AGENTS[name]
    if entry.trained_on:
        return [entry.trained_on]
    import yaml

    data = yaml.safe_load(training.conf_path(entry.config).read_text(encoding="utf-8"))
    return [env_id for env_id in footstep_gym.ENV_IDS.values() if env_id in data]


def agent_grid(names: Sequence[str], env_ids: Sequence[str] | None, seeds: Sequence[int]) -> list[Job]:
    """The jobs that train registered agents ``names`` again with the config they were shipped from, agents x envs x
    seeds; ``env_ids`` None: each agent's own (:func:`agent_envs`). A ``ValueError`` (one line) for an unknown agent,
    one whose hyperparameters are in no file of ``configs/rl/``, or an env it was not trained for."""
    jobs = []
    for name in names:
        if name not in AGENTS:
            raise ValueError(f"unknown agent {name!r}; registered: {', '.join(AGENTS)}")
        entry = AGENTS[name]
        if entry.config is None:
            raise ValueError(f"{name} cannot be trained by name: {entry.why_not_trainable}")
        own = agent_envs(name)
        envs = list(env_ids) if env_ids else own
        if entry.trained_on and envs != [entry.trained_on]:
            raise ValueError(f"{name} is trained on {entry.trained_on}, not {', '.join(envs)}")
        for env_id in envs:
            try:
                training.zoo_entry(entry.algo, env_id, training.conf_path(entry.config))
            except KeyError as exc:
                raise ValueError(f"{name}: {exc.args[0]}") from None
        jobs += [Job(entry.algo, env_id, seed, agent=name) for env_id in envs for seed in seeds]
    return jobs


def shipped_longer(jobs: list[Job], agents_dir: Path, timesteps: int | None) -> str | None:
    """Why a job's run could not replace its shipped agent (a run with fewer timesteps), or None: checked before
    training (the success is checked when shipping)."""
    for job in jobs:
        shipped = agents_dir / job.folder / f"{job.env_id}_{job.seed}"
        planned = training.planned_timesteps(job.algo, job.env_id, timesteps, job.conf_file)
        problem = training.replace_problem(shipped, planned, check_success=False)
        if problem:
            return problem
    return None


def train_and_ship(job: Job, log_folder: str, agents_dir: str | None, force: bool = False,
                   **kwargs: Any) -> dict[str, Any]:
    """Train ``job`` with rl_zoo3 (its own log folder per seed; per agent and seed for a registered agent, whose
    config and evaluation options it takes where ``kwargs`` do not set them) and ship it if ``agents_dir``.

    Returns ``run`` (the zoo's run folder), ``wall`` [s], ``shipped`` (the agent's folder or
    None) and ``refused`` (why a shipped agent was not replaced, or None).
    """
    log = Path(log_folder) / f"seed{job.seed}"
    entry = job.entry
    if entry is not None:
        log = Path(log_folder) / job.agent / f"seed{job.seed}"
        kwargs = {"conf_file": job.conf_file, **kwargs}
        kwargs.setdefault("eval_freq", entry.eval_freq)
        if entry.eval_like_training:
            kwargs.setdefault("eval_env_kwargs", "training")
    kwargs["eval_freq"] = kwargs.get("eval_freq", 25_000)
    run, wall = training.train(job.algo, job.env_id, job.seed, log, **kwargs)
    print(f"  {job.name} on {job.env_id}, seed {job.seed}: {run} in {wall:.0f} s", file=sys.stderr)
    out = {"run": str(run), "wall": wall, "shipped": None, "refused": None}
    if agents_dir is None:
        named = f" --agent {job.agent}" if job.agent else ""
        print(f"  to ship it: python baselines/train_rl.py --ship {run} --wall-time {wall:.0f}{named}",
              file=sys.stderr)
    else:
        try:
            out["shipped"] = str(training.ship(run, agents_dir, wall, seed=job.seed, force=force, agent=job.folder))
        except training.ShipRefused as exc:
            out["refused"] = str(exc)
    return out


def run_jobs(jobs: list[Job], options: dict, backend: str, address: str | None, workers: int) -> list[dict[str, Any]]:
    """Every job, one after the other or as Ray tasks (a local Ray of ``workers`` CPUs without ``address``)."""
    print(f"{len(jobs)} training run(s) ({backend}): " + ", ".join(f"{j.name}/{j.env_id}/{j.seed}" for j in jobs),
          file=sys.stderr)
    if backend == "local":
        return [train_and_ship(job, **options) for job in jobs]
    import ray

    if address:
        ray.init(address=address, log_to_driver=True)
    else:
        ray.init(num_cpus=workers, include_dashboard=False)
    try:
        remote = ray.remote(num_cpus=1)(train_and_ship)
        return ray.get([remote.remote(job, **options) for job in jobs])
    finally:
        ray.shutdown()


def draw_shipped_curves(jobs: list[Job], outcomes: list[dict[str, Any]], agents_dir: Path, curves_dir: Path,
                        reference: Path) -> list[Path]:
    """The learning curves of the shipped agents of each (algorithm, env) of the grid a run was shipped to
    (:func:`draw_curves`)."""
    shipped = {(j.folder, j.env_id) for j, o in zip(jobs, outcomes) if o["shipped"]}
    return [path for key in dict.fromkeys((j.folder, j.env_id) for j in jobs) if key in shipped
            for path in draw_curves(agents_dir, curves_dir, reference, only=key)]


def draw_run_curves(jobs: list[Job], outcomes: list[dict[str, Any]], log_folder: Path, reference: Path) -> list[Path]:
    """The learning curves of a grid's runs (not shipped), one per (algorithm, env) into
    ``<log_folder>/learning_curves/<algo>_<EnvId>.png``; runs with no evaluation recorded are left out."""
    written = []
    for name, env_id in dict.fromkeys((j.name, j.env_id) for j in jobs):
        runs = [Path(o["run"]) for j, o in zip(jobs, outcomes) if (j.name, j.env_id) == (name, env_id)]
        runs = [r for r in runs if training.success_curve(r)["success"]]
        if runs:
            title = f"{name.upper()} on {env_id}: success while training ({len(runs)} run(s))"
            written.append(training.learning_curves(runs, log_folder / "learning_curves" / f"{name}_{env_id}.png",
                                                    title, planner_reference(reference, env_id)))
    return written
