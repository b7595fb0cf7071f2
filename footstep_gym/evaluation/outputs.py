"""The files of a finished evaluation: results, episodes, figures, command tables, videos, ``summary.md``
and ``run.json`` (:func:`write_outputs`, :func:`record_videos`); the tables themselves come from
:mod:`footstep_gym.evaluation.report`."""

from __future__ import annotations

import json
import os
import platform
import shlex
from pathlib import Path
from typing import Any, Sequence

import footstep_gym
from footstep_gym.evaluation import report
from footstep_gym.evaluation.profiles import Settings, sweep_axes
from footstep_gym.evaluation.runner import WARMUP_ACTS, Cell, record_video, safe_name
from footstep_gym.evaluation.records import CellRecord, cell_record, dump_records, over_runs
from footstep_gym.evaluation.stats import TIMING_FIELDS, EpisodeResult

SHOWCASE_POLICY = "period-aware"  # the figures show a seed this policy solved, when there is one
SCRIPT = "baselines/eval_planner.py"  # the command line that runs an evaluation (in run.json's "command")


def command_line(argv: Sequence[str]) -> str:
    """The command of a run with arguments ``argv``, as a shell would take it."""
    return "python " + " ".join(shlex.quote(a) for a in [SCRIPT, *argv])


def write_outputs(settings: Settings, cells: list[Cell], results: list[EpisodeResult],
                  wall_s: float, argv: Sequence[str], videos: list[Path]) -> tuple[str, list[Path]]:
    """Every file of a finished evaluation into ``settings.out``; returns the markdown table and the files."""
    out = settings.out
    per_run = [cell_record(c.env_id, c.scenario, c.policy, c.params_dict,
                           [r for r in results if r.cell_index == i], run=c.run_name) for i, c in enumerate(cells)]
    records = over_runs(per_run)
    files = [out / "results.json", out / "results.csv", out / "episodes.csv"]
    files[0].write_text(dump_records(records), encoding="utf-8")
    report.write_csv(files[1], report.csv_table(records))
    report.write_csv(files[2], report.episode_table(cells, results))
    if any(r.run is not None for r in per_run):
        (out / "runs").mkdir(exist_ok=True)
        files += [out / "runs" / "results.json", out / "runs" / "results.csv"]
        files[-2].write_text(dump_records(per_run), encoding="utf-8")
        report.write_csv(files[-1], report.csv_table(per_run))
    if settings.figures:
        files += report.write_pictures(out, cells, results, SHOWCASE_POLICY)
    files += videos
    run_info = {
        "command": command_line(argv),
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
    summary = out / "summary.md"
    text = summary_markdown(run_info, records, [str(p.relative_to(out)) for p in files + [summary]])
    summary.write_text(text, encoding="utf-8")
    return run_table(settings.profile, records), files + [summary]


def run_table(profile: str, records: Sequence[CellRecord]) -> str:
    """The table of a run (what the command prints): a row per record, and for an ablation what each addition buys."""
    table = report.markdown_table(records)
    if profile != "ablation":
        return table
    from footstep_gym.planners.ablation import BASE

    return (f"{table}\n## What each addition buys\n\nEach cell: success [Wilson 95 % CI] (difference to {BASE}); "
            f"steps / time (s) / path (m) over the successes; median planning time per footstep.\n\n"
            f"{report.ablation_table(records, BASE)}")


def summary_markdown(run_info: dict[str, Any], records: Sequence[CellRecord], listing: Sequence[str]) -> str:
    """``summary.md`` of an evaluation: its command and seeds (``run.json``), the table of its records (and the
    ablation's table), the definitions, the paper's numbers beside its own, and its files (``listing``, relative
    paths)."""
    table = run_table(run_info["profile"], records)
    seeds = run_info["seeds"]
    files = "\n".join(f"- `{name}`" for name in listing)
    return (f"# Policy evaluation ({run_info['profile']})\n\n`{run_info['command']}`: "
            f"{sum(r.episodes for r in records)} episodes, {run_info['split']} seeds {seeds[0]}..{seeds[-1]} per cell, "
            f"{run_info['workers']} worker(s) ({run_info['backend']}), {run_info['wall_time_s']:.0f} s wall time.\n\n"
            f"{table}\n{report.DEFINITIONS}\n{report.paper_comparison(records)}\n"
            f"Figures show the policies side by side on the lowest seed the {SHOWCASE_POLICY} planner solved "
            f"in that setting (the lowest seed if none); the command tables are those episodes'.\n\n"
            f"## Files\n\n{files}\n")


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
