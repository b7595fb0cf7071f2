"""Train the RL baselines with rl_zoo3, several seeds in a row; ship them with a manifest and learning curves.

Usage::

    python baselines/train_rl.py --algo ppo --env door --seeds 1 --timesteps 8192   # a first, short try: runs/rl/
    python baselines/train_rl.py --algo ppo --env door --seeds 1 2 3 --ship       # train, ship, redraw the curves
    python baselines/train_rl.py --algo ppo --env all --seeds 1 --ship            # ppo-all: FootstepMix-v0
    python baselines/train_rl.py --algo ppo sac --env door crowd --seeds 1 2 3 --backend ray   # a grid as Ray tasks
    python baselines/train_rl.py --algo sac --env door --seeds 1 --timesteps 20000 --eval-freq 5000
    python baselines/train_rl.py --ship runs/rl/seed1/ppo/FootstepDoor-v0_1 --wall-time 1500   # ship a finished run
    python baselines/train_rl.py --ship runs/rl-fixed/seed1/ppo/FootstepDoor-v0_1 --wall-time 267 \\
        --agent ppo-fixed-period                                         # ... as a registered agent of its own
    python baselines/train_rl.py --curves                                # learning curves of every shipped agent
    python baselines/train_rl.py --throughput                            # PPO env steps/s with 1 and 2 envs

Each seed is one ``python -m rl_zoo3.train`` run (hyperparameters: ``configs/rl/<algo>.yml``,
one torch thread) into ``--log-folder`` (default ``runs/rl``: ``seed<S>/<algo>/<EnvId>_<k>/``
and the zoo's output in ``seed<S>/<algo>_<EnvId>_<S>.log``); the console shows a progress
bar and each periodic evaluation (the zoo's deterministic evaluation every ``--eval-freq``
env steps, success from ``info["is_success"]``; a run shorter than that is evaluated once,
at its end). The runs' learning curves are drawn to ``<log-folder>/learning_curves/``.

Nothing is shipped unless asked: with ``--ship``, each run's small files are copied to
``--agents-dir/<algo>/<EnvId>_<seed>/`` (default ``baselines/agents``, the agents the
evaluation uses; with ``--ship RUN --agent NAME``, that registered agent's folder instead of
``<algo>``) in the zoo's layout with a ``manifest.json`` (wall time, env steps per second),
and the learning curves of the shipped agents are redrawn to
``--curves-dir/<folder>_<EnvId>.png`` (default ``baselines/results/learning_curves``) with the
planners' success on the same env as reference lines. A shipped agent is not replaced by a
run with fewer timesteps (checked before training) or a lower final evaluation success
(checked before anything is copied) unless ``--force`` is given: the run then stays in
``--log-folder``, one error line says why, and the exit status is 2.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import footstep_gym
from footstep_gym.rl import AGENTS, training

REPO = Path(__file__).resolve().parent.parent
DEFAULT_AGENTS = REPO / "baselines" / "agents"
DEFAULT_CURVES = REPO / "baselines" / "results" / "learning_curves"
DEFAULT_REFERENCE = REPO / "baselines" / "results" / "agents" / "results.json"
REFERENCE_PLANNERS = ("period-aware", "fixed-period")


def env_id_of(name: str) -> str:
    """A scene name (``door``), ``all`` (the mix) or an env id -> the env id (``footstep_gym.resolve_env_id``)."""
    try:
        return footstep_gym.resolve_env_id(name, mix=True)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


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
        runs = [r for r in runs if training.eval_curve(r)["success"]]
        if not runs:
            print(f"no evaluation recorded for {folder} on {env_id} (training shorter than --eval-freq): no curve",
                  file=sys.stderr)
            continue
        name = algos[folder].upper() + ("" if folder == algos[folder] else f" ({folder})")
        title = f"{name} on {env_id}: success of the periodic evaluation ({len(runs)} training seed(s))"
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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="train_rl.py", description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--ship", nargs="?", const=True, type=Path, metavar="RUN",
                      help="with training: ship each run to --agents-dir and redraw its learning curves "
                           "(without it, runs stay in --log-folder); with RUN: ship that finished zoo run "
                           "folder instead of training (needs --wall-time)")
    mode.add_argument("--curves", action="store_true", help="only draw the learning curves of the shipped agents")
    mode.add_argument("--throughput", action="store_true",
                      help="measure PPO's env steps/s inside learn() with 1 and 2 envs on each env, CartPole-v1 "
                           "as the ceiling; prints a markdown table (a measurement: run it on an idle machine)")
    parser.add_argument("--algo", choices=("ppo", "sac"), nargs="+",
                        help="algorithm(s) (configs/rl/<algo>.yml); several make a grid with --env and --seeds")
    parser.add_argument("--env", type=env_id_of, nargs="+",
                        help="door, crossing, crowd, all (FootstepMix-v0) or an env id; several make a grid")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1], metavar="S", help="training seeds (default 1)")
    parser.add_argument("--timesteps", type=int, metavar="N",
                        help="env steps per run (default: the config's n_timesteps, e.g. 600000 for PPO on the door)")
    parser.add_argument("--eval-freq", type=int, default=25_000, metavar="N",
                        help="env steps (all envs together) between the zoo's evaluations (default 25000); "
                             "a run shorter than this is evaluated once, at its end")
    parser.add_argument("--eval-episodes", type=int, default=20, metavar="N", help="episodes per evaluation")
    parser.add_argument("--log-folder", type=Path, default=REPO / "runs" / "rl",
                        help="where the runs and their logs go (default runs/rl)")
    parser.add_argument("--agents-dir", type=Path, default=DEFAULT_AGENTS,
                        help="where --ship puts agents (default baselines/agents)")
    parser.add_argument("--curves-dir", type=Path, default=DEFAULT_CURVES,
                        help="where --ship redraws the shipped agents' learning curves "
                             "(default baselines/results/learning_curves)")
    parser.add_argument("--force", action="store_true",
                        help="with --ship: replace a shipped agent even by a shorter or worse run")
    parser.add_argument("--reference", type=Path, default=DEFAULT_REFERENCE,
                        help="an evaluation's results.json for the planners' reference lines")
    parser.add_argument("--wall-time", type=float, metavar="S",
                        help="with --ship RUN: the run's measured wall time [s]")
    parser.add_argument("--agent", choices=sorted(AGENTS), metavar="NAME",
                        help="with --ship RUN: the registered agent the run ships as, in its folder under "
                             "--agents-dir (default: the run's algorithm's folder), e.g. ppo-fixed-period for a "
                             "run of configs/rl/ppo-fixed-period.yml")
    parser.add_argument("--no-ship", action="store_true", help=argparse.SUPPRESS)  # the default now; kept for scripts
    parser.add_argument("--backend", choices=("local", "ray"), default="local",
                        help="local: the runs one after the other; ray: each run a Ray task (one CPU)")
    parser.add_argument("--ray-address", metavar="ADDR", help="an existing Ray cluster (default: a local Ray)")
    parser.add_argument("--workers", type=int, default=2, metavar="N", help="CPUs of a local Ray (default 2)")
    return parser


def refuse(message: str) -> int:
    """One error line on stderr; exit status 2 (as argparse's errors)."""
    print(f"train_rl.py: error: {message}", file=sys.stderr)
    return 2


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.force and args.ship is None:
        parser.error("--force applies with --ship only")
    if args.agent and not isinstance(args.ship, Path):
        parser.error("--agent applies with --ship RUN only")
    if args.curves:
        for path in draw_curves(args.agents_dir, args.curves_dir, args.reference):
            print(path)
        return 0
    if args.throughput:
        print(throughput_table(args.timesteps or 8192))
        return 0
    if isinstance(args.ship, Path):
        if args.wall_time is None or args.wall_time <= 0:
            parser.error("--ship RUN needs --wall-time S (> 0): the run's measured wall time")
        folder = AGENTS[args.agent].folder if args.agent else None
        try:
            dest = training.ship(args.ship, args.agents_dir, args.wall_time, force=args.force, agent=folder)
        except training.ShipRefused as exc:
            return refuse(str(exc))
        print(dest)
        manifest = json.loads((dest / "manifest.json").read_text(encoding="utf-8"))
        if args.agent and manifest["algorithm"] != AGENTS[args.agent].algo:
            print(f"train_rl.py: warning: {args.agent} is registered as {AGENTS[args.agent].algo}, the run is "
                  f"{manifest['algorithm']}", file=sys.stderr)
        for path in draw_curves(args.agents_dir, args.curves_dir, args.reference,
                                only=(dest.parent.name, manifest["env_id"])):
            print(path)
        return 0
    ship = args.ship is True
    if ship and args.no_ship:
        parser.error("--ship and --no-ship contradict each other")
    if not args.algo or not args.env:
        parser.error("training needs --algo and --env (or use --ship RUN / --curves / --throughput)")
    if args.timesteps is not None and args.timesteps < 1:
        parser.error("--timesteps must be >= 1")
    if args.eval_freq < 1:
        parser.error("--eval-freq must be >= 1")
    if args.ray_address and args.backend != "ray":
        parser.error("--ray-address needs --backend ray")
    for algo in args.algo:
        for env_id in args.env:
            try:
                training.zoo_entry(algo, env_id)
            except KeyError as exc:
                parser.error(str(exc.args[0]))
    jobs = [Job(algo, env_id, seed) for algo in args.algo for env_id in args.env for seed in args.seeds]
    if ship and not args.force:  # a shorter run cannot replace a shipped agent: say so before training
        for job in jobs:
            problem = training.replace_problem(args.agents_dir / job.algo / f"{job.env_id}_{job.seed}",
                                               training.planned_timesteps(job.algo, job.env_id, args.timesteps),
                                               check_success=False)
            if problem:
                return refuse(problem)
    print(f"runs and logs go to {args.log_folder}; " + (f"shipping to {args.agents_dir}" if ship else
          "nothing is shipped (--ship copies the runs to the agents the evaluation uses)"), file=sys.stderr)
    options = dict(log_folder=str(args.log_folder), agents_dir=str(args.agents_dir) if ship else None,
                   force=args.force, timesteps=args.timesteps, eval_freq=args.eval_freq,
                   eval_episodes=args.eval_episodes, progress=None if args.backend == "local" else False)
    outcomes = run_jobs(jobs, options, args.backend, args.ray_address, args.workers)
    groups = list(dict.fromkeys((j.algo, j.env_id) for j in jobs))
    if ship:
        shipped = {(j.algo, j.env_id) for j, o in zip(jobs, outcomes) if o["shipped"]}
        for key in groups:
            if key in shipped:
                for path in draw_curves(args.agents_dir, args.curves_dir, args.reference, only=key):
                    print(path)
    else:
        for algo, env_id in groups:
            runs = [Path(o["run"]) for j, o in zip(jobs, outcomes) if (j.algo, j.env_id) == (algo, env_id)]
            runs = [r for r in runs if training.eval_curve(r)["success"]]
            if runs:
                title = f"{algo.upper()} on {env_id}: success of the periodic evaluation ({len(runs)} run(s))"
                print(training.learning_curves(runs, args.log_folder / "learning_curves" / f"{algo}_{env_id}.png",
                                               title, planner_reference(args.reference, env_id)))
    refused = [o for o in outcomes if o["refused"]]
    for o in refused:
        print(f"train_rl.py: error: {o['refused']}; the run stays in {o['run']} (ship it anyway: "
              f"python baselines/train_rl.py --ship {o['run']} --wall-time {o['wall']:.0f} --force)", file=sys.stderr)
    return 2 if refused else 0


@dataclass(frozen=True)
class Job:
    """One training run of the grid."""

    algo: str
    env_id: str
    seed: int


def train_and_ship(job: Job, log_folder: str, agents_dir: str | None, force: bool = False,
                   **kwargs: Any) -> dict[str, Any]:
    """Train ``job`` with rl_zoo3 (its own log folder per seed) and ship it if ``agents_dir``.

    Returns ``run`` (the zoo's run folder), ``wall`` [s], ``shipped`` (the agent's folder or
    None) and ``refused`` (why a shipped agent was not replaced, or None).
    """
    run, wall = training.train(job.algo, job.env_id, job.seed, Path(log_folder) / f"seed{job.seed}", **kwargs)
    print(f"  {job.algo} on {job.env_id}, seed {job.seed}: {run} in {wall:.0f} s", file=sys.stderr)
    out = {"run": str(run), "wall": wall, "shipped": None, "refused": None}
    if agents_dir is None:
        print(f"  to ship it: python baselines/train_rl.py --ship {run} --wall-time {wall:.0f}", file=sys.stderr)
    else:
        try:
            out["shipped"] = str(training.ship(run, agents_dir, wall, seed=job.seed, force=force))
        except training.ShipRefused as exc:
            out["refused"] = str(exc)
    return out


def run_jobs(jobs: list[Job], options: dict, backend: str, address: str | None, workers: int) -> list[dict[str, Any]]:
    """Every job, one after the other or as Ray tasks (a local Ray of ``workers`` CPUs without ``address``)."""
    print(f"{len(jobs)} training run(s) ({backend}): " + ", ".join(f"{j.algo}/{j.env_id}/{j.seed}" for j in jobs),
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


if __name__ == "__main__":
    sys.exit(main())
