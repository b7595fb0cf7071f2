"""The benchmark: one policy on every cell of every tier of every scene, one leaderboard row.

``python baselines/eval_planner.py --benchmark --policy NAME --out DIR`` (docs/benchmark.md) is a
thin front-end to this module:

* :func:`benchmark_cells`: the cells, ``(scene, tier, cell)`` triples with their env kwargs, from
  the benchmark's tiers (``configs/benchmark.yaml`` through :mod:`footstep_gym.tiers`); each
  runs as ``gymnasium.make(env_id, tier=TIER, tier_cell=CELL)``;
* :func:`runner_cells` and :func:`tasks`: the evaluation runner's cells (one per benchmark cell and
  training run) and episodes, the same seeds for every cell: the first ``episodes`` seeds of the
  validation split, or with ``release`` (``--release``: the board's row) of the test split
  (:data:`EPISODES`, a leaderboard row's number), run by :func:`~footstep_gym.evaluation.runner.run_tasks` locally
  or on Ray; a release run is refused from uncommitted code and logged first (:func:`release_problem`,
  :func:`start_release`, :mod:`footstep_gym.evaluation.protocol`);
* :func:`cell_records`: one record per scene x tier x cell x policy (x training run), the
  evaluation's record (:func:`~footstep_gym.evaluation.stats.cell_record`: success with its Wilson
  95 % interval, collision, fall and timeout rates, time to goal and path length over the
  successes, smallest clearance and ZMP margin, act time median / p99 after the warm-up) with the
  cell's ``scene``, ``tier``, ``cell``, ``env_kwargs`` and ``upper_bound`` added;
* :func:`tier_aggregates`: per tier, the board's score (:func:`~footstep_gym.evaluation.scores.tier_score`: the
  scene-balanced mean of the cells' success with its hierarchical bootstrap interval, and safe success), and as
  secondary figures the IQM of the success rates over the tier's cells with rliable's stratified-bootstrap interval
  over training runs (:func:`~footstep_gym.evaluation.stats.iqm_over_tasks`) and the plain mean;
* :func:`benchmark_document` and :func:`markdown`: ``benchmark.json`` and ``benchmark.md``;
* :class:`BenchmarkSettings` (:func:`benchmark_settings` checks a run's options), :func:`run_benchmark`
  and :func:`write_benchmark`: a whole run into a temporary folder that replaces ``--out`` once
  finished (:mod:`footstep_gym.evaluation.outfolder`);
* :func:`evaluate`: the same for any callable ``observation -> action`` (the library's way in,
  ``footstep_gym.benchmark.evaluate``).

The policy's name is resolved once (:func:`footstep_gym.registry.resolve`) and its entry travels
with the settings. A policy that reads the true future (``oracle``) is an upper bound: its records
carry ``upper_bound: true`` and the tables call it "NAME (upper bound)".
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, NoReturn, Sequence

import pandas as pd

import footstep_gym
from footstep_gym import registry
from footstep_gym.evaluation import report
from footstep_gym.evaluation.outfolder import check_out, run_into
from footstep_gym.evaluation.profiles import OptionError, unique, usable_cores
from footstep_gym.evaluation.runner import (WARMUP_ACTS, Cell, PolicyFactory, Task, check_cells, default_factory,
                                            run_tasks)
from footstep_gym.evaluation.submission import AgentArg, CallableFactory, SubmissionError, parse_agents, runs_by_env
from footstep_gym.evaluation import protocol as row_protocol
from footstep_gym.evaluation.splits import PROTOCOL_VERSION, TEST, split_seeds
from footstep_gym.evaluation.records import CellRecord, cell_record, over_runs
from footstep_gym.evaluation.scores import tier_score
from footstep_gym.evaluation.stats import TIMING_FIELDS, EpisodeResult, iqm_over_tasks, score_matrix
from footstep_gym.evaluation.tables import interval, markdown as markdown_table, mm, num, plural, runs as runs_text
from footstep_gym.scenarios import resolve_env_id, scene_of

#: The seeds of every cell: the validation split's first ones (a development run, no board row), or with
#: ``--release`` the test split's (:data:`RELEASE_SPLIT`: the board; configs/eval.yaml).
SPLIT = "validation"
RELEASE_SPLIT = TEST
#: Episodes per cell: every leaderboard row's number (make_leaderboard.py refuses a mix of numbers), the default.
EPISODES = 100
# PROTOCOL_VERSION (imported above): the protocol's version written into benchmark.json, configs/eval.yaml's.


@dataclass(frozen=True)
class BenchmarkCell:
    """One cell of the benchmark: ``scene`` (door / crossing / crowd), ``tier``, the cell's ``name`` in it, the
    env kwargs it stands for (``env_kwargs``, for the record) and ``selector``: what ``gymnasium.make`` is given
    beside the env id to build it (``tier=TIER, tier_cell=CELL``)."""

    scene: str
    tier: str
    name: str
    selector: tuple[tuple[str, Any], ...] = ()
    env_kwargs: Mapping[str, Any] = field(default_factory=dict, compare=False, hash=False)

    @property
    def env_id(self) -> str:
        return footstep_gym.ENV_IDS[self.scene]

    @property
    def label(self) -> str:
        """``scene/tier/cell``."""
        return f"{self.scene}/{self.tier}/{self.name}"


def _tier_table() -> list[tuple[str, str, str, dict[str, Any]]]:
    """``(scene, tier, cell, env kwargs)`` of every cell the tiers define (configs/benchmark.yaml), tier by tier in
    the file's order, then scene by scene (``SCENARIOS``' order), then the tier's cells in the file's order."""
    from footstep_gym import tiers
    from footstep_gym.scenarios import SCENARIOS

    table = []
    for name in tiers.tier_names():
        listed = tiers.tier(name).scenes
        for scene in SCENARIOS:
            if scene not in listed and name != tiers.DEFAULT_TIER:
                continue  # a tier need not cover every scene (the default tier covers them all)
            table += [(scene, name, cell.name, tiers.plain(cell.kwargs)) for cell in tiers.cells(scene, name)]
    return table


def tier_names() -> list[str]:
    """The benchmark's tiers, in the order of configs/benchmark.yaml (``paper``, ``train``, ``shifted``,
    ``structure``, ``noise``)."""
    from footstep_gym import tiers

    return tiers.tier_names()


def benchmark_cells(scenes: Sequence[str] | None = None, tiers: Sequence[str] | None = None) -> list[BenchmarkCell]:
    """Every cell of the benchmark (tier by tier, scene by scene, cell by cell), or those of ``scenes`` / ``tiers``
    only (a partial run: fine while developing, no leaderboard row). Each is made as
    ``gymnasium.make(env_id, tier=TIER, tier_cell=CELL)``."""
    table = _tier_table()
    known_scenes = list(dict.fromkeys(scene for scene, *_ in table))
    known_tiers = list(dict.fromkeys(tier for _, tier, *_ in table))
    for what, asked, known in (("scene", scenes, known_scenes), ("tier", tiers, known_tiers)):
        unknown = [x for x in asked or () if x not in known]
        if unknown:
            raise ValueError(f"unknown benchmark {what}(s) {', '.join(map(repr, unknown))}; the benchmark has "
                             f"{', '.join(known)}")
    return [BenchmarkCell(scene, tier, name, selector=(("tier", tier), ("tier_cell", name)), env_kwargs=kwargs)
            for scene, tier, name, kwargs in table
            if (scenes is None or scene in scenes) and (tiers is None or tier in tiers)]


#: The tracks (docs/benchmark.md): generalisation (trained on ``train``, tested on every tier) and in-distribution
#: (trained on tier T's cells with train-split seeds, tested on T only).
GENERALISATION, IN_DISTRIBUTION = "generalisation", "in-distribution"


def is_complete(cells: Sequence[BenchmarkCell], trained_on_tier: str | None = None) -> bool:
    """Whether ``cells`` are every cell of the benchmark (a generalisation row needs them all), or with
    ``trained_on_tier`` every cell of that tier (an in-distribution row)."""
    every = benchmark_cells(tiers=[trained_on_tier] if trained_on_tier else None)
    return {c.label for c in cells} == {c.label for c in every}


def track_tier(tier: str | None, tiers: Sequence[str] | None, where: str) -> tuple[str, ...] | None:
    """The tiers a method trained on ``tier`` (the in-distribution track; None: the generalisation track) is run
    on, given the asked ``tiers``: ``(tier,)``; ``ValueError`` (one line, naming ``where``) for a tier without a
    distribution to train on (the default), an unknown tier, or asked tiers other than it."""
    from footstep_gym import tiers as tier_module

    if tier is None:
        return tuple(tiers) if tiers else None
    known = tier_module.tier_names()
    tracked = [t for t in known if t not in (tier_module.DEFAULT_TIER, "train")]
    if tier not in known:
        raise ValueError(f"{where}: unknown tier {tier!r}; choose one of {', '.join(tracked)}")
    if tier == tier_module.DEFAULT_TIER:
        raise ValueError(f"{where}: {tier!r} has no distribution to train on (its cells are the paper's fixed "
                         f"scenes); the in-distribution track has {', '.join(tracked)}")
    if tier == "train":
        raise ValueError(f"{where}: a method trained on 'train' is on the generalisation track (tested on every "
                         f"tier): leave the option out; the in-distribution track has {', '.join(tracked)}")
    if tiers and set(tiers) != {tier}:
        raise ValueError(f"{where}: a method trained on tier {tier!r} is tested on it only (the in-distribution "
                         f"track); --tier {', '.join(t for t in tiers if t != tier)} contradicts it")
    return (tier,)


# ---------------------------------------------------------------- what runs
#: ``runs(env_id) -> [run, ...]``: the training runs of an agent for an env, each a path or an
#: :class:`~footstep_gym.evaluation.submission.AgentArg` (``[None]``: a planner, one "run").
RunsOf = Callable[[str], Sequence["str | AgentArg | None"]]


def runner_cells(cells: Sequence[BenchmarkCell], entry: registry.PolicyEntry, runs_of: RunsOf | None = None
                 ) -> tuple[list[Cell], list[BenchmarkCell]]:
    """The runner's cells (one per benchmark cell and training run), each carrying ``entry`` (the policy, resolved
    once), and, index for index, their benchmark cells.

    ``runs_of``: an agent's training runs per env id (``None``: a planner, no run). A cell whose env has
    no run is left out (the caller says so).
    """
    out: list[Cell] = []
    owners: list[BenchmarkCell] = []
    for bc in cells:
        for run in (runs_of(bc.env_id) if runs_of is not None else [None]):
            if isinstance(run, AgentArg):
                out.append(Cell(bc.env_id, bc.scene, entry.name, bc.selector, run=run.path, algo=run.algo,
                                vecnormalize=run.vecnormalize, entry=entry))
            else:
                out.append(Cell(bc.env_id, bc.scene, entry.name, bc.selector, run=None if run is None else str(run),
                                entry=entry))
            owners.append(bc)
    return out, owners


def seeds(episodes: int, split: str = SPLIT, release: bool = False) -> list[int]:
    """The seeds of every cell: the first ``episodes`` of ``split`` (the validation split: a development run); the
    test split's only for a ``release`` run (:func:`~footstep_gym.evaluation.splits.split_seeds` refuses it
    otherwise)."""
    return split_seeds(split, episodes, release=release)


def tasks(cells: Sequence[Cell], episodes: int, split: str = SPLIT, release: bool = False) -> list[Task]:
    """Every episode: each cell at each of :func:`seeds` (nothing recorded for figures)."""
    return [Task(i, c, s) for i, c in enumerate(cells) for s in seeds(episodes, split, release)]


# ---------------------------------------------------------------- records and aggregates
def cell_records(cells: Sequence[Cell], owners: Sequence[BenchmarkCell], results: Sequence[EpisodeResult],
                 reads_truth: bool = False) -> list[CellRecord]:
    """One record per runner cell (scene x tier x cell x policy x training run), in the cells' order;
    ``reads_truth``: the policy's (its records' ``upper_bound``)."""
    by_cell: dict[int, list[EpisodeResult]] = {}
    for r in results:
        by_cell.setdefault(r.cell_index, []).append(r)
    return [cell_record(c.env_id, c.scenario, c.policy, c.params_dict, by_cell.get(i, []), run=c.run_name,
                        scene=bc.scene, tier=bc.tier, cell=bc.name, env_kwargs=dict(bc.env_kwargs),
                        upper_bound=reads_truth)
            for i, (c, bc) in enumerate(zip(cells, owners))]


def tier_aggregates(records: Sequence[CellRecord], reps: int = 2000) -> list[dict[str, Any]]:
    """Per tier and policy: the board's figures (:func:`~footstep_gym.evaluation.scores.tier_score`): ``success``, the
    scene-balanced mean of the cells' success (each scene the same weight, each cell within a scene the same) with
    its hierarchical bootstrap 95 % interval ``success_ci95`` (over training runs, then episodes: a planner's
    interval is its episode noise), ``safe_success`` and ``safe_success_ci95`` likewise (None where the records
    carry no safe successes), ``iqm_runs`` (the IQM over runs x cells, from
    :data:`~footstep_gym.evaluation.scores.IQM_MIN_RUNS` runs; else None); and protocol 2's figure, kept as a
    secondary one: ``success_iqm``, the IQM of the success rates over the tier's cells (all scenes) with a
    stratified-bootstrap 95 % interval over training runs (:func:`~footstep_gym.evaluation.stats.iqm_over_tasks`).

    ``records``: one per cell and run (:func:`cell_records`). The score matrix
    (:func:`~footstep_gym.evaluation.stats.score_matrix`) has one column per cell of the tier and one row per
    training run; an agent with fewer runs for some scene is cut to the fewest (``runs`` says how many entered). A
    planner is one run: its interval is its point. Also ``success_mean`` (the plain mean over the tier's cells of the
    success pooled over runs), ``cells``, ``scenes`` and ``episodes`` (all episodes of the tier).
    """
    groups: dict[tuple[str, str], list[CellRecord]] = {}
    for r in records:
        groups.setdefault((r.tier, r.policy), []).append(r)
    out = []
    for (tier, policy), mine in groups.items():
        by_cell = pd.DataFrame([(f"{r.scene}/{r.cell}", r.run or "", r.successes, r.episodes) for r in mine],
                               columns=["cell", "run", "successes", "episodes"])
        cells = list(dict.fromkeys(by_cell["cell"]))
        matrix, _ = score_matrix(mine, cells)
        n_runs = matrix.shape[0]
        totals = by_cell.groupby("cell", sort=False)[["successes", "episodes"]].sum()
        used = by_cell.sort_values("run").groupby("cell", sort=False).head(n_runs)["run"]  # the runs in the matrix
        iqm, lo, hi = iqm_over_tasks(matrix, reps=reps)
        board = tier_score(mine, cells, reps=reps)
        out.append({
            "tier": tier, "policy": policy, "upper_bound": bool(mine[0].upper_bound),
            "success": board["success"], "success_ci95": board["success_ci95"],
            "safe_success": board["safe_success"], "safe_success_ci95": board["safe_success_ci95"],
            "iqm_runs": board["iqm"],
            "success_iqm": iqm, "success_iqm_ci95": [lo, hi],
            "success_mean": float((totals["successes"] / totals["episodes"]).mean()),
            "runs": n_runs, "cells": cells, "scenes": sorted({r.scene for r in mine}),
            "episodes": int(totals["episodes"].sum()), "runs_used": sorted(set(used) - {""}),
        })
    return out


#: The files that define the benchmark's envs besides the scenarios' own YAMLs (relative to configs/): a
#: submission's ``env_configs_sha256`` must match the release's (the planner's and the agents' own configs are the
#: method's business).
BASE_CONFIGS = ("benchmark.yaml", "env.yaml", "eval.yaml", "robot.yaml")


def env_config_files() -> list[str]:
    """The files :func:`env_configs_sha256` hashes: :data:`BASE_CONFIGS`, then every registered scenario's
    ``config_file`` (in ``SCENARIOS`` order; relative to configs/ or absolute)."""
    from footstep_gym.scenarios import SCENARIOS

    return [*BASE_CONFIGS, *(cls.config_file for cls in SCENARIOS.values())]


def env_configs_sha256() -> str:
    """One SHA-256 over the files of :func:`env_config_files`: each one's name and content (its YAML as loaded,
    written as JSON in the file's key order, which is the order of a ``randomize`` range's draws), in that
    order. A comment or a layout change keeps it; a value, a key or an order changes it."""
    import hashlib

    from footstep_gym.config import read_yaml

    digest = hashlib.sha256()
    for name in env_config_files():
        content = json.dumps(read_yaml(name), separators=(",", ":"))
        digest.update(name.encode() + b"\0" + content.encode() + b"\0")
    return digest.hexdigest()


def source_commit(root: Path | None = None) -> str | None:
    """The git commit of the checkout at ``root`` (default the package's), ``+dirty`` where its code differs from
    it, or None outside one. Dirty is the release check's rule (:func:`~footstep_gym.evaluation.protocol.tree_state`):
    modified, added, deleted or untracked files, the outputs under ``baselines/results/`` (a board's rows and its
    access log) left out."""
    state = row_protocol.tree_state(root)
    if state.commit is None:
        return None
    return state.commit + ("+dirty" if state.dirty else "")


def benchmark_document(entry: registry.PolicyEntry, cells: Sequence[BenchmarkCell], records: Sequence[CellRecord],
                       episodes: int, run_info: Mapping[str, Any], trained_on_tier: str | None = None,
                       split: str = SPLIT, release: bool = False) -> dict[str, Any]:
    """What ``benchmark.json`` holds: the protocol, the per-run records, their summary over runs, the aggregates;
    ``track`` and ``trained_on_tier`` say which track the row is on (:data:`GENERALISATION`: ``trained_on_tier``
    None); ``split``: the seeds' (the test split only with ``release``: the board's row; else a development run).
    ``protocol.fingerprint``
    is :func:`~footstep_gym.evaluation.protocol.fingerprint` (the configs and the simulator's source)."""
    return {
        "benchmark": "footstep_gym", "protocol_version": PROTOCOL_VERSION, "footstep_gym": footstep_gym.__version__,
        "policy": entry.name, "label": entry.label, "upper_bound": entry.reads_truth,
        "description": entry.description,
        "track": IN_DISTRIBUTION if trained_on_tier else GENERALISATION, "trained_on_tier": trained_on_tier,
        "complete": is_complete(cells, trained_on_tier),
        "protocol": {
            "split": split, "episodes_per_cell": episodes, "seeds": seeds(episodes, split, release),
            "tiers": list(dict.fromkeys(c.tier for c in cells)), "scenes": list(dict.fromkeys(c.scene for c in cells)),
            "cells": [{"scene": c.scene, "tier": c.tier, "cell": c.name, "env_id": c.env_id,
                       "env_kwargs": dict(c.env_kwargs)} for c in cells],
            "warmup_acts": WARMUP_ACTS, "timing_fields": list(TIMING_FIELDS),
            "env_configs_sha256": env_configs_sha256(), "fingerprint": row_protocol.fingerprint(),
        },
        "aggregates": tier_aggregates(records),
        "records": [r.to_dict() for r in records],
        "summary": [r.to_dict() for r in over_runs(records)],
        "run": {**run_info, "python": platform.python_version(), "machine": platform.machine(),
                "source_commit": source_commit()},
    }


# ---------------------------------------------------------------- markdown
def _score_text(a: Mapping[str, Any]) -> str:
    """A tier's headline: the scene-balanced success [hierarchical CI] (protocol 2's files: the IQM) and its runs."""
    if "success" not in a:
        return f"{interval(a['success_iqm'], a['success_iqm_ci95'])} ({runs_text(a['runs'])})"
    return f"{interval(a['success'], a['success_ci95'])} ({runs_text(a['runs'])})"


def _secondary_text(a: Mapping[str, Any]) -> str:
    """A tier's secondary figures: safe success, the IQM over runs x cells (enough runs only), the plain mean."""
    parts = []
    if a.get("safe_success") is not None:
        parts.append(f"safe {interval(a['safe_success'], a['safe_success_ci95'])}")
    if a.get("iqm_runs") is not None:
        parts.append(f"IQM over runs {a['iqm_runs']:.2f}")
    parts.append(f"mean {a['success_mean']:.2f}")
    return "; ".join(parts)


DEFINITIONS = """\
Every cell runs the same seeds, the first {episodes} of the {split} split ({first}..{last}); each
episode seeds the env and the policy with its seed, so the figures do not depend on the machine,
the worker count or the backend, except the act times. Success [95 % CI] is the share of episodes
that reached the goal with its Wilson interval; collision, fall (an infeasible step) and timeout
(step or time limit) are the other outcomes' shares (the four sum to 1). Time to goal and path
(the robot centre's walked path) are means over the successful episodes (– when there is none).
Clearance is the smallest gap between the body circle and any obstacle over an episode, ZMP
margin the smallest distance of the ZMP from the stable region's edge, both in mm as median /
min over the cell's episodes. Act time is the wall clock of `policy.act` per footstep (planning,
or an agent's inference) as median / p99 over the cell's footsteps, timed after each worker's
untimed warm-up of {warmup} acts per cell. A tier's score is the scene-balanced mean of its cells'
success (each scene weighs the same, each cell within a scene the same: no cell is dropped), with
a hierarchical bootstrap 95 % interval (training runs, then episodes within each run and cell, so a
one-run planner's interval shows its episode noise); "safe" is the same for safe success (the goal
reached with the episode's smallest clearance and ZMP margin at least configs/eval.yaml's
`safe_success` thresholds); "IQM over runs" (rliable's interquartile mean over runs x cells) is
shown from 5 training runs on, and "mean" is the plain mean of the cells' success rates.
A policy marked "(upper bound)" reads the true future of the obstacles (docs/benchmark.md): it
bounds what prediction can buy, it is not a baseline.
"""


def markdown(doc: Mapping[str, Any], command: str = "") -> str:
    """``benchmark.md``: the leaderboard row (scene-balanced success per tier), then every cell's record, then the
    definitions."""
    protocol = doc["protocol"]
    label = doc["label"]
    aggregates = doc["aggregates"]
    seeds_ = protocol["seeds"]
    tiers = protocol["tiers"]
    lines = [f"# Benchmark: {label}", ""]
    if command:
        lines += [f"`{command}`", ""]
    n = protocol["episodes_per_cell"]
    lines.append(f"{len(protocol['cells'])} cells (tiers {', '.join(tiers)}; scenes {', '.join(protocol['scenes'])}), "
                 f"{n} episode{'s' if n != 1 else ''} per cell, {protocol['split']} seeds {seeds_[0]}..{seeds_[-1]}.")
    if protocol["split"] != RELEASE_SPLIT:
        lines += ["", f"**Development run** ({protocol['split']} seeds, no `--release`): not a board row (rows run "
                      f"on the {RELEASE_SPLIT} split, once)."]
    trained_on = doc.get("trained_on_tier")
    if trained_on:
        lines += ["", f"**In-distribution track**: trained on the {trained_on} tier's cells (train-split seeds), "
                      f"tested on its test seeds only."]
    if not doc["complete"]:
        lines += ["", "**Partial run** (some tiers or scenes left out): not a leaderboard row."]
    by_tier = {a["tier"]: a for a in aggregates}
    headline = "IQM success" if any("success" not in a for a in aggregates) else "success"
    row = pd.DataFrame([[label, *(_score_text(by_tier[t]) if t in by_tier else "–" for t in tiers)]],
                       columns=["policy", *(f"{t}: {headline} [95% CI]" for t in tiers)])
    lines += ["", "## Leaderboard row", "", markdown_table(row).rstrip("\n"), "", "## Cells", ""]
    rows = []
    summary = [CellRecord.from_dict(r) for r in doc["summary"]]
    for tier in tiers:
        for r in (r for r in summary if r.tier == tier):
            rows.append([r.tier, r.scene, r.cell, f"{r.episodes}" + (f" ({len(r.runs)} runs)" if r.runs else ""),
                         interval(r.success_rate, r.success_ci95), num(r.collision_rate), num(r.fall_rate),
                         num(r.timeout_rate), num(r.mean_time, 1), num(r.mean_path_length),
                         f"{mm(r.min_clearance_median)} / {mm(r.min_clearance_min)}",
                         f"{mm(r.min_zmp_margin_median)} / {mm(r.min_zmp_margin_min)}",
                         f"{num(r.plan_ms_median)} / {num(r.plan_ms_p99, 1)}"])
        a = by_tier.get(tier)
        if a is not None:
            how = "scene-balanced" if "success" in a else "IQM"
            rows.append([f"**{tier}**", "**all**", f"{how} over {plural(len(a['cells']), 'cell')}",
                         str(a["episodes"]), f"**{_score_text(a)}**", _secondary_text(a), *[""] * 7])
    head = ["tier", "scene", "cell", "n", "success [95% CI]", "collision", "fall", "timeout", "time to goal (s)*",
            "path (m)*", "clearance mm", "ZMP margin mm", "act ms median / p99"]
    lines.append(markdown_table(pd.DataFrame(rows, columns=head), left=3).rstrip("\n"))
    lines += ["", DEFINITIONS.format(episodes=protocol["episodes_per_cell"], first=seeds_[0], last=seeds_[-1],
                                     warmup=protocol["warmup_acts"], split=protocol["split"])]
    return "\n".join(lines)


# ---------------------------------------------------------------- a run (eval_planner.py --benchmark)
@dataclass(frozen=True)
class BenchmarkSettings:
    """A ``--benchmark`` run: one method (its resolved :class:`~footstep_gym.registry.PolicyEntry` and, for an
    agent, its training runs per env id) on the benchmark's cells (``scenes`` / ``tiers``: ``None`` for all of
    them); ``factory`` makes each episode's policy (the registry's, or a callable's: :func:`evaluate`)."""

    entry: registry.PolicyEntry
    runs: dict[str, tuple[str | AgentArg, ...]] | None  # env id -> training runs; None: not an agent
    scenes: tuple[str, ...] | None
    tiers: tuple[str, ...] | None
    episodes: int
    out: Path
    workers: int
    backend: str
    ray_address: str | None
    factory: PolicyFactory = default_factory
    trained_on_tier: str | None = None  # the in-distribution track's tier; None: the generalisation track
    split: str = SPLIT  # the seeds' split: validation for a development run, the test split for a release
    release: bool = False  # a run of the test split (the board's): committed code, logged

    @property
    def policy(self) -> str:
        return self.entry.name

    @property
    def cells(self) -> list[BenchmarkCell]:
        return benchmark_cells(self.scenes, self.tiers)


def benchmark_settings(*, policies: Sequence[str] | None, agents: Sequence[str | Path] | None, name: str | None,
                       episodes: int | None, envs: Sequence[str] | None, tiers: Sequence[str] | None,
                       out: Path, workers: int | None, backend: str, ray_address: str | None,
                       agents_dir: Path | None, algo: str | None = None,
                       vecnormalize: Sequence[str] | None = None,
                       trained_on_tier: str | None = None, release: bool = False) -> BenchmarkSettings:
    """A run's settings from its options, checked: the first bad one raises
    :class:`~footstep_gym.evaluation.profiles.OptionError` (one line; nothing is run or written).

    ``agents``: ``--agent`` values, ``PATH`` or ``SCENE=PATH`` (:func:`~footstep_gym.evaluation.submission.
    parse_agents`; ``algo`` and ``vecnormalize`` for plain ``.zip`` files). ``trained_on_tier``
    (``--trained-on-tier``): the method trained on that tier's cells, the in-distribution track: it runs on
    that tier only (a shipped agent registered with a ``tier`` is on that track by itself). ``release``
    (``--release``): the test split, refused from a tree with uncommitted changes and for a partial run
    (:func:`release_problem`)."""
    named = list(policies or [])
    if bool(named) == bool(agents) or len(named) > 1:
        raise OptionError("--benchmark evaluates one method: give one --policy NAME, or --agent [SCENE=]PATH "
                          "(repeated for its training runs)")
    if (algo or vecnormalize) and not agents:
        raise OptionError("--algo and --vecnormalize go with --agent")
    if name and not agents:
        raise OptionError("--name names an --agent's method")
    episodes = episodes or EPISODES
    entry = None
    if named:
        try:
            entry = registry.resolve(named[0])
        except ValueError as exc:
            raise OptionError(str(exc) if isinstance(exc, registry.PolicyLoadError) else
                              f"unknown policy {named[0]!r}; choose from {', '.join(registry.policy_names())}, or "
                              "give a policy of your own as module:attr") from None
        if entry.kind != "import":  # a registered policy's track is its registration's
            registered_tier = getattr(entry.agent, "tier", None)
            if trained_on_tier and registered_tier != trained_on_tier:
                raise OptionError(
                    f"--trained-on-tier {trained_on_tier}: {entry.name} is registered "
                    + (f"as trained on tier {registered_tier!r}" if registered_tier else
                       "on the generalisation track") + "; --trained-on-tier is for a method of your own "
                    "(--policy module:attr, --agent PATH)")
            trained_on_tier = registered_tier
    try:
        scenes = unique([scene_of(resolve_env_id(e)) for e in envs]) if envs else None
        tiers = track_tier(trained_on_tier, unique(tiers) if tiers else None,
                           f"--trained-on-tier {trained_on_tier}" if trained_on_tier else "--tier")
        cells = benchmark_cells(scenes, tiers)
        seeds(episodes, RELEASE_SPLIT if release else SPLIT, release)
    except ValueError as exc:
        raise OptionError(str(exc)) from None
    problem = release_problem(cells, episodes, trained_on_tier) if release else None
    if problem:
        raise OptionError(problem)
    if ray_address and backend != "ray":
        raise OptionError("--ray-address needs --backend ray")
    env_ids = list(dict.fromkeys(c.env_id for c in cells))
    runs: dict[str, tuple[str | AgentArg, ...]] | None = None
    if agents:
        try:
            parsed = parse_agents([str(a) for a in agents], algo, vecnormalize)
            runs = runs_by_env(parsed, env_ids)
        except SubmissionError as exc:
            raise OptionError(str(exc)) from None
        entry = registry.resolve(f"{registry.USER_AGENT_PREFIX}{name or parsed[0].label}")
    else:
        assert entry is not None
        if entry.kind == "agent":
            from footstep_gym.rl.registry import agent_runs, missing_agents_note

            try:
                runs = {env_id: tuple(str(r) for r in agent_runs(entry.name, env_id, agents_dir)) for env_id in env_ids}
            except FileNotFoundError as exc:  # no agents folder
                raise OptionError(f"{entry.name}: {exc}") from None
            missing = [env_id for env_id, found in runs.items() if not found]
            if missing:
                raise OptionError(f"{entry.name}: no training run for {', '.join(missing)} "
                                  f"({missing_agents_note({entry.name: missing}, agents_dir)}); a benchmark "
                                  "row needs every scene (--env restricts it: a partial run)")
    return BenchmarkSettings(entry=entry, runs=runs, scenes=scenes, tiers=tiers, episodes=episodes, out=out,
                             workers=workers or usable_cores(), backend=backend, ray_address=ray_address,
                             trained_on_tier=trained_on_tier, split=RELEASE_SPLIT if release else SPLIT,
                             release=release)


def release_problem(cells: Sequence[BenchmarkCell], episodes: int, trained_on_tier: str | None = None,
                    state: row_protocol.TreeState | None = None) -> str | None:
    """Why a release run (the test split) of ``cells`` may not start, one line, or None: a row comes from committed
    code (``state``, default the package's checkout: :func:`~footstep_gym.evaluation.protocol.dirty_refusal`),
    covers its track's every cell, and runs :data:`EPISODES` seeds per cell (every row's number)."""
    if not is_complete(cells, trained_on_tier):
        return "--release runs a whole row: every cell of the benchmark (of its tier, in-distribution); drop --env/--tier"
    if episodes != EPISODES:
        return f"--release runs {EPISODES} episodes per cell (every row's number), not {episodes}"
    return row_protocol.dirty_refusal(state if state is not None else row_protocol.tree_state())


def start_release(settings: BenchmarkSettings, log: Path | None = None) -> dict[str, Any]:
    """Log a release run before its first episode: one line of the access log (``log``, default the repository's
    :data:`~footstep_gym.evaluation.protocol.ACCESS_LOG`); returns it as the row's ``run.release``."""
    state = row_protocol.tree_state()
    access = row_protocol.new_access(state.commit or "", settings.policy, len(settings.cells), settings.episodes,
                                     row_protocol.fingerprint())
    row_protocol.append_access(log if log is not None else row_protocol.access_log_path(), access)
    return access.to_dict()


def write_benchmark(folder: Path, settings: BenchmarkSettings, cells: list[Cell],
                    owners: list[BenchmarkCell], results: list[EpisodeResult], wall_s: float,
                    argv: Sequence[str], command: str | None = None, release: Mapping[str, Any] | None = None
                    ) -> tuple[str, list[Path]]:
    """``benchmark.json``, ``benchmark.md``, ``episodes.csv`` and ``run.json`` of a finished run, into ``folder``
    (``command``: how it was run, default ``eval_planner.py`` with ``argv``; ``release``: the access log's line of a
    release run). Paths are recorded relative to the repository
    (:func:`~footstep_gym.evaluation.protocol.repo_path`)."""
    command = command or row_protocol.repo_command(argv)
    run_info = {"command": command, "mode": "benchmark", "policy": settings.policy,
                "episodes": settings.episodes, "split": settings.split,
                "workers": settings.workers,
                "backend": settings.backend, "wall_time_s": round(wall_s, 2), "cpu_count": os.cpu_count(),
                "agent_runs": sorted({row_protocol.repo_path(c.run) for c in cells if c.run})}
    if release is not None:
        run_info["release"] = dict(release)
    source = settings.entry.source
    if source is not None:  # a policy of one's own: where it came from, and which version of it
        run_info["policy_source"] = {"import_path": source.path, "file": row_protocol.repo_path(source.file),
                                     "sha256": source.sha256}
    if isinstance(settings.factory, CallableFactory):
        run_info["policy_source"] = {"callable": settings.factory.name, "pickle_sha256": settings.factory.key}
    records = cell_records(cells, owners, results, settings.entry.reads_truth)
    doc = benchmark_document(settings.entry, settings.cells, records, settings.episodes, run_info,
                             settings.trained_on_tier, settings.split, settings.release)
    text = markdown(doc, command)
    files = [folder / "benchmark.json", folder / "benchmark.md", folder / "episodes.csv", folder / "run.json"]
    files[0].write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    files[1].write_text(text, encoding="utf-8")
    report.write_csv(files[2], report.episode_table(cells, results))
    files[3].write_text(json.dumps({**run_info, "complete": doc["complete"],
                                    "footstep_gym": footstep_gym.__version__}, indent=2) + "\n", encoding="utf-8")
    row = text.split("## Leaderboard row\n\n", 1)[1].split("\n\n", 1)[0]
    return row, files


def run_benchmark(settings: BenchmarkSettings, argv: Sequence[str], refuse: Callable[[str], NoReturn]) -> int:
    """Check every cell and ``settings.out`` first (a problem goes to ``refuse``, one line: nothing is written), run
    the episodes, write into a temporary folder that replaces ``settings.out`` once finished (as an evaluation
    does); returns the exit status."""
    runs = settings.runs
    cells, owners = runner_cells(settings.cells, settings.entry,
                                 None if runs is None else (lambda env_id: runs.get(env_id, ())))
    problem = check_cells(cells, factory=settings.factory) or check_out(settings.out)
    if problem:
        refuse(problem)
    all_tasks = tasks(cells, settings.episodes, settings.split, settings.release)
    workers = max(1, min(settings.workers, len(all_tasks)))
    per_run = f" ({len(cells)} with the training runs)" if len(cells) != len(settings.cells) else ""
    print(f"benchmark of {settings.policy}: {plural(len(settings.cells), 'cell')}{per_run} x "
          f"{plural(settings.episodes, 'seed')} = {plural(len(all_tasks), 'episode')} on {workers} worker(s) "
          f"({settings.backend}) -> {settings.out}", file=sys.stderr)
    release = start_release(settings) if settings.release else None  # logged before the first test episode

    def work(folder: Path) -> tuple[str, list[Path], str]:
        t0 = time.perf_counter()
        results = run_tasks(all_tasks, workers, backend=settings.backend, address=settings.ray_address,
                            factory=settings.factory)
        wall = time.perf_counter() - t0
        row, files = write_benchmark(folder, settings, cells, owners, results, wall, argv, release=release)
        return row, files, f"{len(results)} episodes in {wall:.1f} s"

    return run_into(settings.out, "the benchmark", "benchmark.md: every cell", work)


# ---------------------------------------------------------------- the library's way in
def _check_factory(make_policy_fn: Any) -> None:
    """``ValueError`` (one line) unless ``make_policy_fn`` is a callable that takes ``(scene, seed)``: a plain
    ``observation -> action`` function given in its place is named as such."""
    import inspect

    if not callable(make_policy_fn):
        raise ValueError(f"evaluate: make_policy_fn must be a function (scene, seed) -> policy, got a "
                         f"{type(make_policy_fn).__name__}")
    try:
        signature = inspect.signature(make_policy_fn)
    except (TypeError, ValueError):  # a builtin without a signature: its call says what is wrong
        return
    try:
        signature.bind("door", 0)
    except TypeError:
        label = getattr(make_policy_fn, "__name__", type(make_policy_fn).__name__)
        raise ValueError(f"evaluate: make_policy_fn must take (scene, seed) and return a policy (a Policy or an "
                         f"observation -> action callable); {label}{signature} does not: to evaluate an observation "
                         f"-> action function f itself, pass make_policy_fn=lambda scene, seed: f") from None


def evaluate(make_policy_fn: Callable[[str, int], Any], *, name: str, out: str | Path, snapshot: bool = False,
             episodes: int = EPISODES, scenes: Sequence[str] | None = None, tiers: Sequence[str] | None = None,
             workers: int | None = None, backend: str = "local", ray_address: str | None = None,
             trained_on_tier: str | None = None, split: str = SPLIT, release: bool = False) -> dict[str, Any]:
    """Run the benchmark for any policy and write ``benchmark.json`` (and ``benchmark.md``, ``episodes.csv``,
    ``run.json``) to ``out``, as ``eval_planner.py --benchmark`` does; returns the ``benchmark.json`` document.

    Args:
        make_policy_fn: ``make_policy_fn(scene, seed)`` called once per episode in the worker that runs it
            (``scene``: ``door``, ``crossing``, ``crowd``; ``seed``: the episode's), returning a
            :class:`~footstep_gym.policy.Policy` or any callable ``observation -> action`` (with
            ``snapshot=True``: ``(observation, snapshot) -> action``, the snapshot being
            ``env.unwrapped.sensing()``), the action the footstep command ``[S, L, θ, T_SS, T_DS]``
            in SI units (a numpy array, a torch tensor or a JAX array). It goes to the workers pickled
            with cloudpickle, its own module by value, so it may be a closure or a lambda.
        name: the method's name in the tables.
        out: the output folder (an earlier run's files there are replaced once this run has finished).
        episodes: seeds per cell (:data:`EPISODES`, the leaderboard's number; fewer for a quick try).
        scenes, tiers: only these (a partial run, no leaderboard row); ``None``: every one.
        workers, backend, ray_address: as ``eval_planner.py``'s ``--workers``, ``--backend``, ``--ray-address``.
        trained_on_tier: the method trained on this tier's cells (train-split seeds): the in-distribution
            track, run on that tier only; ``None``: the generalisation track (trained on ``train``).
        split: the seeds' split (``configs/eval.yaml``) of a development run: ``"validation"`` (the default) to try
            a method out; never a board row.
        release: run the test split instead (the board's row: committed code, every cell, logged in the access
            log; ``split="test"`` without it is refused).

    Raises ``ValueError`` (one line) before anything runs for a bad option or a policy that cannot be built
    or returns no 5-number command on the first cell's first observation;
    :class:`~footstep_gym.evaluation.runner.PolicyFailed` if it fails in an episode (``out`` is then left as
    it was).
    """
    from footstep_gym.evaluation.outfolder import commit_out, new_run_folder

    if not name or not isinstance(name, str):
        raise ValueError("evaluate: name= the method's name in the tables")
    if name in registry.policy_names():
        raise ValueError(f"evaluate: name {name!r} is a registered policy's; choose another for your method")
    _check_factory(make_policy_fn)
    for arg, value, what in (("episodes", episodes, "seeds per cell"), ("workers", workers, "worker processes")):
        if value is None and arg == "workers":
            continue
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"evaluate: {arg} must be a whole number >= 1 ({what}), got {value!r}")
    out = Path(out)
    try:
        tiers = track_tier(trained_on_tier, tiers, "trained_on_tier")
        cells = benchmark_cells(scenes, tiers)
        if release:
            split = RELEASE_SPLIT
        seeds(episodes, split, release)
    except ValueError as exc:
        raise ValueError(f"evaluate: {exc}") from None
    problem = release_problem(cells, episodes, trained_on_tier) if release else None
    if problem:
        raise ValueError(f"evaluate: {problem}")
    if backend == "local" and ray_address is not None:
        raise ValueError("evaluate: ray_address needs backend='ray'")
    factory = CallableFactory(make_policy_fn, name, snapshot)
    entry = registry.PolicyEntry(name, "callable", f"{name}: a callable evaluated with footstep_gym.benchmark.evaluate",
                                 factory)
    settings = BenchmarkSettings(entry=entry, runs=None, scenes=tuple(scenes) if scenes else None,
                                 tiers=tuple(tiers) if tiers else None, episodes=episodes, out=out,
                                 workers=workers or usable_cores(), backend=backend, ray_address=ray_address,
                                 factory=factory, trained_on_tier=trained_on_tier, split=split, release=release)
    runner, owners = runner_cells(cells, entry)
    problem = check_cells(runner, factory=factory) or check_out(out)
    if problem:
        raise ValueError(f"evaluate: {problem}")
    all_tasks = tasks(runner, episodes, split, release)
    logged = start_release(settings) if release else None
    folder = new_run_folder(out)
    try:
        t0 = time.perf_counter()
        results = run_tasks(all_tasks, max(1, min(settings.workers, len(all_tasks))), backend=backend,
                            address=ray_address, factory=factory)
        write_benchmark(folder, settings, runner, owners, results, time.perf_counter() - t0, [],
                        command=f"footstep_gym.benchmark.evaluate(make_policy_fn, name={name!r}, episodes={episodes}"
                                + (", release=True)" if release else f", split={split!r})" if split != SPLIT else ")"),
                        release=logged)
    except BaseException:
        import shutil

        shutil.rmtree(folder, ignore_errors=True)
        raise
    commit_out(folder, out)
    return json.loads((out / "benchmark.json").read_text(encoding="utf-8"))
