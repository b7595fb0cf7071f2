"""Evaluate the reference footstep planners on the three envs over many seeds (paper §3, Tables 2-4, Fig. 8-10).

Usage::

    python baselines/eval_planner.py                 # quick default: all envs, all policies, a few seeds
    python baselines/eval_planner.py --paper         # the reproduction protocol (>= 20 seeds per cell)
    python baselines/eval_planner.py --env door --door-speed 8 --door-speed 17 --policy period-aware \\
        --episodes 10 --seed 100 --out runs/door --workers 2

Each cell (env, door speed, policy) runs ``--episodes`` episodes with seeds ``--seed``,
``--seed + 1``, ...; each episode seeds the env and the policy with its seed
(``env.reset(seed=s)``, ``policy.reset(seed=s)``), so the results do not depend on
``--workers``. The script prints a markdown table and writes to ``--out``:

* ``results.json``: one record per cell (fields defined in ``eval_stats.py``);
* ``results.csv``: the same rows, ``params`` flattened to ``param_<key>`` columns;
* ``episodes.csv``: one row per episode (outcome, steps, time, path, plan time);
* ``figures/<setting>.png``: the policies side by side on one seed (footprints, CoM
  path, obstacles at several instants, per-step period and stride), like Fig. 8-10;
* ``tables/<setting>_<policy>_seed<s>.md``: that episode's commands in the format of
  Tables 2 and 4 (pre-PSO values in parentheses);
* ``summary.md`` (the table, definitions, the list of files) and ``run.json`` (the
  command, the settings, the wall time).

The seed shown in a figure is the lowest seed at which the period-aware planner reached
the goal in that setting (the lowest seed if it never did), so the picture shows what the
planner can do and, beside it, what the other planners do on the same episode.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import platform
import shlex
import sys
import time
from concurrent.futures import FIRST_EXCEPTION, ProcessPoolExecutor, wait
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any, Callable, Sequence

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the eval_* helper modules beside this file

from tqdm import tqdm  # noqa: E402

import footstep_gym  # noqa: E402
from eval_episode import Cell, Task, run_episode  # noqa: E402
from eval_stats import TIMING_FIELDS, EpisodeResult, cell_record  # noqa: E402

SHOWCASE_POLICY = "period-aware"  # the figures show a seed this policy solved, when there is one
FIGURE_SCENARIOS = ("door", "crossing", "crowd")
TABLE_SCENARIOS = ("door", "crowd")  # Tables 2 and 4 of the paper; crossing is summarised by Table 3


@dataclass(frozen=True)
class Profile:
    """Defaults of a run; options given on the command line override them."""

    envs: tuple[str, ...]
    episodes: int
    door_speeds: tuple[float, ...]  # [deg/s]
    policies: tuple[str, ...] | None  # None: every registered policy


PROFILES = {
    # A few minutes on two cores (see the report of the run in summary.md / run.json).
    "quick": Profile(envs=("door", "crossing", "crowd"), episodes=3, door_speeds=(17.0,), policies=None),
    # The paper's protocol: door at 8, 14, 17 deg/s, crossing, crowd; >= 20 seeds per cell.
    "paper": Profile(envs=("door", "crossing", "crowd"), episodes=20, door_speeds=(8.0, 14.0, 17.0),
                     policies=("period-aware", "fixed-period", "pso-only")),
}


# ---------------------------------------------------------------- command line
def registered_policies() -> tuple[str, ...]:
    from footstep_gym.planners import POLICIES

    return tuple(POLICIES)


def resolve_env(name: str) -> str:
    """Scenario key (``door``/``crossing``/``crowd``) of a short name or an env id (``FootstepDoor-v0``)."""
    wanted = name.strip().lower()
    for key, env_id in footstep_gym.ENV_IDS.items():
        if wanted in (key, env_id.lower(), f"footstep_gym:{env_id}".lower()):
            return key
    choices = ", ".join(list(footstep_gym.ENV_IDS) + list(footstep_gym.ENV_IDS.values()))
    raise ValueError(f"unknown env {name!r}; choose from {choices}")


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


_positive_int = _int_at_least(1)
_nonnegative_int = _int_at_least(0)


def _door_speed(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a speed in deg/s, got {text!r}") from None
    if not math.isfinite(v) or v < 0:
        raise argparse.ArgumentTypeError(f"must be a finite speed >= 0 deg/s, got {text!r}")
    return v


def _speeds(profile: Profile) -> str:
    return ", ".join(f"{v:g}" for v in profile.door_speeds)


def build_parser() -> argparse.ArgumentParser:
    quick, paper = PROFILES["quick"], PROFILES["paper"]
    parser = argparse.ArgumentParser(
        prog="eval_planner.py", description=__doc__.split("\n\n")[0],
        epilog=f"Without options: the quick default (all envs, all policies, {quick.episodes} seeds, "
               f"door at {_speeds(quick)} deg/s).",
    )
    parser.add_argument("--env", action="append", metavar="ENV",
                        help="door, crossing, crowd or a full id (FootstepDoor-v0); repeatable; default: all three")
    parser.add_argument("--policy", action="append", metavar="NAME",
                        help="a name of footstep_gym.planners.POLICIES; repeatable; default: all")
    parser.add_argument("--episodes", type=_positive_int, metavar="N",
                        help=f"seeds per cell (default {quick.episodes}; {paper.episodes} with --paper)")
    parser.add_argument("--seed", type=_nonnegative_int, default=0, metavar="S", help="first seed (default 0)")
    parser.add_argument("--door-speed", type=_door_speed, action="append", metavar="DEG_S",
                        help="revolving door speed in deg/s; repeatable (one cell per speed; default "
                             f"{_speeds(quick)}; {_speeds(paper)} with --paper)")
    parser.add_argument("--out", type=Path, default=Path("runs/eval"), help="output directory (default runs/eval)")
    parser.add_argument("--workers", type=_positive_int, metavar="N",
                        help="episodes run in parallel processes (default: all cores); results do not depend on it")
    parser.add_argument("--paper", action="store_true",
                        help=f"the full reproduction protocol: door at {_speeds(paper)} deg/s, crossing, crowd, "
                             f"{paper.episodes} seeds, {' vs '.join(paper.policies or ('all policies',))}")
    parser.add_argument("--no-figures", action="store_true", help="skip the figures and command tables")
    return parser


@dataclass(frozen=True)
class Settings:
    profile: str
    envs: tuple[str, ...]
    policies: tuple[str, ...]
    episodes: int
    seed: int
    door_speeds: tuple[float, ...]
    out: Path
    workers: int
    figures: bool

    @property
    def seeds(self) -> list[int]:
        return list(range(self.seed, self.seed + self.episodes))


def _unique(items: Sequence[Any]) -> tuple[Any, ...]:
    return tuple(dict.fromkeys(items))


def parse_settings(argv: Sequence[str] | None = None) -> Settings:
    """Parse and validate the command line; exits with status 2 and a message on a bad value."""
    parser = build_parser()
    args = parser.parse_args(argv)
    profile_name = "paper" if args.paper else "quick"
    profile = PROFILES[profile_name]
    try:
        envs = _unique([resolve_env(e) for e in (args.env or profile.envs)])
    except ValueError as exc:
        parser.error(str(exc))
    try:
        available = registered_policies()
    except ImportError as exc:
        parser.error(f"cannot import the planners (footstep_gym.planners): {exc}")
    if args.policy:
        unknown = [p for p in args.policy if p not in available]
        if unknown:
            parser.error(f"unknown policy {', '.join(map(repr, unknown))}; choose from {', '.join(available)}")
        policies = _unique(args.policy)
    elif profile.policies is not None:
        policies = tuple(p for p in profile.policies if p in available)
    else:
        policies = available
    if args.door_speed and "door" not in envs:
        parser.error("--door-speed applies to the door env only; add --env door")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return Settings(
        profile=profile_name, envs=envs, policies=policies, episodes=args.episodes or profile.episodes,
        seed=args.seed, door_speeds=_unique(args.door_speed or profile.door_speeds), out=args.out,
        workers=args.workers or cores, figures=not args.no_figures,
    )


def make_cells(settings: Settings) -> list[Cell]:
    """Cells in a fixed order: envs as given, door speeds as given, then policies as given."""
    cells = []
    for scenario in settings.envs:
        env_id = footstep_gym.ENV_IDS[scenario]
        settings_of_env = [(("door_speed", v),) for v in settings.door_speeds] if scenario == "door" else [()]
        for params in settings_of_env:
            for policy in settings.policies:
                cells.append(Cell(env_id=env_id, scenario=scenario, policy=policy, params=params))
    return cells


# ---------------------------------------------------------------- running
def run_tasks(tasks: list[Task], workers: int) -> list[EpisodeResult]:
    """Run every task (in ``workers`` spawned processes if > 1); results sorted by (cell, seed)."""
    results: list[EpisodeResult] = []
    bar = tqdm(total=len(tasks), desc="episodes", unit="ep", dynamic_ncols=True)
    try:
        if workers <= 1:
            for task in tasks:
                results.append(run_episode(task))
                bar.update()
        else:
            for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
                os.environ.setdefault(var, "1")  # one process per core; no nested BLAS threads
            # "spawn": each worker imports the package afresh (no state inherited from this process).
            pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"))
            try:
                pending = {pool.submit(run_episode, task) for task in tasks}
                while pending:
                    done, pending = wait(pending, return_when=FIRST_EXCEPTION)
                    for fut in done:
                        results.append(fut.result())  # re-raises an episode's error (it names the episode)
                        bar.update()
            finally:  # on an error or Ctrl-C, drop the queued episodes instead of running them
                pool.shutdown(wait=True, cancel_futures=True)
    finally:
        bar.close()
    results.sort(key=lambda r: (r.cell_index, r.seed))
    return results


def showcase_seed(cells: list[Cell], results: list[EpisodeResult], indices: list[int]) -> int:
    """The lowest seed that ``SHOWCASE_POLICY`` solved among the cells ``indices`` (else the lowest seed)."""
    seeds = sorted({r.seed for r in results if r.cell_index in indices})
    wins = sorted(r.seed for r in results if r.cell_index in indices
                  and cells[r.cell_index].policy == SHOWCASE_POLICY and r.outcome == "goal")
    return wins[0] if wins else seeds[0]


# ---------------------------------------------------------------- output
def _fmt(v: Any, digits: int = 2) -> str:
    return "–" if v is None else f"{v:.{digits}f}"


def markdown_table(records: list[dict[str, Any]]) -> str:
    head = ["env", "setting", "policy", "n", "success [95% CI]", "collision", "fall", "timeout",
            "steps*", "path (m)*", "time (s)*", "mean T (s)", "PSO steps", "plan ms median / p95 / p99"]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(["---"] * 3 + ["---:"] * (len(head) - 3)) + "|"]
    for r in records:
        lo, hi = r["success_ci95"]
        setting = ", ".join(f"{k}={v:g}" for k, v in r["params"].items()) or "–"
        pso = "–" if r["pso_step_rate"] is None else f"{100 * r['pso_step_rate']:.0f} %"
        lines.append("| " + " | ".join([
            r["scenario"], setting, r["policy"], str(r["episodes"]),
            f"{r['success_rate']:.2f} [{lo:.2f}, {hi:.2f}]", f"{r['collision_rate']:.2f}",
            f"{r['fall_rate']:.2f}", f"{r['timeout_rate']:.2f}", _fmt(r["mean_steps"], 1),
            _fmt(r["mean_path_length"]), _fmt(r["mean_time"], 1), _fmt(r["mean_period"]), pso,
            f"{_fmt(r['plan_ms_median'], 1)} / {_fmt(r['plan_ms_p95'], 1)} / {_fmt(r['plan_ms_p99'], 1)}",
        ]) + " |")
    return "\n".join(lines) + "\n"


def csv_rows(records: list[dict[str, Any]]) -> tuple[list[str], list[dict[str, Any]]]:
    """``results.csv`` columns and rows: params flattened to ``param_<key>``, lists joined by spaces."""
    param_keys = sorted({k for r in records for k in r["params"]})
    rows = []
    for r in records:
        row: dict[str, Any] = {}
        for key, value in r.items():
            if key == "params":
                row.update({f"param_{k}": r["params"].get(k, "") for k in param_keys})
            elif key == "success_ci95":
                row["success_ci95_lo"], row["success_ci95_hi"] = value
            elif isinstance(value, list):
                row[key] = " ".join(str(v) for v in value)
            else:
                row[key] = "" if value is None else value
        rows.append(row)
    return (list(rows[0]) if rows else []), rows


def write_csv(path: Path, columns: list[str], rows: list[dict[str, Any]]) -> None:
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)


def episode_rows(cells: list[Cell], results: list[EpisodeResult]) -> list[dict[str, Any]]:
    rows = []
    for r in results:
        c = cells[r.cell_index]
        rows.append({
            "env": c.env_id, "setting": c.setting, "policy": c.policy, "seed": r.seed, "outcome": r.outcome,
            "obstacle": r.obstacle or "", "steps": r.steps, "time": round(r.time, 4),
            "path_length": round(r.path_length, 4), "com_path_length": round(r.com_path_length, 4),
            "mean_period": round(sum(r.periods) / len(r.periods), 4) if r.periods else "",
            "min_period": round(min(r.periods), 4) if r.periods else "",
            "pso_steps": sum(bool(x) for x in r.pso_ran if x is not None),
            "plan_ms_mean": round(sum(r.plan_ms) / len(r.plan_ms), 3) if r.plan_ms else "",
            "plan_ms_max": round(max(r.plan_ms), 3) if r.plan_ms else "",
        })
    return rows


def write_pictures(settings: Settings, cells: list[Cell], results: list[EpisodeResult]) -> list[Path]:
    """One figure per env setting (policies side by side on the showcase seed) and its command tables."""
    from eval_report import episode_figure, params_text, write_command_table

    written = []
    groups: dict[tuple[str, tuple], list[int]] = {}
    for i, c in enumerate(cells):
        groups.setdefault((c.env_id, c.params), []).append(i)
    for (env_id, _), indices in groups.items():
        scenario = cells[indices[0]].scenario
        if scenario not in FIGURE_SCENARIOS:
            continue
        seed = showcase_seed(cells, results, indices)
        traces = [r.trace for i in indices for r in results if r.cell_index == i and r.seed == seed]
        traces = [t for t in traces if t is not None]
        if not traces:
            continue
        setting = cells[indices[0]].setting
        title = f"{env_id}" + (f" ({params_text(traces[0].params)})" if traces[0].params else "") + f", seed {seed}"
        written.append(episode_figure(traces, settings.out / "figures" / f"{setting}.png", title))
        if scenario in TABLE_SCENARIOS:
            for tr in traces:
                path = settings.out / "tables" / f"{setting}_{tr.policy}_seed{seed}.md"
                written.append(write_command_table(tr, path))
    return written


def _rate(r: dict[str, Any] | None) -> str:
    if r is None:
        return "not run"
    lo, hi = r["success_ci95"]
    return f"{r['success_rate']:.2f} [{lo:.2f}, {hi:.2f}]"


#: Door outcomes in the paper (§3.1): door speed [deg/s] -> (fixed-period, period-aware).
PAPER_DOOR = {8.0: ("goal", "goal"), 14.0: ("collides", "goal"), 17.0: ("collides", "goal")}


def paper_comparison(records: list[dict[str, Any]]) -> str:
    """The paper's results (DESIGN.md §6) beside the numbers of this run, for the cells that were run."""
    def find(scenario: str, policy: str, **params: float) -> dict[str, Any] | None:
        return next((r for r in records if r["scenario"] == scenario and r["policy"] == policy
                     and r["params"] == params), None)

    def steps_path(r: dict[str, Any] | None) -> str:
        if r is None or r["mean_steps"] is None:
            return "no success" if r is not None else "not run"
        return f"{r['mean_steps']:.1f} steps, {100 * r['mean_path_length']:.0f} cm"

    rows = []
    speeds = sorted({r["params"]["door_speed"] for r in records if r["scenario"] == "door"})
    for v in speeds:
        fixed, aware = find("door", "fixed-period", door_speed=v), find("door", "period-aware", door_speed=v)
        paper = PAPER_DOOR.get(v)
        paper_text = f"fixed-period {paper[0]}, period-aware {paper[1]}" if paper else "(speed not in the paper)"
        rows.append(f"| door {v:g} deg/s: success | {paper_text} "
                    f"| fixed-period {_rate(fixed)}, period-aware {_rate(aware)} |")
    if any(r["scenario"] == "crossing" for r in records):
        fixed, aware = find("crossing", "fixed-period"), find("crossing", "period-aware")
        rows.append(f"| crossing: success | both reach the goal | fixed-period {_rate(fixed)}, "
                    f"period-aware {_rate(aware)} |")
        rows.append(f"| crossing: steps, path (successes) | fixed-period 26 steps, 260 cm; period-aware 20 steps, "
                    f"190 cm | fixed-period {steps_path(fixed)}; period-aware {steps_path(aware)} |")
    if any(r["scenario"] == "crowd" for r in records):
        fixed, aware = find("crowd", "fixed-period"), find("crowd", "period-aware")
        rows.append(f"| crowd: success | fixed-period collides, period-aware survives | fixed-period {_rate(fixed)}, "
                    f"period-aware {_rate(aware)} |")
        period = "not run" if aware is None else f"mean T {aware['mean_period']:.2f} s, min {aware['min_period']:.2f} s"
        rows.append(f"| crowd: period-aware period | T_SS 0.60 -> 0.54 s (T 0.80 -> 0.74 s), S 7.0 -> 5.6 cm "
                    f"(Table 4) | {period} |")
    if not rows:
        return ""
    return ("## Against the paper\n\n| result | paper (one run each) | this run (success rate [95% CI]) |\n"
            "|---|---|---|\n" + "\n".join(rows) + "\n")


DEFINITIONS = """\
Columns marked * are means over the successful episodes only (– when there is none);
`results.json` also has them over all episodes (`*_all`). The rates sum to 1: success
(goal), collision, fall (an infeasible step: the ZMP leaves the stable region or a
kinematic limit is broken) and timeout (step or time limit). The 95 % interval is
Wilson's. The path is the walked path of the robot centre (midpoint of the feet), as the
paper's "length of path". Mean T is the walking period T_SS + T_DS averaged over all
footsteps; PSO steps is the share of footsteps on which the policy ran PSO. Plan time is
the wall clock of `policy.act` per footstep, pooled over the cell's footsteps (it depends
on the machine and the load, the other fields do not).
"""


def write_outputs(settings: Settings, cells: list[Cell], results: list[EpisodeResult],
                  wall_s: float, argv: Sequence[str]) -> tuple[str, list[Path]]:
    out = settings.out
    out.mkdir(parents=True, exist_ok=True)
    records = [cell_record(c.env_id, c.scenario, c.policy, c.params_dict,
                           [r for r in results if r.cell_index == i]) for i, c in enumerate(cells)]
    table = markdown_table(records)
    files = [out / "results.json", out / "results.csv", out / "episodes.csv"]
    files[0].write_text(json.dumps(records, indent=2) + "\n", encoding="utf-8")
    write_csv(files[1], *csv_rows(records))
    ep_rows = episode_rows(cells, results)
    write_csv(files[2], list(ep_rows[0]), ep_rows)
    if settings.figures:
        files += write_pictures(settings, cells, results)
    run_info = {
        "command": "python " + " ".join(shlex.quote(a) for a in ["baselines/eval_planner.py", *argv]),
        "profile": settings.profile, "envs": list(settings.envs), "policies": list(settings.policies),
        "episodes": settings.episodes, "seeds": settings.seeds, "door_speeds": list(settings.door_speeds),
        "workers": settings.workers, "wall_time_s": round(wall_s, 2), "timing_fields": list(TIMING_FIELDS),
        "python": platform.python_version(), "machine": platform.machine(), "cpu_count": os.cpu_count(),
        "footstep_gym": footstep_gym.__version__,
    }
    files.append(out / "run.json")
    files[-1].write_text(json.dumps(run_info, indent=2) + "\n", encoding="utf-8")
    summary = out / "summary.md"
    listing = "\n".join(f"- `{p.relative_to(out)}`" for p in files + [summary])
    summary.write_text(
        f"# Planner evaluation ({settings.profile})\n\n`{run_info['command']}`: "
        f"{len(results)} episodes, seeds {settings.seed}..{settings.seed + settings.episodes - 1} per cell, "
        f"{settings.workers} worker(s), {wall_s:.0f} s wall time.\n\n{table}\n{DEFINITIONS}\n"
        f"{paper_comparison(records)}\n"
        f"Figures show the policies side by side on the lowest seed the {SHOWCASE_POLICY} planner solved "
        f"in that setting (the lowest seed if none); the command tables are those episodes'.\n\n"
        f"## Files\n\n{listing}\n",
        encoding="utf-8",
    )
    return table, files + [summary]


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    settings = parse_settings(argv)
    cells = make_cells(settings)
    tasks = [Task(i, c, s, record=settings.figures) for i, c in enumerate(cells) for s in settings.seeds]
    workers = max(1, min(settings.workers, len(tasks)))
    print(f"{len(cells)} cells x {settings.episodes} seeds = {len(tasks)} episodes on {workers} worker(s) "
          f"-> {settings.out}", file=sys.stderr)
    t0 = time.perf_counter()
    results = run_tasks(tasks, workers)
    wall = time.perf_counter() - t0
    table, files = write_outputs(settings, cells, results, wall, argv)
    print(table)
    print(f"{len(results)} episodes in {wall:.1f} s; wrote {len(files)} files to {settings.out}/ "
          f"(summary.md lists them)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
