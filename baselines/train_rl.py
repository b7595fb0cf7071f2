"""Train the RL baselines with rl_zoo3, several seeds in a row; ship them with a manifest and learning curves.

Usage::

    python baselines/train_rl.py --agent ppo-wide --seeds 1 2 3                   # a shipped agent, as it was shipped
    python baselines/train_rl.py --agent ppo sac td3 --env door --seeds 4 --ship  # more seeds of shipped agents
    python baselines/train_rl.py --algo ppo --env door --seeds 1 --timesteps 8192   # a first, short try: runs/rl/
    python baselines/train_rl.py --algo ppo --env door --seeds 1 2 3 --ship       # train, ship, redraw the curves
    python baselines/train_rl.py --algo ppo --env all --seeds 1 --ship            # ppo-all: FootstepMix-v0
    python baselines/train_rl.py --algo ppo sac --env door crowd --seeds 1 2 3 --backend ray   # a grid as Ray tasks
    python baselines/train_rl.py --algo sac --env door --seeds 1 --timesteps 20000 --eval-freq 5000
    python baselines/train_rl.py --algo sac_sbx td3_sbx --env door --seeds 1 --eval-freq 10000 --eval-like-training
    python baselines/train_rl.py --ship runs/rl/seed1/ppo/FootstepDoor-v0_1 --wall-time 1500   # ship a finished run
    python baselines/train_rl.py --ship runs/rl-fixed/seed1/ppo/FootstepDoor-v0_1 --wall-time 267 \\
        --agent ppo-fixed-period                                         # ... as a registered agent of its own
    python baselines/train_rl.py --curves                                # learning curves (per agent, per scene), cost
    python baselines/train_rl.py --throughput                            # PPO env steps/s with 1 and 2 envs

``--agent NAME`` trains a shipped agent (``footstep_gym.rl.registry.AGENTS``) with the config it was
shipped from (``configs/rl/<config>.yml``), its evaluation options, on the envs it was shipped for
(``--env`` to choose some) and ships it, with ``--ship``, into its own folder; ``--algo NAME`` trains
``configs/rl/<algo>.yml`` (``sac`` is stable-baselines3's SAC, the straw man ``sac-sb3``; the shipped
``sac`` is ``--agent sac``, sbx's).

Each seed is one ``python -m rl_zoo3.train`` run (hyperparameters: ``configs/rl/<algo>.yml``,
one torch thread) into ``--log-folder`` (default ``runs/rl``: ``seed<S>/<algo>/<EnvId>_<k>/``, for an
agent ``<agent>/seed<S>/<algo>/<EnvId>_<k>/``, and the zoo's output in ``seed<S>/<algo>_<EnvId>_<S>.log``);
the console shows a progress
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
from pathlib import Path
from typing import Sequence

import footstep_gym
from footstep_gym.rl import report, training
from footstep_gym.rl.jobs import (agent_grid, draw_curves, draw_run_curves, draw_shipped_curves, grid, run_jobs,
                                  shipped_longer, throughput_table)
from footstep_gym.rl.registry import AGENTS

REPO = Path(__file__).resolve().parent.parent
DEFAULT_AGENTS = REPO / "baselines" / "agents"
DEFAULT_CURVES = REPO / "baselines" / "results" / "learning_curves"
DEFAULT_REFERENCE = REPO / "baselines" / "results" / "agents" / "results.json"


def env_id_of(name: str) -> str:
    """A scene name (``door``), ``all`` (the mix) or an env id -> the env id (``footstep_gym.resolve_env_id``)."""
    try:
        return footstep_gym.resolve_env_id(name, mix=True)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def seed_value(text: str) -> int:
    """A training seed: a whole number >= 0 (the zoo draws a random seed for a negative one)."""
    try:
        seed = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a training seed is a whole number >= 0, got {text!r}") from None
    if seed < 0:
        raise argparse.ArgumentTypeError(f"a training seed is a whole number >= 0, got {seed} (rl_zoo3 would draw a "
                                         "random seed for it)")
    return seed


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="train_rl.py", description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--ship", nargs="?", const=True, type=Path, metavar="RUN",
                      help="with training: ship each run to --agents-dir and redraw its learning curves "
                           "(without it, runs stay in --log-folder); with RUN: ship that finished zoo run "
                           "folder instead of training (needs --wall-time)")
    mode.add_argument("--curves", action="store_true", help="only draw the learning curves of the shipped agents (one per agent and env, "
                           "one per env with every agent: scene_<EnvId>.png) and write their training cost "
                           "(training_cost.md)")
    mode.add_argument("--throughput", action="store_true",
                      help="measure PPO's env steps/s inside learn() with 1 and 2 envs on each env, CartPole-v1 "
                           "as the ceiling; prints a markdown table (a measurement: run it on an idle machine)")
    parser.add_argument("--agent", nargs="+", metavar="NAME",
                        help="shipped agent(s) to train, each with the config it was shipped from and on the envs it "
                             f"was shipped for (--env: some of them): {', '.join(AGENTS)}; with --ship RUN: the "
                             "registered agent the run ships as, in its folder under --agents-dir")
    parser.add_argument("--algo", choices=("ppo", "sac", "sac_sbx", "td3_sbx"), nargs="+",
                        help="algorithm(s) whose config configs/rl/<algo>.yml to train (sac: stable-baselines3's SAC, "
                             "the straw man sac-sb3; the shipped sac and td3 are sbx's: --agent sac, --agent td3); "
                             "several make a grid with --env and --seeds")
    parser.add_argument("--env", type=env_id_of, nargs="+",
                        help="door, crossing, crowd, all (FootstepMix-v0) or an env id; several make a grid")
    parser.add_argument("--seeds", type=seed_value, nargs="+", default=[1], metavar="S",
                        help="training seeds, whole numbers >= 0 (default 1)")
    parser.add_argument("--timesteps", type=int, metavar="N",
                        help="env steps per run (default: the config's n_timesteps, e.g. 600000 for PPO on the door)")
    parser.add_argument("--eval-freq", type=int, metavar="N",
                        help="env steps (all envs together) between the zoo's evaluations (default 25000; an --agent's "
                             "own as shipped); a run shorter than this is evaluated once, at its end")
    parser.add_argument("--eval-episodes", type=int, default=20, metavar="N", help="episodes per evaluation")
    parser.add_argument("--eval-like-training", action="store_true",
                        help="the zoo's evaluation env gets the config's env_kwargs (--eval-env-kwargs; without it "
                             "the zoo evaluates on the env's defaults)")
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
    for name in args.agent or ():
        if name not in AGENTS:
            parser.error(f"--agent {name}: unknown agent; registered: {', '.join(AGENTS)}")
    if isinstance(args.ship, Path) and args.agent and len(args.agent) > 1:
        parser.error("--ship RUN ships one run: give one --agent")
    agent = args.agent[0] if isinstance(args.ship, Path) and args.agent else None
    if args.curves:
        for path in draw_curves(args.agents_dir, args.curves_dir, args.reference):
            print(path)
        for path in report.scene_curves(args.agents_dir, args.curves_dir):
            print(path)
        cost = args.curves_dir / "training_cost.md"
        cost.write_text("# What training the shipped agents cost\n\n" + report.cost_table(args.agents_dir) + "\n\n"
                        "Medians over each agent's training seeds, from their manifests (`baselines/agents/`); wall "
                        "time on two shared cores, start-up and periodic evaluations included.\n", encoding="utf-8")
        print(cost)
        return 0
    if args.throughput:
        print(throughput_table(args.timesteps or 8192))
        return 0
    if isinstance(args.ship, Path):
        if args.wall_time is None or args.wall_time <= 0:
            parser.error("--ship RUN needs --wall-time S (> 0): the run's measured wall time")
        folder = AGENTS[agent].folder if agent else None
        try:
            dest = training.ship(args.ship, args.agents_dir, args.wall_time, force=args.force, agent=folder)
        except training.ShipRefused as exc:
            return refuse(str(exc))
        print(dest)
        manifest = json.loads((dest / "manifest.json").read_text(encoding="utf-8"))
        if agent and manifest["algorithm"] != AGENTS[agent].algo:
            print(f"train_rl.py: warning: {agent} is registered as {AGENTS[agent].algo}, the run is "
                  f"{manifest['algorithm']}", file=sys.stderr)
        for path in draw_curves(args.agents_dir, args.curves_dir, args.reference,
                                only=(dest.parent.name, manifest["env_id"])):
            print(path)
        return 0
    ship = args.ship is True
    if ship and args.no_ship:
        parser.error("--ship and --no-ship contradict each other")
    if bool(args.algo) == bool(args.agent):
        parser.error("training needs --agent NAME (a shipped agent) or --algo NAME with --env, not both "
                     "(or use --ship RUN / --curves / --throughput)")
    if args.algo and not args.env:
        parser.error("--algo needs --env")
    if len(set(args.seeds)) != len(args.seeds):
        parser.error(f"--seeds: a seed given twice ({' '.join(map(str, args.seeds))})")
    if args.timesteps is not None and args.timesteps < 1:
        parser.error("--timesteps must be >= 1")
    if args.eval_freq is not None and args.eval_freq < 1:
        parser.error("--eval-freq must be >= 1")
    if args.ray_address and args.backend != "ray":
        parser.error("--ray-address needs --backend ray")
    try:
        jobs = agent_grid(args.agent, args.env, args.seeds) if args.agent else grid(args.algo, args.env, args.seeds)
    except KeyError as exc:
        parser.error(str(exc.args[0]))
    except ValueError as exc:
        parser.error(str(exc))
    if ship and not args.force:  # a shorter run cannot replace a shipped agent: say so before training
        problem = shipped_longer(jobs, args.agents_dir, args.timesteps)
        if problem:
            return refuse(problem)
    print(f"runs and logs go to {args.log_folder}; " + (f"shipping to {args.agents_dir}" if ship else
          "nothing is shipped (--ship copies the runs to the agents the evaluation uses)"), file=sys.stderr)
    options = dict(log_folder=str(args.log_folder), agents_dir=str(args.agents_dir) if ship else None,
                   force=args.force, timesteps=args.timesteps, eval_episodes=args.eval_episodes,
                   progress=None if args.backend == "local" else False)
    if args.eval_freq is not None:
        options["eval_freq"] = args.eval_freq
    if args.eval_like_training:
        options["eval_env_kwargs"] = "training"
    outcomes = run_jobs(jobs, options, args.backend, args.ray_address, args.workers)
    for path in (draw_shipped_curves(jobs, outcomes, args.agents_dir, args.curves_dir, args.reference) if ship
                 else draw_run_curves(jobs, outcomes, args.log_folder, args.reference)):
        print(path)
    refused = [o for o in outcomes if o["refused"]]
    for o in refused:
        print(f"train_rl.py: error: {o['refused']}; the run stays in {o['run']} (ship it anyway: "
              f"python baselines/train_rl.py --ship {o['run']} --wall-time {o['wall']:.0f} --force)", file=sys.stderr)
    return 2 if refused else 0


if __name__ == "__main__":
    sys.exit(main())
