"""Evaluate footstep policies (the reference planners and the trained agents) on the three envs over many seeds.

Usage::

    python baselines/eval_planner.py                 # quick default: all envs, planners and shipped agents, 3 seeds
    python baselines/eval_planner.py --paper         # the paper's protocol (door 8/14/17 deg/s, crossing, crowd; 20 seeds)
    python baselines/eval_planner.py --profile agents   # agents against both planners on every setting of the README
    python baselines/eval_planner.py --ablation         # period-aware with each of our additions off in turn
    python baselines/eval_planner.py --env door --door-speed 8 --door-speed 17 --policy period-aware \\
        --policy ppo --episodes 10 --split validation --out runs/door --workers 2
    python baselines/eval_planner.py --env crowd --crowd-speed 0.2 --agent runs/rl/ppo/FootstepCrowd-v0_1
    python baselines/eval_planner.py --benchmark --policy period-aware --out runs/bench   # one leaderboard row

The sweep flags (``--door-speed``, ``--crowd-speed``) are the scenarios' ``sweep_axes``
(``footstep_gym.scenarios``): a scenario's key ``door_speed`` is ``--door-speed``, one cell per
value; a scene without a sweep runs at its YAML's values.

Each cell (env, setting, policy; for an agent, each training run) runs ``--episodes``
episodes with the seeds of ``--split`` (disjoint ranges in ``configs/eval.yaml``: train,
validation, test; the README's tables come from test), starting ``--seed`` seeds into it.
Each episode seeds the env and the policy with its seed, so results do not depend on
``--workers`` or ``--backend``. Every setting is checked before anything runs (a bad value
is one error line, exit status 2). The script prints a markdown table and writes to ``--out``
(a folder of its own: an earlier run's files there are replaced, a folder holding anything
else is refused). The run writes into a temporary folder beside ``--out`` and moves into
place only once it has finished: a run that fails or is interrupted leaves ``--out`` as it was.

* ``results.json``: one record per cell summarised over training runs, and ``runs/results.json``
  one per training run (fields in ``footstep_gym.evaluation.stats``); ``results.csv`` likewise;
* ``episodes.csv``: one row per episode (outcome, steps, time, path, clearance, ZMP margin, act time);
* ``figures/<setting>.png``: the policies side by side on one seed (footprints, CoM path,
  obstacles at several instants, per-step period and stride), like the paper's Fig. 8-10;
* ``tables/<setting>_<policy>_seed<s>.md``: that episode's commands as in Tables 2 and 4;
* ``videos/<setting>_<policy>.mp4`` with ``--video``: one episode per policy and setting, in real time
  (in file names a user's agent ``agent:NAME`` is ``agent-NAME``);
* ``summary.md`` (the table, definitions, the paper's numbers, the files) and ``run.json``.

``--benchmark`` runs one policy (``--policy NAME``, or ``--agent PATH`` repeated over the training
runs of one method, named with ``--name``) on every cell of every tier of every scene
(``footstep_gym.evaluation.benchmark``; docs/benchmark.md) with the first ``--episodes`` seeds of
the test split (100; ``--full``: 500), and writes ``benchmark.json`` (the protocol, one record per
scene x tier x cell x training run, the records over runs, per tier the IQM with its
stratified-bootstrap interval over runs), ``benchmark.md`` (the leaderboard row and every cell),
``episodes.csv`` and ``run.json``, with the same checks and the same temporary folder as above.
``--env`` and ``--tier`` restrict it to some scenes or tiers: a partial run, no leaderboard row.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import platform
import re
import shlex
import shutil
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable, Sequence

import footstep_gym
from footstep_gym import policies as registry
from footstep_gym.evaluation import benchmark, report
from footstep_gym.evaluation.runner import (BACKENDS, WARMUP_ACTS, Cell, Task, record_video, run_tasks,
                                           safe_name)
from footstep_gym.evaluation.runner import check_cells as runner_check_cells
from footstep_gym.evaluation.splits import SPLITS, split_seeds
from footstep_gym.evaluation.stats import TIMING_FIELDS, EpisodeResult, cell_record, over_runs
from footstep_gym.scenarios import SCENARIOS, resolve_env_id, scene_of

SHOWCASE_POLICY = "period-aware"  # the figures show a seed this policy solved, when there is one


@dataclass(frozen=True)
class Profile:
    """Defaults of a run; options given on the command line override them."""

    envs: tuple[str, ...]
    episodes: int
    #: ``{scene: {key: values}}`` over the scenes' ``sweep_axes``: one cell per value (the product over a
    #: scene's keys); a key not given (or given no values) stays at the scenario's default.
    sweeps: dict[str, dict[str, tuple[float, ...]]]
    policies: tuple[str, ...] | None  # None: every registered policy


PROFILES = {
    # About a minute on two cores: every planner and every shipped agent, 3 seeds.
    "quick": Profile(envs=("door", "crossing", "crowd"), episodes=3, sweeps={"door": {"door_speed": (17.0,)}},
                     policies=None),
    # The paper's protocol: door at 8, 14, 17 deg/s, crossing, crowd; >= 20 seeds per cell.
    "paper": Profile(envs=("door", "crossing", "crowd"), episodes=20,
                     sweeps={"door": {"door_speed": (8.0, 14.0, 17.0)}},
                     policies=("period-aware", "fixed-period", "pso-only", "paper-period-aware",
                               "paper-fixed-period")),
    # period-aware with each addition switched off in turn, and the paper's planner with each switched on in turn
    # (filled in by --ablation: footstep_gym.planners.ablation_variants()).
    "ablation": Profile(envs=("door", "crossing", "crowd"), episodes=10, sweeps={"door": {"door_speed": (17.0,)}},
                        policies=()),
    # The agents against both planners on every setting the README reports.
    "agents": Profile(envs=("door", "crossing", "crowd"), episodes=20,
                      sweeps={"door": {"door_speed": (8.0, 11.0, 14.0, 17.0, 20.0)},
                              "crowd": {"crowd_speed": (0.16, 0.2)}},
                      policies=("period-aware", "fixed-period", "ppo", "ppo-all", "sac")),
}
OWN_FILES = ("results.json", "results.csv", "episodes.csv", "summary.md", "run.json", "benchmark.json", "benchmark.md")
OWN_DIRS = ("figures", "tables", "videos", "runs")


# ---------------------------------------------------------------- command line
def sweep_axes() -> dict[str, list[tuple[str, str]]]:
    """``{key: [(scene, unit), ...]}``: every registered scenario's ``sweep_axes``, each key with the scenes
    sweeping it (in ``SCENARIOS`` order). Each key is a flag: ``door_speed`` -> ``--door-speed``."""
    axes: dict[str, list[tuple[str, str]]] = {}
    for scene, cls in SCENARIOS.items():
        for key, unit in cls.sweep_axes.items():
            axes.setdefault(key, []).append((scene, unit))
    return axes


def flag_of(key: str) -> str:
    """The command-line flag of sweep key ``key`` (``door_speed`` -> ``--door-speed``)."""
    return "--" + key.replace("_", "-")


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


def _list(values: Sequence[float]) -> str:
    return ", ".join(f"{v:g}" for v in values) or "the scenario's default"


def _swept(profile: Profile, scene: str) -> str:
    """``door at 8, 14, 17 deg/s`` (``scene`` with the profile's sweep of it), or just ``scene``."""
    axes = {k: v for k, v in profile.sweeps.get(scene, {}).items() if v}
    units = SCENARIOS[scene].sweep_axes if scene in SCENARIOS else {}
    if len(axes) == 1:
        (key, values), = axes.items()
        return f"{scene} at {_list(values)} {units.get(key, '')}".rstrip()
    parts = [f"{key} {_list(values)} {units.get(key, '')}".rstrip() for key, values in axes.items()]
    return f"{scene} at {', '.join(parts)}" if parts else scene


def build_parser() -> argparse.ArgumentParser:
    quick, paper = PROFILES["quick"], PROFILES["paper"]
    names = registry.policy_names()
    width = max(len(n) for n in names)
    listing = "\n".join(f"  {n:<{width}}  {registry.describe(n)}" for n in names)
    parser = argparse.ArgumentParser(
        prog="eval_planner.py", description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=f"policies (--policy):\n{listing}\n  <planner>-no-<switch>  a planner with one addition of "
               f"configs/planner.yaml off (the ablation's variants)\n\nWithout options: the quick default (all envs, every policy, "
               f"{quick.episodes} seeds of the test split"
               + "".join(f", {_swept(quick, e)}" for e in quick.envs if _swept(quick, e) != e)
               + "). An agent with no run shipped for an env is skipped there with a warning.",
    )
    parser.add_argument("--env", action="append", metavar="ENV",
                        help=f"{', '.join(SCENARIOS)} or a full id ({next(iter(SCENARIOS.values())).env_id}); "
                             "repeatable; default: all")
    parser.add_argument("--policy", action="append", metavar="NAME", help="a policy listed below; repeatable")
    parser.add_argument("--agent", action="append", metavar="PATH", type=Path,
                        help="your own agent: a zoo run folder (.../ppo/FootstepDoor-v0_1) or a model .zip; "
                             "repeatable; evaluated on every env given")
    parser.add_argument("--agents-dir", type=Path, metavar="DIR",
                        help=f"where the shipped agents are (default ${registry.AGENTS_DIR_ENV_VAR}, else "
                             f"./baselines/agents in the working directory: {registry.default_agents_dir()})")
    parser.add_argument("--profile", choices=sorted(PROFILES), help="defaults of a run (default quick)")
    parser.add_argument("--paper", action="store_true", help="same as --profile paper: "
                        f"{', '.join(_swept(paper, e) for e in paper.envs)}, {paper.episodes} seeds, planners only")
    parser.add_argument("--ablation", action="store_true",
                        help="same as --profile ablation: period-aware with each addition of configs/planner.yaml "
                             "switched off in turn (period-aware-no-<switch>), and paper-period-aware")
    parser.add_argument("--episodes", type=_int_at_least(1), metavar="N", help="seeds per cell (default: profile's)")
    parser.add_argument("--split", choices=sorted(SPLITS), default="test",
                        help="seed range (configs/eval.yaml): " + ", ".join(
                            f"{k} {a}-{b - 1}" for k, (a, b) in SPLITS.items()) + " (default test)")
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
                            f"(default {benchmark.EPISODES}) seeds of the test split per cell; writes benchmark.json "
                            "and benchmark.md")
    bench.add_argument("--full", action="store_true",
                       help=f"with --benchmark: {benchmark.FULL_EPISODES} episodes per cell (the full protocol)")
    bench.add_argument("--tier", action="append", metavar="TIER",
                       help="with --benchmark: only this tier of configs/benchmark.yaml (paper, train, shifted, hard); "
                            "repeatable; a partial run (so is --env)")
    bench.add_argument("--name", metavar="LABEL",
                       help="with --benchmark --agent: the method's name in the tables (agent:LABEL; default the "
                            "first run's folder name)")
    return parser


@dataclass(frozen=True)
class Settings:
    profile: str
    envs: tuple[str, ...]
    policies: tuple[str, ...]
    agents: tuple[Path, ...]
    agents_dir: Path | None
    episodes: int
    split: str
    offset: int
    #: ``{scene: {key: values}}`` for every scenario with sweep axes (the flags', else the profile's values;
    #: ``()``: the scenario's default); :func:`make_cells` reads the scenes in ``envs``.
    sweeps: dict[str, dict[str, tuple[float, ...]]]
    out: Path
    workers: int
    backend: str
    ray_address: str | None
    figures: bool
    video: bool

    @property
    def seeds(self) -> list[int]:
        return split_seeds(self.split, self.episodes, self.offset)


def _unique(items: Sequence[Any]) -> tuple[Any, ...]:
    return tuple(dict.fromkeys(items))


def parse_settings(argv: Sequence[str] | None = None) -> Settings | BenchmarkSettings:
    """Parse and validate the command line; exits with status 2 and a message on a bad value."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.benchmark:
        return benchmark_settings(parser, args)
    given = [flag for flag, value in (("--full", args.full), ("--tier", args.tier), ("--name", args.name)) if value]
    if given:
        parser.error(f"{', '.join(given)} go(es) with --benchmark")
    chosen = {name for flag, name in ((args.paper, "paper"), (args.ablation, "ablation")) if flag}
    if args.profile:
        chosen.add(args.profile)
    if len(chosen) > 1:
        parser.error(f"choose one profile, got {', '.join(sorted(chosen))}")
    profile_name = chosen.pop() if chosen else "quick"
    profile = PROFILES[profile_name]
    try:
        envs = _unique([scene_of(resolve_env_id(e)) for e in (args.env or profile.envs)])
    except ValueError as exc:
        parser.error(str(exc))
    available = registry.policy_names()
    if args.policy:
        unknown = [p for p in args.policy if not registry.is_policy(p)]
        if unknown:
            parser.error(f"unknown policy {', '.join(map(repr, unknown))}; choose from {', '.join(available)}")
        policies = _unique(args.policy)
    elif args.agent:
        policies = ()  # only the user's agents
    elif profile_name == "ablation":
        from footstep_gym.planners.ablation import ablation_variants

        policies = ablation_variants()
    elif profile.policies is not None:
        policies = tuple(p for p in profile.policies if p in available)
    else:  # every registered policy but an upper bound (oracle), which runs only when named
        policies = tuple(p for p in available if not registry.reads_truth(p))
    for path in args.agent or ():
        if not path.exists():
            parser.error(f"--agent {path}: no such file or folder")
    axes = sweep_axes()
    for key, owners in axes.items():
        scenes = [s for s, _ in owners]
        if getattr(args, key) and not set(scenes) & set(envs):
            parser.error(f"{flag_of(key)} applies to the {' and '.join(scenes)} env only; "
                         f"add {' or '.join(f'--env {s}' for s in scenes)}")
    sweeps = {scene: {key: _unique(getattr(args, key) or profile.sweeps.get(scene, {}).get(key, ()))
                      for key in cls.sweep_axes} for scene, cls in SCENARIOS.items() if cls.sweep_axes}
    if args.ray_address and args.backend != "ray":
        parser.error("--ray-address needs --backend ray")
    episodes = args.episodes or profile.episodes
    try:
        split_seeds(args.split, episodes, args.seed)
    except ValueError as exc:
        parser.error(str(exc))
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return Settings(
        profile=profile_name, envs=envs, policies=policies, agents=tuple(p.resolve() for p in args.agent or ()),
        agents_dir=args.agents_dir, episodes=episodes, split=args.split, offset=args.seed,
        sweeps=sweeps, out=args.out,
        workers=args.workers or cores, backend=args.backend, ray_address=args.ray_address,
        figures=not args.no_figures, video=args.video,
    )


def make_cells(settings: Settings) -> list[Cell]:
    """Cells in a fixed order: envs, settings, policies as given; an agent once per training run.

    A scene's settings are the product of its sweep's values (``settings.sweeps[scene]``, keys in
    its ``sweep_axes`` order; a key without values stays at the default; no sweep: one setting).
    An agent with no run for an env is skipped there, said in one line on stderr.
    """
    cells = []
    missing: dict[str, list[str]] = {}
    for scenario in settings.envs:
        env_id = footstep_gym.ENV_IDS[scenario]
        axes = [(key, values) for key, values in settings.sweeps.get(scenario, {}).items() if values]
        variants = [tuple(zip([key for key, _ in axes], combo)) for combo in itertools.product(*(v for _, v in axes))]
        runs_of = {}
        for policy in settings.policies:
            if policy in registry.AGENTS:
                runs_of[policy] = registry.agent_runs(policy, env_id, settings.agents_dir)
                if not runs_of[policy]:
                    missing.setdefault(policy, []).append(env_id)
        for params in variants:
            for policy in settings.policies:
                if policy in registry.AGENTS:
                    cells += [Cell(env_id, scenario, policy, params, run=str(r)) for r in runs_of[policy]]
                else:
                    cells.append(Cell(env_id=env_id, scenario=scenario, policy=policy, params=params))
            for path in settings.agents:
                label = path.stem if path.suffix == ".zip" else path.name
                cells.append(Cell(env_id, scenario, f"{registry.USER_AGENT_PREFIX}{label}", params, run=str(path)))
    if missing:
        print(registry.missing_agents_note(missing, settings.agents_dir), file=sys.stderr)
    return cells


def check_cells(cells: list[Cell]) -> str | None:
    """:func:`footstep_gym.evaluation.runner.check_cells`, each setting named by its command-line flags."""
    return runner_check_cells(
        cells, lambda cell: " ".join(f"--{k.replace('_', '-')} {v:g}" for k, v in cell.params) or "its defaults")


def check_out(out: Path) -> str | None:
    """Why ``out`` cannot take this run's files (one line), or None: it must be a folder that
    is empty or holds an earlier evaluation (its ``run.json``). Nothing is written."""
    if out.exists() and not out.is_dir():
        return f"--out {out} is a file, not a folder"
    if out.is_dir() and any(out.iterdir()) and not (out / "run.json").is_file():
        return f"--out {out} is not empty and holds no earlier evaluation (run.json); choose another folder"
    return None


def new_run_folder(out: Path) -> Path:
    """An empty folder beside ``out`` (same file system) for this run's files until it has finished."""
    out = out.absolute()
    out.parent.mkdir(parents=True, exist_ok=True)
    folder = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".partial", dir=out.parent))
    umask = os.umask(0)
    os.umask(umask)
    folder.chmod(0o777 & ~umask)  # as a folder made by mkdir (mkdtemp makes it private)
    return folder


def commit_out(run: Path, out: Path) -> None:
    """Put a finished run's folder in place as ``out``.

    An earlier run's files in ``out`` (``OWN_FILES``, ``OWN_DIRS``) are replaced by the new
    ones and anything else a user put there is kept. ``out`` is moved aside and ``run``
    renamed into its place (both beside ``out``: renames, no copies); where ``out`` is a
    symbolic link or cannot be moved (a mount point), its contents are replaced in place.
    """
    out = out.absolute()
    if not out.exists() and not out.is_symlink():
        os.replace(run, out)
        return

    def in_place() -> None:
        for name in OWN_FILES:
            (out / name).unlink(missing_ok=True)
        for name in OWN_DIRS:
            shutil.rmtree(out / name, ignore_errors=True)
        for entry in run.iterdir():
            os.replace(entry, out / entry.name)
        run.rmdir()

    if out.is_symlink() or os.path.ismount(out):
        in_place()
        return
    aside = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".old", dir=out.parent))
    try:
        os.replace(out, aside / "out")
    except OSError:
        aside.rmdir()
        in_place()
        return
    try:
        os.replace(run, out)
    except OSError:
        os.replace(aside / "out", out)  # put the earlier run back
        aside.rmdir()
        raise
    for entry in (aside / "out").iterdir():
        if entry.name not in OWN_FILES + OWN_DIRS:  # a user's file beside the earlier run: kept
            os.replace(entry, out / entry.name)
    shutil.rmtree(aside)


def write_outputs(settings: Settings, cells: list[Cell], results: list[EpisodeResult],
                  wall_s: float, argv: Sequence[str], videos: list[Path]) -> tuple[str, list[Path]]:
    out = settings.out
    per_run = [cell_record(c.env_id, c.scenario, c.policy, c.params_dict,
                           [r for r in results if r.cell_index == i], run=c.run_name) for i, c in enumerate(cells)]
    records = over_runs(per_run)
    table = report.markdown_table(records)
    files = [out / "results.json", out / "results.csv", out / "episodes.csv"]
    files[0].write_text(json.dumps(records, indent=2) + "\n", encoding="utf-8")
    report.write_csv(files[1], *report.csv_rows(records))
    ep_rows = report.episode_rows(cells, results)
    report.write_csv(files[2], list(ep_rows[0]), ep_rows)
    if any(r["run"] is not None for r in per_run):
        (out / "runs").mkdir(exist_ok=True)
        files += [out / "runs" / "results.json", out / "runs" / "results.csv"]
        files[-2].write_text(json.dumps(per_run, indent=2) + "\n", encoding="utf-8")
        report.write_csv(files[-1], *report.csv_rows(per_run))
    if settings.figures:
        files += report.write_pictures(out, cells, results, SHOWCASE_POLICY)
    files += videos
    run_info = {
        "command": "python " + " ".join(shlex.quote(a) for a in ["baselines/eval_planner.py", *argv]),
        "profile": settings.profile, "envs": list(settings.envs), "policies": sorted({c.policy for c in cells}),
        "agent_runs": sorted({c.run for c in cells if c.run}), "episodes": settings.episodes,
        "split": settings.split, "seeds": settings.seeds,
        # One list per sweep key: door_speeds, crowd_speeds ([]: the scenario's default).
        **{f"{key}s": list(settings.sweeps.get(owners[0][0], {}).get(key, ())) for key, owners in sweep_axes().items()},
        "workers": settings.workers, "backend": settings.backend,
        "wall_time_s": round(wall_s, 2), "timing_fields": list(TIMING_FIELDS),
        "warmup_acts": WARMUP_ACTS,  # untimed acts per worker process and cell before the timed ones
        "python": platform.python_version(), "machine": platform.machine(), "cpu_count": os.cpu_count(),
        "footstep_gym": footstep_gym.__version__,
    }
    files.append(out / "run.json")
    files[-1].write_text(json.dumps(run_info, indent=2) + "\n", encoding="utf-8")
    if settings.profile == "ablation":
        from footstep_gym.planners.ablation import BASE

        table = (f"{table}\n## What each addition buys\n\nEach cell: success [Wilson 95 % CI] (difference to {BASE}); "
                 f"steps / time (s) / path (m) over the successes; median planning time per footstep.\n\n"
                 f"{report.ablation_table(records, BASE)}")
    summary = out / "summary.md"
    listing = "\n".join(f"- `{p.relative_to(out)}`" for p in files + [summary])
    seeds = settings.seeds
    summary.write_text(
        f"# Policy evaluation ({settings.profile})\n\n`{run_info['command']}`: "
        f"{len(results)} episodes, {settings.split} seeds {seeds[0]}..{seeds[-1]} per cell, "
        f"{settings.workers} worker(s) ({settings.backend}), {wall_s:.0f} s wall time.\n\n{table}\n"
        f"{report.DEFINITIONS}\n{report.paper_comparison(records)}\n"
        f"Figures show the policies side by side on the lowest seed the {SHOWCASE_POLICY} planner solved "
        f"in that setting (the lowest seed if none); the command tables are those episodes'.\n\n"
        f"## Files\n\n{listing}\n",
        encoding="utf-8",
    )
    return table, files + [summary]


def record_videos(settings: Settings, cells: list[Cell]) -> list[Path]:
    """One video per (setting, policy) at the split's first seed; an agent by its first training run."""
    done, paths = set(), []
    for c in cells:
        key = (c.env_id, c.params, c.policy)
        if key in done:
            continue
        done.add(key)
        paths.append(record_video(c, settings.seeds[0], settings.out / "videos", name=safe_name(c.setting, c.policy)))
    return paths


# ---------------------------------------------------------------- --benchmark
@dataclass(frozen=True)
class BenchmarkSettings:
    """A ``--benchmark`` run: one method (a policy name and, for an agent, its training runs per env id) on the
    benchmark's cells (``scenes`` / ``tiers``: ``None`` for all of them)."""

    policy: str
    runs: dict[str, tuple[str, ...]] | None  # env id -> training runs; None: a planner
    scenes: tuple[str, ...] | None
    tiers: tuple[str, ...] | None
    episodes: int
    out: Path
    workers: int
    backend: str
    ray_address: str | None

    @property
    def cells(self) -> list[benchmark.BenchmarkCell]:
        return benchmark.benchmark_cells(self.scenes, self.tiers)


#: Options of an evaluation that do not go with --benchmark (its cells, seeds and outputs are the protocol's).
_NOT_WITH_BENCHMARK = (("--paper", "paper"), ("--ablation", "ablation"), ("--profile", "profile"),
                       ("--video", "video"), ("--no-figures", "no_figures"))


def benchmark_settings(parser: argparse.ArgumentParser, args: argparse.Namespace) -> BenchmarkSettings:
    """Validate the options of ``--benchmark`` (exit 2 with one line on a bad one; nothing is run or written)."""
    clash = [flag for flag, dest in _NOT_WITH_BENCHMARK if getattr(args, dest)]
    clash += [flag_of(key) for key in sweep_axes() if getattr(args, key)]
    if args.split != benchmark.SPLIT:
        clash.append(f"--split {args.split}")
    if args.seed:
        clash.append("--seed")
    if clash:
        parser.error(f"--benchmark runs the protocol's cells and test seeds: {', '.join(clash)} do(es) not apply")
    named = list(args.policy or [])
    if bool(named) == bool(args.agent) or len(named) > 1:
        parser.error("--benchmark evaluates one method: give one --policy NAME, or --agent PATH (repeated for "
                     "its training runs)")
    if args.name and not args.agent:
        parser.error("--name names an --agent's method")
    if args.full and args.episodes not in (None, benchmark.FULL_EPISODES):
        parser.error(f"--full is {benchmark.FULL_EPISODES} episodes per cell; --episodes {args.episodes} "
                     "contradicts it")
    episodes = benchmark.FULL_EPISODES if args.full else args.episodes or benchmark.EPISODES
    try:
        scenes = _unique([scene_of(resolve_env_id(e)) for e in args.env]) if args.env else None
        tiers = _unique(args.tier) if args.tier else None
        cells = benchmark.benchmark_cells(scenes, tiers)
        split_seeds(benchmark.SPLIT, episodes)
    except ValueError as exc:
        parser.error(str(exc))
    if args.ray_address and args.backend != "ray":
        parser.error("--ray-address needs --backend ray")
    env_ids = sorted({c.env_id for c in cells})
    runs: dict[str, tuple[str, ...]] | None = None
    if args.agent:
        for path in args.agent:
            if not path.exists():
                parser.error(f"--agent {path}: no such file or folder")
        first = args.agent[0]
        label = args.name or (first.stem if first.suffix == ".zip" else first.name)
        policy = f"{registry.USER_AGENT_PREFIX}{label}"
        paths = tuple(str(p.resolve()) for p in _unique(args.agent))
        runs = {env_id: paths for env_id in env_ids}
    else:
        policy = named[0]
        if not registry.is_policy(policy):
            parser.error(f"unknown policy {policy!r}; choose from {', '.join(registry.policy_names())}")
        if policy in registry.AGENTS:
            runs = {env_id: tuple(str(r) for r in registry.agent_runs(policy, env_id, args.agents_dir))
                    for env_id in env_ids}
            missing = [env_id for env_id, found in runs.items() if not found]
            if missing:
                parser.error(f"{policy}: no training run for {', '.join(missing)} "
                             f"({registry.missing_agents_note({policy: missing}, args.agents_dir)}); a benchmark "
                             "row needs every scene (--env restricts it: a partial run)")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return BenchmarkSettings(policy=policy, runs=runs, scenes=scenes, tiers=tiers, episodes=episodes, out=args.out,
                             workers=args.workers or cores, backend=args.backend, ray_address=args.ray_address)


def write_benchmark(folder: Path, settings: BenchmarkSettings, cells: list[Cell],
                    owners: list[benchmark.BenchmarkCell], results: list[EpisodeResult], wall_s: float,
                    argv: Sequence[str]) -> tuple[str, list[Path]]:
    """``benchmark.json``, ``benchmark.md``, ``episodes.csv`` and ``run.json`` of a finished run, into ``folder``."""
    command = "python " + " ".join(shlex.quote(a) for a in ["baselines/eval_planner.py", *argv])
    run_info = {"command": command, "mode": "benchmark", "policy": settings.policy,
                "episodes": settings.episodes, "split": benchmark.SPLIT, "workers": settings.workers,
                "backend": settings.backend, "wall_time_s": round(wall_s, 2), "cpu_count": os.cpu_count(),
                "agent_runs": sorted({c.run for c in cells if c.run})}
    records = benchmark.cell_records(cells, owners, results)
    doc = benchmark.benchmark_document(settings.policy, settings.cells, records, settings.episodes, run_info)
    text = benchmark.markdown(doc, command)
    files = [folder / "benchmark.json", folder / "benchmark.md", folder / "episodes.csv", folder / "run.json"]
    files[0].write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    files[1].write_text(text, encoding="utf-8")
    rows = report.episode_rows(cells, results)
    report.write_csv(files[2], list(rows[0]), rows)
    files[3].write_text(json.dumps({**run_info, "complete": doc["complete"],
                                    "footstep_gym": footstep_gym.__version__}, indent=2) + "\n", encoding="utf-8")
    row = text.split("## Leaderboard row\n\n", 1)[1].split("\n\n", 1)[0]
    return row, files


def run_into(out: Path, what: str, index: str, work: Callable[[Path], tuple[str, list[Path], str]]) -> int:
    """Run ``work(folder)`` into a new temporary folder beside ``out`` and put it in place only when it finished:
    a failure (exit status 1) or an interrupt (130) removes the folder and leaves ``out`` as it was. ``work``
    returns the table to print, the files written and a line on how long it took."""
    folder = new_run_folder(out)
    try:
        table, files, took = work(folder)
    except KeyboardInterrupt:
        shutil.rmtree(folder, ignore_errors=True)
        print(f"\ninterrupted; {out} left as it was", file=sys.stderr)
        return 130
    except Exception as exc:
        shutil.rmtree(folder, ignore_errors=True)
        traceback.print_exc()
        print(f"error: {what} failed; {out} left as it was. {exc}", file=sys.stderr)
        return 1
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    commit_out(folder, out)
    print(table)
    print(f"{took}; wrote {len(files)} files to {out}/ ({index})")
    return 0


def run_benchmark(settings: BenchmarkSettings, argv: Sequence[str]) -> int:
    """``--benchmark``: check every cell and ``--out`` first, run the episodes, write into a temporary folder that
    replaces ``--out`` once finished (as an evaluation does)."""
    runs = settings.runs
    cells, owners = benchmark.runner_cells(settings.cells, settings.policy,
                                           None if runs is None else (lambda env_id: runs.get(env_id, ())))
    problem = runner_check_cells(cells) or check_out(settings.out)
    if problem:
        build_parser().error(problem)  # one line, exit status 2; nothing written
    tasks = benchmark.tasks(cells, settings.episodes)
    workers = max(1, min(settings.workers, len(tasks)))
    per_run = f" ({len(cells)} with the training runs)" if len(cells) != len(settings.cells) else ""
    print(f"benchmark of {settings.policy}: {len(settings.cells)} cells{per_run} x {settings.episodes} seeds = "
          f"{len(tasks)} episodes on {workers} worker(s) ({settings.backend}) -> {settings.out}", file=sys.stderr)
    def work(folder: Path) -> tuple[str, list[Path], str]:
        t0 = time.perf_counter()
        results = run_tasks(tasks, workers, backend=settings.backend, address=settings.ray_address)
        wall = time.perf_counter() - t0
        row, files = write_benchmark(folder, settings, cells, owners, results, wall, argv)
        return row, files, f"{len(results)} episodes in {wall:.1f} s"

    return run_into(settings.out, "the benchmark", "benchmark.md: every cell", work)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    settings = parse_settings(argv)
    if isinstance(settings, BenchmarkSettings):
        return run_benchmark(settings, argv)
    cells = make_cells(settings)
    if not cells:
        print("error: nothing to evaluate (no policy has a cell on these envs)", file=sys.stderr)
        return 2
    problem = check_cells(cells) or check_out(settings.out)
    if problem:
        build_parser().error(problem)  # one line, exit status 2; nothing written
    tasks = [Task(i, c, s, record=settings.figures) for i, c in enumerate(cells) for s in settings.seeds]
    workers = max(1, min(settings.workers, len(tasks)))
    print(f"{len(cells)} cells x {settings.episodes} seeds = {len(tasks)} episodes on {workers} worker(s) "
          f"({settings.backend}) -> {settings.out}", file=sys.stderr)
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
