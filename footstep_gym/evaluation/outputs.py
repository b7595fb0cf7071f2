"""The files of a finished evaluation: results, episodes, figures, command tables, videos, ``summary.md``
and ``run.json`` (:func:`write_outputs`, :func:`record_videos`); the tables themselves come from
:mod:`footstep_gym.evaluation.report`."""

from __future__ import annotations

import json
import os
import platform
import shlex
from pathlib import Path
from typing import Sequence

import footstep_gym
from footstep_gym.evaluation import report
from footstep_gym.evaluation.profiles import Settings, sweep_axes
from footstep_gym.evaluation.runner import WARMUP_ACTS, Cell, record_video, safe_name
from footstep_gym.evaluation.records import cell_record, dump_records, over_runs
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
    table = report.markdown_table(records)
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
