"""Evaluate footstep policies (the reference planners and the trained agents) on the three envs over many seeds.

Usage::

    python baselines/eval_planner.py                 # quick default: all envs, planners and shipped agents, 3 seeds
    python baselines/eval_planner.py --paper         # the paper's protocol (door 8/14/17 deg/s, crossing, crowd; 20 seeds)
    python baselines/eval_planner.py --profile agents   # agents against both planners (docs/results.md)
    python baselines/eval_planner.py --ablation         # period-aware with each of our additions off in turn
    python baselines/eval_planner.py --env door --door-speed 8 --door-speed 17 --policy period-aware \\
        --policy ppo --episodes 10 --split validation --out runs/door --workers 2
    python baselines/eval_planner.py --env crowd --crowd-speed 0.2 --agent runs/rl/ppo/FootstepCrowd-v0_1
    python baselines/eval_planner.py --benchmark --policy period-aware --out runs/bench   # one leaderboard row
    python baselines/eval_planner.py --benchmark --policy my_walker:Walker --out runs/bench/walker   # your own
    python baselines/eval_planner.py --benchmark --agent door=door.zip --agent crossing=crossing.zip \
        --agent crowd=crowd.zip --algo ppo --name mine --out runs/bench/mine   # plain SB3 models, one per scene

The sweep flags (``--door-speed``, ``--crowd-speed``) are the scenarios' ``sweep_axes``
(``footstep_gym.scenarios``): a scenario's key ``door_speed`` is ``--door-speed``, one cell per
value; a scene without a sweep runs at its YAML's values.

Each cell (env, setting, policy; for an agent, each training run) runs ``--episodes``
episodes with the seeds of ``--split`` (disjoint ranges in ``configs/eval.yaml``: train,
train and validation, default validation; the test split is the board's, run only by
``--benchmark --release``; the committed protocol-2 results came from its test split), starting ``--seed`` seeds into it.
Each episode seeds the env and the policy with its seed, so results do not depend on
``--workers`` or ``--backend``. Every setting is checked before anything runs (a bad value
is one error line, exit status 2). The script prints a markdown table and writes to ``--out``
(a folder of its own: an earlier run's files there are replaced, a folder holding anything
else is refused). The run writes into a temporary folder beside ``--out`` and moves into
place only once it has finished: a run that fails or is interrupted leaves ``--out`` as it was.

* ``results.json``: one record per cell summarised over training runs, and ``runs/results.json``
  one per training run (fields in ``footstep_gym.evaluation.records``); ``results.csv`` likewise;
* ``episodes.csv``: one row per episode (outcome, steps, time, path, clearance, ZMP margin, act time);
* ``figures/<setting>.png``: the policies side by side on one seed (footprints, CoM path,
  obstacles at several instants, per-step period and stride), like the paper's Fig. 8-10;
* ``tables/<setting>_<policy>_seed<s>.md``: that episode's commands as in Tables 2 and 4;
* ``videos/<setting>_<policy>.mp4`` with ``--video``: one episode per policy and setting, in real time
  (in file names a user's agent ``agent:NAME`` is ``agent-NAME``);
* ``summary.md`` (the table, definitions, the paper's numbers, the files) and ``run.json``.

``--benchmark`` runs one policy (``--policy NAME``, a policy of one's own ``--policy module:attr``, or
``--agent [SCENE=]PATH`` repeated over the training runs of one method, named with ``--name``) on every
cell of every tier of every scene
(``footstep_gym.evaluation.benchmark``; docs/benchmark.md) with the first ``--episodes`` seeds of
the validation split (100, a leaderboard row's number; ``--release``: of the test split, the board's row, from
committed code and logged in the access log), and writes ``benchmark.json`` (the protocol, one record per
scene x tier x cell x training run, the records over runs, per tier the IQM with its
stratified-bootstrap interval over runs), ``benchmark.md`` (the leaderboard row and every cell),
``episodes.csv`` and ``run.json``, with the same checks and the same temporary folder as above.
``--env`` and ``--tier`` restrict it to some scenes or tiers: a partial run, no leaderboard row.
A method trained on one tier's cells (the in-distribution track: ``--trained-on-tier TIER``, or a shipped
agent registered with its tier) runs on that tier only; its row is the in-distribution table's.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable, NoReturn, Sequence

from footstep_gym import registry
from footstep_gym.rl.registry import AGENTS_DIR_ENV_VAR, default_agents_dir
from footstep_gym.evaluation import benchmark
from footstep_gym.evaluation.benchmark import BenchmarkSettings, run_benchmark
from footstep_gym.evaluation.outfolder import check_out, run_into
from footstep_gym.evaluation.outputs import record_videos, write_outputs
from footstep_gym.evaluation.profiles import (PROFILES, OptionError, Settings, check_cells, describe_cells,
                                             describe_sweep, evaluation_settings, flag_of, make_cells, sweep_axes)
from footstep_gym.evaluation.runner import BACKENDS, Task, run_tasks
from footstep_gym.evaluation.splits import SPLITS
from footstep_gym.evaluation.tables import plural
from footstep_gym.scenarios import SCENARIOS


# ---------------------------------------------------------------- command line
def _int_at_least(minimum: int) -> Callable[[str], int]:
    """An argparse type: a whole number >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, got {text!r}") from None
        if v < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {v}")
        return v

    return parse


def _sweep_value(scene: str, key: str, unit: str) -> Callable[[str], float]:
    """An argparse type: a finite number in ``unit``, >= 0 (> 0) where the config field of ``key`` is
    nonnegative (positive); the env checks the rest (e.g. ``max_*`` bounds) before anything runs."""
    check = SCENARIOS[scene].Config.__dataclass_fields__[key].metadata.get("check")
    least = {"nonnegative": ">= 0", "positive": "> 0", "fraction": "> 0"}.get(check or "")

    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number in {unit}, got {text!r}") from None
        if not math.isfinite(v) or (least == ">= 0" and v < 0) or (least == "> 0" and v <= 0):
            raise argparse.ArgumentTypeError(f"must be a finite number{' ' + least if least else ''} {unit}, "
                                             f"got {text!r}")
        return v

    return parse


def build_parser() -> argparse.ArgumentParser:
    quick, paper = PROFILES["quick"], PROFILES["paper"]
    names = registry.policy_names()
    width = max(len(n) for n in names)
    listing = "\n".join(f"  {n:<{width}}  {registry.resolve(n).description}" for n in names)
    parser = argparse.ArgumentParser(
        prog="eval_planner.py", description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=f"policies (--policy):\n{listing}\n  <planner>-no-<switch>  a planner with one addition of "
               f"configs/planner.yaml off (the ablation's variants)\n  module:attr  a policy of your own: a "
               f"footstep_gym.policy.Policy subclass built as attr(robot, seed), or a factory returning one"
               f"\n\nWithout options: the quick default (all envs, every policy, "
               f"{quick.episodes} seeds of the validation split"
               + "".join(f", {describe_sweep(quick, e)}" for e in quick.envs if describe_sweep(quick, e) != e)
               + "). An agent with no run shipped for an env is skipped there with a warning.",
    )
    parser.add_argument("--env", action="append", metavar="ENV",
                        help=f"{', '.join(SCENARIOS)} or a full id ({next(iter(SCENARIOS.values())).env_id}); "
                             "repeatable; default: all")
    parser.add_argument("--policy", action="append", metavar="NAME",
                        help="a policy listed below, or one of your own as module:attr; repeatable")
    parser.add_argument("--agent", action="append", metavar="[SCENE=]PATH",
                        help="your own agent: a zoo run folder (.../ppo/FootstepDoor-v0_1) or a stable-baselines3 / "
                             "sbx model .zip; SCENE=PATH (door=..., crossing=..., crowd=...) for an agent of that "
                             "scene only (a zoo run of one scene's env is that scene's); repeatable (one per training "
                             "run and scene)")
    parser.add_argument("--algo", metavar="ALGO",
                        help="with --agent: the algorithm of a .zip without the zoo's args.yml (ppo, sac, td3, a2c, "
                             "ddpg, sac_sbx, td3_sbx, ppo_lstm)")
    parser.add_argument("--vecnormalize", action="append", metavar="FILE",
                        help="with --agent: its VecNormalize statistics (.pkl) where they are not the zoo's; one per "
                             "--agent, in their order")
    parser.add_argument("--agents-dir", type=Path, metavar="DIR",
                        help=f"where the shipped agents are (default ${AGENTS_DIR_ENV_VAR}, else ./baselines/agents "
                             f"in the working directory, else the checkout's: {default_agents_dir()})")
    parser.add_argument("--profile", choices=sorted(PROFILES), help="defaults of a run (default quick)")
    parser.add_argument("--paper", action="store_true", help="same as --profile paper: "
                        f"{', '.join(describe_sweep(paper, e) for e in paper.envs)}, {paper.episodes} seeds, planners only")
    parser.add_argument("--ablation", action="store_true",
                        help="same as --profile ablation: period-aware with each addition of configs/planner.yaml "
                             "switched off in turn (period-aware-no-<switch>), and paper-period-aware")
    parser.add_argument("--episodes", type=_int_at_least(1), metavar="N", help="seeds per cell (default: profile's)")
    parser.add_argument("--split", choices=sorted(SPLITS), default="validation",
                        help="seed range (configs/eval.yaml): " + ", ".join(
                            f"{k} {a}-{b - 1}" for k, (a, b) in SPLITS.items()) + " (default validation; the test "
                            "split is the board's: --benchmark --release only)")
    parser.add_argument("--seed", type=_int_at_least(0), default=0, metavar="K",
                        help="start K seeds into the split (default 0)")
    for key, owners in sweep_axes().items():  # one flag per sweep axis of the scenarios (--door-speed, ...)
        scene, unit = owners[0]
        envs = " and ".join(s for s, _ in owners)
        parser.add_argument(flag_of(key), dest=key, type=_sweep_value(scene, key, unit), action="append",
                            metavar=re.sub(r"[^A-Z0-9]+", "_", unit.upper()).strip("_") or "VALUE",
                            help=f"{key.replace('_', ' ')} of the {envs} env in {unit}; repeatable, one cell per value")
    parser.add_argument("--out", type=Path, default=Path("runs/eval"), help="output folder (default runs/eval)")
    parser.add_argument("--workers", type=_int_at_least(1), metavar="N",
                        help="episodes run in parallel (default: all cores); results do not depend on it")
    parser.add_argument("--backend", choices=BACKENDS, default="local",
                        help="local worker processes (default) or Ray tasks")
    parser.add_argument("--ray-address", metavar="ADDR",
                        help="an existing Ray cluster (with --backend ray); default: a local Ray for this run")
    parser.add_argument("--no-figures", action="store_true", help="skip the figures and command tables")
    parser.add_argument("--video", action="store_true",
                        help="record one episode per policy and setting (the split's first seed) as mp4, in real time")
    bench = parser.add_argument_group(
        "benchmark", "--benchmark: one policy on every tier of every scene, one leaderboard row (docs/benchmark.md)")
    bench.add_argument("--benchmark", action="store_true",
                       help=f"run the benchmark: --policy NAME (or --agent PATH per training run), --episodes N "
                            f"(default {benchmark.EPISODES}) seeds of the validation split per cell (--release: of "
                            "the test split); writes benchmark.json and benchmark.md")
    bench.add_argument("--release", action="store_true",
                       help="with --benchmark: the board's row, on the test split: every cell, committed code only, "
                            "logged in baselines/results/access_log.csv before the first episode (docs/benchmark.md §6)")
    bench.add_argument("--tier", action="append", metavar="TIER",
                       help="with --benchmark: only this tier of configs/benchmark.yaml (paper, train, shifted, "
                            "structure, noise); repeatable; a partial run (so is --env)")
    bench.add_argument("--trained-on-tier", metavar="TIER",
                       help="with --benchmark: the method trained on this tier's cells (train-split seeds), the "
                            "in-distribution track: it is tested on that tier only (structure, noise, ...; a "
                            "shipped agent registered with a tier, such as ppo-structure, needs no option)")
    bench.add_argument("--name", metavar="LABEL",
                       help="with --benchmark --agent: the method's name in the tables (agent:LABEL; default the "
                            "first run's folder name)")
    return parser


#: Options of an evaluation that do not go with --benchmark (its cells, seeds and outputs are the protocol's).
_NOT_WITH_BENCHMARK = (("--paper", "paper"), ("--ablation", "ablation"), ("--profile", "profile"),
                       ("--video", "video"), ("--no-figures", "no_figures"))


def parse_settings(argv: Sequence[str] | None = None) -> Settings | BenchmarkSettings:
    """Parse and validate the command line; exits with status 2 and a message on a bad value."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.benchmark:
            clash = [flag for flag, dest in _NOT_WITH_BENCHMARK if getattr(args, dest)]
            clash += [flag_of(key) for key in sweep_axes() if getattr(args, key)]
            if args.split != benchmark.SPLIT:
                clash.append(f"--split {args.split}")
            if args.seed:
                clash.append("--seed")
            if clash:
                parser.error(f"--benchmark runs the protocol's cells and seeds: {', '.join(clash)} "
                             f"{'does' if len(clash) == 1 else 'do'} not apply")
            return benchmark.benchmark_settings(
                policies=args.policy, agents=args.agent, name=args.name, episodes=args.episodes,
                envs=args.env, tiers=args.tier, out=args.out, workers=args.workers, backend=args.backend,
                ray_address=args.ray_address, agents_dir=args.agents_dir, algo=args.algo,
                vecnormalize=args.vecnormalize, trained_on_tier=args.trained_on_tier, release=args.release)
        given = [flag for flag, value in (("--tier", args.tier), ("--name", args.name),
                                          ("--trained-on-tier", args.trained_on_tier),
                                          ("--release", args.release)) if value]
        if given:
            parser.error(f"{', '.join(given)} {'goes' if len(given) == 1 else 'go'} with --benchmark only")
        chosen = {name for flag, name in ((args.paper, "paper"), (args.ablation, "ablation")) if flag}
        if args.profile:
            chosen.add(args.profile)
        if len(chosen) > 1:
            parser.error(f"choose one profile, got {', '.join(sorted(chosen))}")
        return evaluation_settings(
            chosen.pop() if chosen else "quick", envs=args.env, policies=args.policy, agents=args.agent,
            agents_dir=args.agents_dir, episodes=args.episodes, split=args.split, offset=args.seed,
            sweeps={key: getattr(args, key) for key in sweep_axes()}, out=args.out, workers=args.workers,
            backend=args.backend, ray_address=args.ray_address, figures=not args.no_figures, video=args.video,
            algo=args.algo, vecnormalize=args.vecnormalize)
    except OptionError as exc:
        parser.error(str(exc))


def refuse(problem: str) -> NoReturn:
    """One usage-error line on stderr, exit status 2; nothing written."""
    build_parser().error(problem)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    settings = parse_settings(argv)
    if isinstance(settings, BenchmarkSettings):
        return run_benchmark(settings, argv, refuse)
    cells = make_cells(settings)
    if not cells:
        print("error: nothing to evaluate (no policy has a cell on these envs)", file=sys.stderr)
        return 2
    problem = check_cells(cells) or check_out(settings.out)
    if problem:
        refuse(problem)
    tasks = [Task(i, c, s, record=settings.figures) for i, c in enumerate(cells) for s in settings.seeds]
    workers = max(1, min(settings.workers, len(tasks)))
    print(f"{describe_cells(cells)} x {plural(settings.episodes, 'seed')} = {plural(len(tasks), 'episode')} on "
          f"{workers} worker(s) ({settings.backend}) -> {settings.out}", file=sys.stderr)

    def work(folder: Path) -> tuple[str, list[Path], str]:
        t0 = time.perf_counter()
        results = run_tasks(tasks, workers, backend=settings.backend, address=settings.ray_address)
        wall = time.perf_counter() - t0
        inside = replace(settings, out=folder)  # the files go to the run's own folder until it has finished
        videos = record_videos(inside, cells) if settings.video else []
        table, files = write_outputs(inside, cells, results, wall, argv, videos)
        return table, files, f"{len(results)} episodes in {wall:.1f} s"

    return run_into(settings.out, "the evaluation", "summary.md lists them", work)


if __name__ == "__main__":
    sys.exit(main())
