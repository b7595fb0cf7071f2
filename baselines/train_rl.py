"""Train the RL baselines with rl_zoo3, several seeds in a row, and ship them with a manifest and learning curves.

Usage::

    python baselines/train_rl.py --algo ppo --env door --seeds 1 2 3     # train, ship, plot
    python baselines/train_rl.py --algo ppo --env all --seeds 1          # ppo-all: FootstepMix-v0
    python baselines/train_rl.py --algo ppo sac --env door crowd --seeds 1 2 3 --backend ray   # a grid as Ray tasks
    python baselines/train_rl.py --algo sac --env door --seeds 1 --timesteps 20000
    python baselines/train_rl.py --ship runs/rl/ppo/FootstepDoor-v0_1 --wall-time 1500   # ship a finished zoo run
    python baselines/train_rl.py --curves                                # learning curves of every shipped agent
    python baselines/train_rl.py --throughput                            # PPO env steps/s with 1 and 2 envs

Each seed is one ``python -m rl_zoo3.train`` run (hyperparameters: ``configs/rl/<algo>.yml``,
one torch thread) into ``--log-folder``; the run's small files are then copied to
``--agents-dir/<algo>/<EnvId>_<seed>/`` in the zoo's layout with a ``manifest.json`` (wall
time, env steps per second), and the learning curves (the zoo's periodic deterministic
evaluation, success from ``info["is_success"]``) are drawn to
``baselines/results/learning_curves/<algo>_<EnvId>.png`` with the planners' success on the
same env as reference lines when an evaluation's ``results.json`` is given or shipped.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import footstep_gym
from footstep_gym import training

REPO = Path(__file__).resolve().parent.parent
DEFAULT_AGENTS = REPO / "baselines" / "agents"
DEFAULT_CURVES = REPO / "baselines" / "results" / "learning_curves"
DEFAULT_REFERENCE = REPO / "baselines" / "results" / "agents" / "results.json"
REFERENCE_PLANNERS = ("period-aware", "fixed-period")


def env_id_of(name: str) -> str:
    """``door``/``crossing``/``crowd``/``all`` or a registered id -> the env id."""
    key = name.strip().lower()
    if key in footstep_gym.ENV_IDS:
        return footstep_gym.ENV_IDS[key]
    if key in ("all", "mix"):
        return footstep_gym.MIX_ENV_ID
    for env_id in (*footstep_gym.ENV_IDS.values(), footstep_gym.MIX_ENV_ID):
        if key == env_id.lower():
            return env_id
    raise argparse.ArgumentTypeError(f"unknown env {name!r}; choose door, crossing, crowd, all or an env id")


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
    """One learning-curve PNG per (algo, env) of the shipped agents."""
    groups: dict[tuple[str, str], list[Path]] = {}
    for manifest in sorted(agents_dir.glob("*/*/manifest.json")):
        m = json.loads(manifest.read_text(encoding="utf-8"))
        groups.setdefault((m["algorithm"], m["env_id"]), []).append(manifest.parent)
    written = []
    for (algo, env_id), runs in sorted(groups.items()):
        if only is not None and (algo, env_id) != only:
            continue
        runs = [r for r in runs if training.eval_curve(r)["success"]]
        if not runs:
            print(f"no evaluation recorded for {algo} on {env_id} (training shorter than --eval-freq): no curve",
                  file=sys.stderr)
            continue
        title = f"{algo.upper()} on {env_id}: success of the periodic evaluation ({len(runs)} training seed(s))"
        written.append(training.learning_curves(runs, out_dir / f"{algo}_{env_id}.png", title,
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
    mode.add_argument("--ship", type=Path, metavar="RUN", help="ship a finished zoo run folder instead of training")
    mode.add_argument("--curves", action="store_true", help="only draw the learning curves of the shipped agents")
    mode.add_argument("--throughput", action="store_true",
                      help="measure PPO's env steps/s inside learn() with 1 and 2 envs on each env, CartPole-v1 "
                           "as the ceiling; prints a markdown table (a measurement: run it on an idle machine)")
    parser.add_argument("--algo", choices=("ppo", "sac"), nargs="+",
                        help="algorithm(s) (configs/rl/<algo>.yml); several make a grid with --env and --seeds")
    parser.add_argument("--env", type=env_id_of, nargs="+",
                        help="door, crossing, crowd, all (FootstepMix-v0) or an env id; several make a grid")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1], metavar="S", help="training seeds (default 1)")
    parser.add_argument("--timesteps", type=int, metavar="N", help="override the config's n_timesteps")
    parser.add_argument("--eval-freq", type=int, default=25_000, metavar="N",
                        help="env steps between the zoo's evaluations (default 25000)")
    parser.add_argument("--eval-episodes", type=int, default=20, metavar="N", help="episodes per evaluation")
    parser.add_argument("--log-folder", type=Path, default=REPO / "runs" / "rl", help="the zoo's log folder")
    parser.add_argument("--agents-dir", type=Path, default=DEFAULT_AGENTS, help="where agents ship")
    parser.add_argument("--curves-dir", type=Path, default=DEFAULT_CURVES, help="where learning curves go")
    parser.add_argument("--reference", type=Path, default=DEFAULT_REFERENCE,
                        help="an evaluation's results.json for the planners' reference lines")
    parser.add_argument("--wall-time", type=float, metavar="S", help="with --ship: the run's measured wall time [s]")
    parser.add_argument("--no-ship", action="store_true", help="train only; leave the runs in --log-folder")
    parser.add_argument("--backend", choices=("local", "ray"), default="local",
                        help="local: the runs one after the other; ray: each run a Ray task (one CPU)")
    parser.add_argument("--ray-address", metavar="ADDR", help="an existing Ray cluster (default: a local Ray)")
    parser.add_argument("--workers", type=int, default=2, metavar="N", help="CPUs of a local Ray (default 2)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.curves:
        for path in draw_curves(args.agents_dir, args.curves_dir, args.reference):
            print(path)
        return 0
    if args.throughput:
        print(throughput_table(args.timesteps or 8192))
        return 0
    if args.ship is not None:
        if args.wall_time is None or args.wall_time <= 0:
            parser.error("--ship needs --wall-time S (> 0): the run's measured wall time")
        dest = training.ship(args.ship, args.agents_dir, args.wall_time)
        print(dest)
        return 0
    if not args.algo or not args.env:
        parser.error("training needs --algo and --env (or use --ship / --curves / --throughput)")
    if args.timesteps is not None and args.timesteps < 1:
        parser.error("--timesteps must be >= 1")
    if args.ray_address and args.backend != "ray":
        parser.error("--ray-address needs --backend ray")
    for algo in args.algo:
        for env_id in args.env:
            try:
                training._zoo_entry(algo, env_id)
            except KeyError as exc:
                parser.error(str(exc.args[0]))
    jobs = [Job(algo, env_id, seed) for algo in args.algo for env_id in args.env for seed in args.seeds]
    options = dict(log_folder=str(args.log_folder), agents_dir=None if args.no_ship else str(args.agents_dir),
                   timesteps=args.timesteps, eval_freq=args.eval_freq, eval_episodes=args.eval_episodes)
    shipped = run_jobs(jobs, options, args.backend, args.ray_address, args.workers)
    if shipped:
        for algo, env_id in dict.fromkeys((j.algo, j.env_id) for j in jobs):
            for path in draw_curves(args.agents_dir, args.curves_dir, args.reference, only=(algo, env_id)):
                print(path)
    return 0


@dataclass(frozen=True)
class Job:
    """One training run of the grid."""

    algo: str
    env_id: str
    seed: int


def train_and_ship(job: Job, log_folder: str, agents_dir: str | None, **kwargs: int | None) -> str:
    """Train ``job`` with rl_zoo3 (its own log folder per seed) and ship it; the run's folder."""
    run, wall = training.train(job.algo, job.env_id, job.seed, Path(log_folder) / f"seed{job.seed}", **kwargs)
    print(f"  {job.algo} on {job.env_id}, seed {job.seed}: {run} in {wall:.0f} s", file=sys.stderr)
    if agents_dir is None:
        return str(run)
    return str(training.ship(run, agents_dir, wall, seed=job.seed))


def run_jobs(jobs: list[Job], options: dict, backend: str, address: str | None, workers: int) -> list[str]:
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
