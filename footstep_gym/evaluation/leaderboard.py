"""The leaderboard across policies: several ``benchmark.json`` files, one table and rliable's figures.

``python baselines/make_leaderboard.py`` (docs/benchmark.md §4) is a thin front-end to this module:

* :func:`find_benchmarks` and :func:`load_benchmark`: the files (a ``benchmark.json``, a folder holding one, or a
  folder whose sub-folders hold one each), checked to be benchmark files of :data:`PROTOCOL_VERSION`;
  :func:`check_compatible`: all of one protocol (``env_configs_sha256``, ``episodes_per_cell``) and one file per
  policy. A problem raises :class:`LeaderboardError` (one line);
* :func:`build`: the leaderboard (what ``leaderboard.json`` holds): per policy and tier the score matrix
  (:func:`~footstep_gym.evaluation.stats.score_matrix`, the benchmark's own: a row per training run, a column per
  cell of the tier, every scene's), its IQM and optimality gap (threshold 1.0: the mean of ``max(0, 1 - success)``)
  with rliable's stratified-bootstrap 95 % intervals over training runs
  (:func:`~footstep_gym.evaluation.stats.interval_estimates`; one run, a planner's: the interval is the point), and
  per policy, tier and scene the mean success over the cells with the pooled Wilson interval
  (:func:`per_scene`);
* :func:`headline_markdown` (the table the README shows; a row of another protocol, admitted by ``--allow-mixed``,
  marked ‡), :func:`scene_markdown` and :func:`markdown` (``leaderboard.md``);
* :func:`write_figures`: ``iqm_per_tier.png`` (every tier side by side), ``iqm_optimality_gap_<tier>.png`` (IQM
  and optimality gap per tier) and ``performance_profiles.png`` (rliable's ``plot_performance_profiles``),
  matplotlib's Agg backend, drawn for a width of 900 px;
* :func:`write_leaderboard`: every file, written into a temporary folder beside ``out`` and then moved in one by
  one (:data:`OWN_FILES`; a user's other files in ``out``, such as the policies' own folders, are left alone).

Two tracks (docs/benchmark.md): a file whose method trained on ``train`` (``"track": "generalisation"``, every
file without the key) is a row of the headline table and the figures, ``board["policies"]``; one whose method
trained on tier T's cells (``"track": "in-distribution"``, ``"trained_on_tier": T``) is a row of the
in-distribution table, ``board["in_distribution"]`` (:func:`in_distribution_markdown`), complete when it covers
every cell of T, shown beside the generalisation track's learned rows and upper bounds on the same tiers.

A policy that covers only some of a tier's cells (a partial run, ``"complete": false``) gets its aggregate over the
cells it covers, marked as such in the tables, and is left out of that tier's figures (they compare policies on
the same cells). A policy with fewer runs for some scene is cut to the fewest, as the benchmark's own aggregate
(:func:`footstep_gym.evaluation.benchmark.tier_aggregates`) does, so the IQM here is the one in that policy's
``benchmark.json``, and so is its interval (the same resamples, seed and seeded bootstrap,
:func:`footstep_gym.evaluation.stats.seeded_bootstrap`).
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from footstep_gym.evaluation.benchmark import GENERALISATION, IN_DISTRIBUTION
from footstep_gym.evaluation import fullbody_column
from footstep_gym.evaluation import protocol as row_protocol
from footstep_gym.evaluation.outfolder import new_run_folder
from footstep_gym.evaluation.records import CellRecord
from footstep_gym.evaluation.scores import board_scores
from footstep_gym.evaluation.splits import PROTOCOL_VERSION  # the version benchmark.json files must carry
from footstep_gym.evaluation.stats import REPS, SEED, interval_estimates, score_matrix, seeded_bootstrap as seeded
from footstep_gym.evaluation.stats import wilson_interval
from footstep_gym.evaluation.tables import DASH, interval, markdown as markdown_table, plural

#: The protocol versions this leaderboard reads: protocol 2's rows (no fingerprint, no access log; their board is
#: labelled "protocol 2") and the present protocol's.
VERSIONS = (2, PROTOCOL_VERSION)
#: The protocol fields that files must share (``--allow-mixed`` lifts this; the rows that differ are marked).
PROTOCOL_KEYS = ("env_configs_sha256", "episodes_per_cell")
#: The optimality gap's threshold: a success rate of 1 is optimal (rliable's ``gamma``).
GAMMA = 1.0
#: The thresholds of the performance profiles (success rates).
TAUS = np.linspace(0.0, 1.0, 101)
#: The file names this module writes (with ``iqm_optimality_gap_<tier>.png`` per tier); nothing else in the
#: output folder is touched.
FIGURE_IQM = "iqm_per_tier.png"
FIGURE_PROFILES = "performance_profiles.png"
#: Protocol 3's headline figure (:func:`scores_figure`): scene-balanced success and safe success per tier.
FIGURE_SCORES = "success_per_tier.png"
#: What :data:`FIGURE_SCORES` draws, as leaderboard.md and docs/results.md caption it.
FIGURE_SCORES_CAPTION = ("per tier, each generalisation row's scene-balanced success (bar) with its hierarchical 95 % "
                         "interval (whisker) and its safe success (circle), the rows in rank order, the privileged "
                         "starred.")
OWN_FILES = ("leaderboard.md", "leaderboard.json", FIGURE_SCORES, FIGURE_IQM, FIGURE_PROFILES)


def tier_figure_name(tier: str) -> str:
    """The file of one tier's IQM and optimality-gap figure."""
    return f"iqm_optimality_gap_{tier}.png"


class LeaderboardError(ValueError):
    """Bad input (one line): the script reports it with exit status 2 and writes nothing."""


# ---------------------------------------------------------------- input
def find_benchmarks(paths: Sequence[Path]) -> list[Path]:
    """The ``benchmark.json`` files ``paths`` name: a file, a folder holding ``benchmark.json``, or a folder whose
    sub-folders hold one each (as ``baselines/results/benchmark/``), in that order (sub-folders by name)."""
    found: list[Path] = []
    for path in paths:
        if path.is_file():
            found.append(path)
        elif (path / "benchmark.json").is_file():
            found.append(path / "benchmark.json")
        elif path.is_dir():
            inner = sorted(p / "benchmark.json" for p in path.iterdir() if (p / "benchmark.json").is_file())
            if not inner:
                raise LeaderboardError(f"{path}: no benchmark.json in it or in its sub-folders")
            found += inner
        else:
            raise LeaderboardError(f"{path}: no such file or folder")
    unique: list[Path] = []
    for p in found:
        if p.resolve() not in {u.resolve() for u in unique}:
            unique.append(p)
    return unique


def load_benchmark(path: Path) -> dict[str, Any]:
    """One ``benchmark.json``, checked to be a footstep_gym benchmark file of a version in :data:`VERSIONS` with its
    records (from protocol 3 on, with its ``protocol.fingerprint`` and ``protocol.split``)."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise LeaderboardError(f"{path}: not a readable JSON file ({exc})") from None
    if not isinstance(doc, dict) or doc.get("benchmark") != "footstep_gym":
        raise LeaderboardError(f"{path}: not a footstep_gym benchmark.json (no \"benchmark\": \"footstep_gym\")")
    if doc.get("protocol_version") not in VERSIONS:
        raise LeaderboardError(f"{path}: protocol_version {doc.get('protocol_version')!r}, this leaderboard reads "
                               f"{' and '.join(map(str, VERSIONS))}")
    protocol = doc.get("protocol")
    records = doc.get("records")
    if (not isinstance(protocol, dict) or not isinstance(records, list) or not records
            or not isinstance(doc.get("policy"), str)):
        raise LeaderboardError(f"{path}: a benchmark.json needs \"policy\", \"protocol\" and non-empty \"records\"")
    try:
        loaded = [CellRecord.from_dict(r) for r in records]
    except (TypeError, ValueError) as exc:
        raise LeaderboardError(f"{path}: {exc}") from None
    if any(r.scene is None or r.tier is None or r.cell is None for r in loaded):
        raise LeaderboardError(f"{path}: a record lacks its benchmark cell (scene, tier, cell)")
    needed = ("env_configs_sha256", "episodes_per_cell", "tiers", "scenes", "cells")
    if doc["protocol_version"] >= 3:
        needed += ("fingerprint", "split")
    for key in needed:
        if key not in protocol:
            raise LeaderboardError(f"{path}: protocol lacks {key!r}")
    return {**doc, "records": loaded}


def check_compatible(docs: Sequence[Mapping[str, Any]], paths: Sequence[Path], allow_mixed: bool = False) -> None:
    """Raise :class:`LeaderboardError` unless the files are of one protocol (the same ``env_configs_sha256`` and
    ``episodes_per_cell``; ``allow_mixed`` lifts this) and each policy is in one file."""
    if not docs:
        raise LeaderboardError("no benchmark.json given")
    seen: dict[str, Path] = {}
    for doc, path in zip(docs, paths):
        if doc["policy"] in seen:
            raise LeaderboardError(f"policy {doc['policy']!r} is in both {seen[doc['policy']]} and {path}; give one")
        seen[doc["policy"]] = path
    if allow_mixed:
        return
    for key in PROTOCOL_KEYS:
        groups: dict[str, list[Path]] = {}
        for doc, path in zip(docs, paths):
            groups.setdefault(str(doc["protocol"][key]), []).append(path)
        if len(groups) > 1:
            board = max(groups, key=lambda v: len(groups[v]))  # the value most files have (the first on a tie)

            def said(value: str) -> str:
                return f"{value} episodes per cell" if key == "episodes_per_cell" else f"env configs {value[:12]}"

            yours = "; ".join(f"{_files(found)}: {said(v)}" for v, found in groups.items() if v != board)
            raise LeaderboardError(f"the files differ in protocol.{key}: {yours}; the board "
                                   f"({_files(groups[board])}): {said(board).removesuffix(' episodes per cell')}; "
                                   "rerun on one protocol or pass --allow-mixed")


def _files(paths: Sequence[Path]) -> str:
    """The first of ``paths``, and how many more: ``a/benchmark.json`` or ``a/benchmark.json and 30 more``."""
    return str(paths[0]) + (f" and {len(paths) - 1} more" if len(paths) > 1 else "")


def check_rows(docs: Sequence[Mapping[str, Any]], paths: Sequence[Path], fingerprint: str | None = None,
               access_log: Path | None = None) -> None:
    """Raise :class:`LeaderboardError` (one line) unless the files make one board: of one protocol version; from
    protocol 3 on, every row of the board's fingerprint (``fingerprint``, default this checkout's
    :func:`~footstep_gym.evaluation.protocol.fingerprint`), all of one split, and a test-split row's release a line
    of the access log (``access_log``, default the repository's). ``--allow-mixed`` lifts none of this."""
    versions = _ordered([doc["protocol_version"] for doc in docs])
    if len(versions) > 1:
        which = ", ".join(f"{p} ({d['protocol_version']})" for d, p in zip(docs, paths))
        raise LeaderboardError(f"the files are of protocols {' and '.join(map(str, versions))}: {which}; a board is "
                               "of one protocol")
    if versions[0] < 3:
        return
    board = fingerprint if fingerprint is not None else row_protocol.fingerprint()
    for doc, path in zip(docs, paths):
        mine = str(doc["protocol"]["fingerprint"])
        if mine != board:
            raise LeaderboardError(f"{path}: fingerprint {mine[:12]} (yours) / {board[:12]} (the board's): another "
                                   "simulator or configs made it; rerun it on this checkout")
    splits = _ordered([doc["protocol"]["split"] for doc in docs])
    if len(splits) > 1:
        raise LeaderboardError(f"the files mix the {' and '.join(splits)} splits; a board is of one (test: the "
                               "release rows; validation: a development board)")
    if splits[0] != row_protocol.TEST_SPLIT:
        return
    log_path = access_log if access_log is not None else row_protocol.access_log_path()
    try:
        log = row_protocol.read_access_log(log_path)
    except ValueError as exc:
        raise LeaderboardError(str(exc)) from None
    for doc, path in zip(docs, paths):
        if not row_protocol.logged((doc.get("run") or {}).get("release"), log):
            raise LeaderboardError(f"{path}: its test-split run is not in the access log ({row_protocol.ACCESS_LOG}); "
                                   "a board row is made by eval_planner.py --benchmark --release")


# ---------------------------------------------------------------- scores
def _ordered(items: Sequence[Any]) -> list[Any]:
    return list(dict.fromkeys(items))


def tier_cells(docs: Sequence[Mapping[str, Any]]) -> dict[str, list[str]]:
    """Per tier, its cells (``scene/cell``) in protocol order: the union over the files' protocols (a complete
    file lists them all; files of one protocol agree on them)."""
    docs = sorted(docs, key=lambda d: -len(d["protocol"]["cells"]))  # the order of the file with the most cells
    cells: dict[str, list[str]] = {}
    for doc in docs:
        for t in doc["protocol"]["tiers"]:
            cells.setdefault(t, [])
        for c in doc["protocol"]["cells"]:
            key = f"{c['scene']}/{c['cell']}"
            if key not in cells.setdefault(c["tier"], []):
                cells[c["tier"]].append(key)
    return cells


def profile_estimates(matrix: np.ndarray, reps: int = REPS, seed: int = SEED, taus: np.ndarray = TAUS
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The performance profile of a ``(runs, tasks)`` matrix at ``taus`` and its 95 % stratified-bootstrap band
    (``rliable.library.create_performance_profile``, score distributions: :func:`profile`), :func:`seeded`."""
    from rliable import library as rly

    with seeded(seed):
        point, interval = rly.create_performance_profile(
            {"policy": np.asarray(matrix, dtype=float)}, taus, custom_profile_func=profile, reps=reps)
    return np.asarray(point["policy"], dtype=float), np.asarray(interval["policy"], dtype=float)


def iqm_and_gap(matrix: np.ndarray) -> np.ndarray:
    """``[IQM, optimality gap]`` of a ``(runs, tasks)`` matrix of success rates (rliable's ``aggregate_iqm`` and
    ``aggregate_optimality_gap`` at :data:`GAMMA`: the mean of ``max(0, 1 - score)``)."""
    from rliable import metrics

    return np.array([metrics.aggregate_iqm(matrix), metrics.aggregate_optimality_gap(matrix, GAMMA)])


def profile(matrix: np.ndarray, taus: np.ndarray = TAUS) -> np.ndarray:
    """rliable's score distribution (``library.score_distributions``, vectorised): for each threshold, the share of
    the ``runs x cells`` success rates above it."""
    return (np.asarray(matrix, dtype=float).reshape(-1)[:, None] > np.asarray(taus)[None, :]).mean(axis=0)


def _records(doc: Mapping[str, Any]) -> list[CellRecord]:
    return [r if isinstance(r, CellRecord) else CellRecord.from_dict(r) for r in doc["records"]]


def per_scene(doc: Mapping[str, Any], tiers: Sequence[str], scenes: Sequence[str]) -> list[dict[str, Any]]:
    """Per tier and scene the policy has records of: the mean over the scene's cells of the success pooled over
    training runs, and the Wilson 95 % interval of all their episodes pooled (runs and cells)."""
    df = pd.DataFrame([(r.tier, r.scene, r.cell, r.successes, r.episodes) for r in _records(doc)],
                      columns=["tier", "scene", "cell", "successes", "episodes"])
    out = []
    for tier in tiers:
        for scene in scenes:
            rs = df[(df["tier"] == tier) & (df["scene"] == scene)]
            if rs.empty:
                continue
            by_cell = rs.groupby("cell", sort=False)
            pooled = by_cell["successes"].sum() / by_cell["episodes"].sum()
            wins, n = int(rs["successes"].sum()), int(rs["episodes"].sum())
            out.append({"policy": doc["policy"], "tier": tier, "scene": scene, "success_mean": float(pooled.mean()),
                        "success_ci95": list(wilson_interval(wins, n)), "cells": list(pooled.index),
                        "runs": int(by_cell.size().min()), "episodes": n})
    return out


# ---------------------------------------------------------------- the leaderboard
def _shown(path: Path) -> str:
    """``path`` relative to the working folder where it is inside it (the same text on every machine)."""
    try:
        return str(Path(path).absolute().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def _label(doc: Mapping[str, Any]) -> str:
    label = doc.get("label") or doc["policy"]
    if doc.get("upper_bound") and "(upper bound)" not in label:
        label += " (upper bound)"
    return label


def default_agents_dir() -> Path | None:
    """This checkout's shipped agents, ``baselines/agents/`` (None outside a source checkout)."""
    root = row_protocol.repo_root()
    return None if root is None else root / "baselines" / "agents"


def training_of(doc: Mapping[str, Any], agents_dir: Path | None) -> dict[str, Any] | None:
    """A learned row's training under the compute protocol (:func:`footstep_gym.rl.compute.row_training`: env steps
    per run against its track's declared budget, runs converged) from its shipped agents' manifests and curves;
    None for a row that does not learn."""
    from footstep_gym.rl import compute

    runs = (doc.get("run") or {}).get("agent_runs") or []
    if not runs:
        return None
    proto = compute.load_protocol()
    trained_on = doc.get("trained_on_tier") if doc.get("track") == IN_DISTRIBUTION else None
    return compute.row_training(runs, agents_dir if agents_dir is not None else Path("baselines/agents"),
                                proto.budget(trained_on), proto.window)


def build(docs: Sequence[Mapping[str, Any]], paths: Sequence[Path] | None = None, reps: int = REPS,
          seed: int = SEED, fullbody: Mapping[str, Any] | None = None,
          agents_dir: Path | None = None) -> dict[str, Any]:
    """The leaderboard of ``docs`` (checked files): what ``leaderboard.json`` holds, and all the tables and
    figures are drawn from. Policies are ordered: complete runs by the mean of their tiers' IQMs (best first),
    then partial runs, then upper bounds. ``fullbody``: a full-body summary
    (:func:`footstep_gym.evaluation.fullbody_column.load_summary`), shown as a column beside its tier. A learned
    row's ``training`` (:func:`training_of`) reads its shipped agents under ``agents_dir`` (default
    :func:`default_agents_dir`)."""
    agents_dir = agents_dir if agents_dir is not None else default_agents_dir()
    cells = tier_cells(docs)
    tiers = list(cells)
    scenes = _ordered([c.split("/")[0] for cs in cells.values() for c in cs])
    paths = list(paths) if paths is not None else [None] * len(docs)
    policies, in_distribution, aggregates, scene_rows = [], [], [], []
    for doc, path in zip(docs, paths):
        name = doc["policy"]
        trained_on = doc.get("trained_on_tier") if doc.get("track") == IN_DISTRIBUTION else None
        rows = []
        records = _records(doc)
        for tier in ([trained_on] if trained_on else tiers):
            matrix, covered = score_matrix([r for r in records if r.tier == tier], cells[tier])
            if not covered:
                continue
            (iqm, gap), bounds = interval_estimates(matrix, iqm_and_gap, reps, seed)
            rows.append({
                "policy": name, "tier": tier, "upper_bound": bool(doc.get("upper_bound")),
                "covers_tier": len(covered) == len(cells[tier]),
                "iqm": float(iqm), "iqm_ci95": [float(bounds[0, 0]), float(bounds[1, 0])],
                "optimality_gap": float(gap), "optimality_gap_ci95": [float(bounds[0, 1]), float(bounds[1, 1])],
                "success_mean": float(matrix.mean()), "runs": int(matrix.shape[0]), "cells": covered,
                "missing_cells": [c for c in cells[tier] if c not in covered],
                "scores": matrix.tolist(),
            })
        aggregates += rows
        scene_rows += per_scene(doc, tiers, scenes)
        covered_all = (all(r["covers_tier"] for r in rows)
                       and {r["tier"] for r in rows} == ({trained_on} if trained_on else set(tiers)))
        (in_distribution if trained_on else policies).append({
            "policy": name, "label": _label(doc), "upper_bound": bool(doc.get("upper_bound")),
            "track": IN_DISTRIBUTION if trained_on else GENERALISATION, "trained_on_tier": trained_on,
            "learned": bool((doc.get("run") or {}).get("agent_runs")),
            "complete": bool(doc.get("complete")) and covered_all,
            "scenes": _ordered([s for s in scenes if any(r.scene == s for r in records)]),
            "protocol": {key: doc["protocol"].get(key) for key in PROTOCOL_KEYS},
            "runs": sorted({r["runs"] for r in rows}),
            "source": None if path is None else _shown(path),
            "description": doc.get("description", ""),
            "training": training_of(doc, agents_dir),
        })

    def rank(p: Mapping[str, Any]) -> tuple:
        iqms = [a["iqm"] for a in aggregates if a["policy"] == p["policy"]]
        return (p["upper_bound"], not p["complete"], -float(np.mean(iqms)) if iqms else 0.0, p["policy"])

    generalisation = {p["policy"] for p in policies}
    trained = {p["policy"]: p["trained_on_tier"] for p in in_distribution}
    scores = board_scores([(d["policy"], bool(d.get("upper_bound")), _records(d)) for d in docs
                           if d["policy"] in generalisation], cells, reps, seed,
                          in_distribution=[(d["policy"], trained[d["policy"]], _records(d)) for d in docs
                                           if d["policy"] in trained])
    version = docs[0].get("protocol_version", PROTOCOL_VERSION)
    if version >= 3:  # protocol 3 ranks by the scene-balanced success over the ranked tiers
        place = {r["policy"]: i for i, r in enumerate(scores["ranking"])}
        policies.sort(key=lambda p: (p["policy"] not in place, place.get(p["policy"], 0), *rank(p)))
    else:
        policies.sort(key=rank)
    in_distribution.sort(key=lambda p: (tiers.index(p["trained_on_tier"]), *rank(p)))
    order = {p["policy"]: i for i, p in enumerate(policies + in_distribution)}
    aggregates.sort(key=lambda a: (tiers.index(a["tier"]), order[a["policy"]]))
    scene_rows.sort(key=lambda a: (tiers.index(a["tier"]), scenes.index(a["scene"]), order[a["policy"]]))
    protocol: dict[str, Any] = {}
    for key in ("env_configs_sha256", "episodes_per_cell", "split", "fingerprint"):
        values = _ordered([d["protocol"].get(key) for d in docs])
        protocol[key] = values[0] if len(values) == 1 else values  # a list: mixed files (--allow-mixed)
    return {
        "leaderboard": "footstep_gym", "protocol_version": version, "protocol": protocol,
        "tiers": tiers, "scenes": scenes, "tier_cells": cells,
        "bootstrap": {"reps": reps, "seed": seed, "confidence": 0.95, "gamma": GAMMA},
        "policies": policies, "in_distribution": in_distribution, "aggregates": aggregates,
        "per_scene": scene_rows, "scores": scores,
        **({"fullbody": dict(fullbody)} if fullbody else {}),
    }


def _aggregate(board: Mapping[str, Any], policy: str, tier: str) -> Mapping[str, Any] | None:
    return next((a for a in board["aggregates"] if a["policy"] == policy and a["tier"] == tier), None)


def in_figure(board: Mapping[str, Any], tier: str) -> tuple[list[Mapping[str, Any]], list[Mapping[str, Any]]]:
    """The policies of ``tier``'s figures (those covering every cell of it) and those left out (covering some)."""
    shown, left_out = [], []
    for p in board["policies"]:
        a = _aggregate(board, p["policy"], tier)
        if a is not None:
            (shown if a["covers_tier"] else left_out).append(p)
    return shown, left_out


# ---------------------------------------------------------------- markdown
def _runs(runs: Sequence[int]) -> str:
    return DASH if not runs else str(runs[0]) if len(runs) == 1 else f"{min(runs)}–{max(runs)}"


def _usual_protocol(board: Mapping[str, Any]) -> dict[str, Any]:
    """The protocol most of the board's policies were run on (the first policy's on a tie)."""
    seen = [json.dumps(p["protocol"], sort_keys=True) for p in board["policies"] if "protocol" in p]
    return json.loads(max(seen, key=seen.count)) if seen else {}


def _other_protocol(board: Mapping[str, Any], p: Mapping[str, Any]) -> str | None:
    """How ``p``'s protocol differs from the board's usual one (``--allow-mixed``), or None."""
    usual = _usual_protocol(board)
    mine = p.get("protocol", usual)
    parts = []
    if mine.get("env_configs_sha256") != usual.get("env_configs_sha256"):
        parts.append(f"env configs {str(mine.get('env_configs_sha256'))[:12]}")
    if mine.get("episodes_per_cell") != usual.get("episodes_per_cell"):
        parts.append(f"{mine.get('episodes_per_cell')} episodes per cell")
    return ", ".join(parts) or None


def _partial_note(board: Mapping[str, Any], p: Mapping[str, Any]) -> str:
    tiers = [t for t in board["tiers"] if _aggregate(board, p["policy"], t) is not None]
    full = [t for t in tiers if _aggregate(board, p["policy"], t)["covers_tier"]]
    parts = []
    if len(p["scenes"]) < len(board["scenes"]):
        parts.append(f"scene{'s' if len(p['scenes']) > 1 else ''} {', '.join(p['scenes'])}")
    if len(tiers) < len(board["tiers"]):
        parts.append(f"tier{'s' if len(tiers) > 1 else ''} {', '.join(tiers)}")
    what = "; ".join(parts) + " only" if parts else "some cells only"
    return (f"{p['label']}: partial run ({what}); its aggregates are over the cells it covers (marked †), not "
            "comparable with the full rows" + (f" except on {', '.join(full)}" if full else ""))


def _fullbody_head(board: Mapping[str, Any]) -> list[str]:
    """The full-body column's header (none without a summary)."""
    fb = board.get("fullbody")
    return [f"full body ({fb['robot'].upper() if fb['robot'] == 'op3' else fb['robot']}, {fb['tier']})"] if fb else []


def _fullbody_cell(board: Mapping[str, Any], policy: str) -> list[str]:
    """The full-body column's cell of ``policy`` (none without a summary; – where it was not replayed)."""
    if not board.get("fullbody"):
        return []
    return [fullbody_column.cell(board["fullbody"], policy) or DASH]


def fullbody_note(board: Mapping[str, Any]) -> list[str]:
    """The line under a table with the full-body column."""
    fb = board.get("fullbody")
    if not fb:
        return []
    return [f"full body ({fb['robot']}, {fb['tier']}): the share of the method's {fb['tier']}-tier episodes "
            f"(validation seeds, every scene pooled; recorded through the env with robot {fb['robot']!r}) that walk "
            f"on the OP3 in MuJoCo without a fall (docs/fullbody.md), then (its env success on those episodes, "
            f"episodes; + k not admitted: an agent's episodes, recorded with the default robot it was trained on, "
            f"whose commands lie outside {fb['robot']!r}'s box or below its swing floor, not walked); – not replayed. "
            f"From baselines/results/fullbody/{fb['source']}."]


def headline_markdown(board: Mapping[str, Any]) -> str:
    """The leaderboard's table (the README's): a row per policy, a column per tier with the IQM success over the
    tier's cells [95 % CI], the training runs; partial runs after the complete ones, upper bounds last. A row of
    another protocol than the others' (``--allow-mixed``) is marked ‡."""
    tiers = board["tiers"]
    cells = board["tier_cells"]
    rows = []
    for p in board["policies"]:
        row = []
        for t in tiers:
            a = _aggregate(board, p["policy"], t)
            row.append(DASH if a is None else interval(a["iqm"], a["iqm_ci95"]) + ("" if a["covers_tier"] else " †"))
        label = p["label"] if p["complete"] else (f"{p['label'][:-1]}, partial)" if p["label"].endswith(")")
                                                  else f"{p['label']} (partial)")
        if _other_protocol(board, p):
            label += " ‡"
        if p["upper_bound"]:
            label = f"*{label}*"
        rows.append([label, _runs(p["runs"]), *row, *_fullbody_cell(board, p["policy"])])
    table = pd.DataFrame(rows, columns=["policy", "runs", *(f"{t} ({plural(len(cells[t]), 'cell')})" for t in tiers),
                                        *_fullbody_head(board)])
    return markdown_table(table).rstrip("\n")


def headline_notes(board: Mapping[str, Any]) -> list[str]:
    """The lines under the headline table: what the numbers are, the partial runs, the rows of another protocol."""
    b = board["bootstrap"]
    notes = [f"IQM of the success rates over every cell of the tier (all scenes) [95 % stratified-bootstrap "
             f"interval over training runs, rliable, {b['reps']} resamples, seed {b['seed']}; one run, a planner's: "
             "the interval is the point]; runs: training runs per cell. Rows: complete runs by the mean of their "
             "tiers' IQMs, then partial runs, then upper bounds (they read the true future; not baselines)."]
    notes += [_partial_note(board, p) + "." for p in board["policies"] if not p["complete"]]
    notes += fullbody_note(board)
    notes += [f"‡ {p['label']}: another protocol than the other rows ({_other_protocol(board, p)}; admitted by "
              "--allow-mixed): not comparable with them." for p in board["policies"] if _other_protocol(board, p)]
    return notes


def _in_distribution_scored(board: Mapping[str, Any]) -> bool:
    """Whether the board scores its in-distribution rows as protocol 3 does (scene-balanced, in ``scores``)."""
    s = board.get("scores") or {}
    return board.get("protocol_version", 0) >= 3 and any(r.get("trained_on_tier") for r in s.get("tiers", []))


def in_distribution_markdown(board: Mapping[str, Any]) -> str:
    """The in-distribution track's table: a row per method trained on a tier (its figure there, the other tiers –),
    then, on the same tiers, the generalisation track's learned rows (trained on ``train``) and upper bounds, for
    comparison. The figure: protocol 3's scene-balanced success [hierarchical 95 % CI] (``scores``), a protocol-2
    board's IQM over the tier's cells. Empty text when no file is on the track."""
    entries = board.get("in_distribution") or []
    if not entries:
        return ""
    tiers = [t for t in board["tiers"] if any(p["trained_on_tier"] == t for p in entries)]
    cells = board["tier_cells"]
    scored = _in_distribution_scored(board)
    by = {(r["policy"], r["tier"]): r for r in board["scores"]["tiers"]} if scored else {}
    rows = []
    others = [p for p in board["policies"] if p["complete"] and (p.get("learned") or p["upper_bound"])]
    for p in [*entries, *others]:
        row = []
        for t in tiers:
            if p["trained_on_tier"] not in (None, t):
                row.append(DASH)
            elif scored:
                r = by.get((p["policy"], t))
                row.append(DASH if r is None else _score(r["success"], r["success_ci95"]))
            else:
                a = _aggregate(board, p["policy"], t)
                row.append(DASH if a is None else interval(a["iqm"], a["iqm_ci95"])
                           + ("" if a["covers_tier"] else " †"))
        label = p["label"] if p["complete"] else f"{p['label']} (partial)"
        rows.append([f"*{label}*" if p["upper_bound"] else label,
                     p["trained_on_tier"] or ("no training" if not p.get("learned") else "train"),
                     _runs(p["runs"]), *row])
    table = pd.DataFrame(rows, columns=["policy", "trained on", "runs",
                                        *(f"{t} ({plural(len(cells[t]), 'cell')})" for t in tiers)])
    return markdown_table(table, left=2).rstrip("\n")


def in_distribution_notes(board: Mapping[str, Any]) -> list[str]:
    """The lines under the in-distribution table."""
    entries = board.get("in_distribution") or []
    if not entries:
        return []
    figure = ("the scene-balanced success over the tier's cells [95 % hierarchical bootstrap interval], as in the "
              "scored table above" if _in_distribution_scored(board) else
              "IQM over the tier's cells [95 % stratified-bootstrap interval over training runs], as in the table "
              "above")
    notes = ["Methods trained on a tier's cells (its train-split seeds) and tested on that tier's test seeds only; "
             "below them, for comparison on the same tiers, the generalisation track's learned methods (trained on "
             f"`train`) and the upper bounds. Per tier: {figure}. Methods that do not learn (planners, null "
             "baselines) score the same on both tracks: the table above."]
    notes += [f"{p['label']}: partial run (not every cell of {p['trained_on_tier']}); marked †."
              for p in entries if not p["complete"]]
    return notes


def training_markdown(board: Mapping[str, Any]) -> str:
    """The learned rows' training under the compute protocol (docs/benchmark.md): per row (both tracks) its
    env steps per run against its track's declared budget, the runs whose validation curve converged, the median
    wall time per run and the CPU time of all its runs; empty text without learned rows."""
    from footstep_gym.rl.compute import short_steps, steps_text

    rows = []
    for p in [*board["policies"], *(board.get("in_distribution") or [])]:
        t = p.get("training")
        if not t:
            continue
        rows.append([p["label"], p["trained_on_tier"] or "train", str(t["runs"]), steps_text(t),
                     short_steps(t["declared_budget"]) if t["declared_budget"] else DASH,
                     DASH if t["at_budget"] is None else ("yes" if t["at_budget"] else "no"),
                     f"{t['converged']}/{t['with_curve']}" if t["with_curve"] else "no curves",
                     DASH if t["median_wall_time_s"] is None else f"{t['median_wall_time_s']:,.0f}",
                     DASH if t["cpu_time_s"] is None else f"{t['cpu_time_s']:,.0f}"])
    if not rows:
        return ""
    table = pd.DataFrame(rows, columns=["policy", "trained on", "runs", "env steps per run", "declared budget",
                                        "at budget", "converged", "median wall s per run", "CPU s (all runs)"])
    return markdown_table(table, left=2).rstrip("\n")


def training_notes(board: Mapping[str, Any]) -> list[str]:
    """The lines under the training table: the rule, the curves' sources, the runs not found."""
    from footstep_gym.rl.compute import plateau_tolerance

    learned = [p for p in [*board["policies"], *(board.get("in_distribution") or [])] if p.get("training")]
    if not learned:
        return []
    notes = ["Compute protocol (docs/benchmark.md): the budget is declared per track in env steps per training run "
             "(configs/compute.yaml); rows below it stay, labelled with their budget (the sample-efficiency view). "
             "Converged: the run's last 3 validation points within ceil(0.5 sqrt(n)) / n of one another, n the "
             f"episodes per point ({plateau_tolerance(40):.3f} at 40, {plateau_tolerance(20):.3f} at 20). CPU s: "
             "where every run's manifest records it (ppo-jax and later runs)."]
    zoo = [p["label"] for p in learned if "zoo evaluation" in p["training"]["curve_sources"]]
    if zoo:
        notes.append(f"{', '.join(zoo)}: some runs have no validation curve; their convergence is read from rl_zoo3's "
                     "periodic evaluation (its eval env's seeds, not the validation split).")
    missing = [f"{p['label']} ({len(p['training']['missing_runs'])})" for p in learned
               if p["training"]["missing_runs"]]
    if missing:
        notes.append(f"Runs named by the benchmark file but not shipped here (not counted): {', '.join(missing)}.")
    return notes


def _ranked_order(board: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The board's generalisation rows, the ranked ones first in rank order (protocol 3's score), then the others in
    the board's order."""
    place = {r["policy"]: i for i, r in enumerate(board["scores"]["ranking"])}
    return sorted(board["policies"], key=lambda p: (p["policy"] not in place, place.get(p["policy"], 0)))


def _score(value: float | None, ci: Sequence[float] | None = None) -> str:
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return DASH
    return interval(value, ci) if ci is not None else f"{value:.2f}"


def scores_markdown(board: Mapping[str, Any], p_next: bool = True) -> str:
    """Protocol 3's table: a row per policy (the ranked rows best first, then the others, the privileged last), per
    tier the scene-balanced success [hierarchical 95 % CI], then the rank score over the ranked tiers, the safe
    success's, and (``p_next``) the probability of improvement over the next ranked row of the whole board."""
    s = board["scores"]
    labels = {p["policy"]: p["label"] for p in board["policies"]}
    by = {(r["policy"], r["tier"]): r for r in s["tiers"]}
    ranked = {r["policy"]: r for r in s["ranking"]}
    rows = []
    for p in _ranked_order(board):
        name = p["policy"]
        r = ranked.get(name)
        label = f"*{labels[name]}*" if p["upper_bound"] else labels[name]
        rows.append([label, *(_score(by[(name, t)]["success"], by[(name, t)]["success_ci95"]) if (name, t) in by
                              else DASH for t in board["tiers"]),
                     _score(r["score"]) if r else DASH, _score(r["safe_score"]) if r else DASH,
                     *([_score(r["p_improvement"]) if r else DASH] if p_next else []), *_fullbody_cell(board, name)])
    head = ["policy", *(f"{t}{' (not ranked)' if t not in s['ranked_tiers'] else ''}" for t in board["tiers"]),
            "score", "safe score", *(["P(> next)"] if p_next else []), *_fullbody_head(board)]
    return markdown_table(pd.DataFrame(rows, columns=head)).rstrip("\n")


def safety_markdown(board: Mapping[str, Any]) -> str:
    """Per policy and tier: safe success [hierarchical 95 % CI] / time to goal over the successes [s] / the
    normalised score; and the IQM over runs where a row has enough runs."""
    s = board["scores"]
    by = {(r["policy"], r["tier"]): r for r in s["tiers"]}
    rows = []
    for p in _ranked_order(board):
        cells = []
        for t in board["tiers"]:
            r = by.get((p["policy"], t))
            cells.append(DASH if r is None else
                         f"{_score(r['safe_success'], r['safe_success_ci95'])} / "
                         f"{DASH if r['time_to_goal'] is None else format(r['time_to_goal'], '.1f')} / "
                         f"{_score(r['normalised'])}" + ("" if r["iqm"] is None else f" / IQM {r['iqm']:.2f}"))
        rows.append([f"*{p['label']}*" if p["upper_bound"] else p["label"], *cells])
    return markdown_table(pd.DataFrame(rows, columns=["policy", *board["tiers"]])).rstrip("\n")


def cells_markdown(board: Mapping[str, Any]) -> str:
    """Every cell (rows) and policy (columns): the success (mean over runs) and its normalised score."""
    s = board["scores"]
    by = {(r["policy"], r["tier"], r["cell"]): r for r in s["cells"]}
    policies = board["policies"]
    rows = []
    for tier, cells in board["tier_cells"].items():
        for cell in cells:
            row = []
            for p in policies:
                r = by.get((p["policy"], tier, cell))
                row.append(DASH if r is None else f"{r['success']:.2f}"
                           + ("" if r["normalised"] is None or np.isnan(r["normalised"]) else f" ({r['normalised']:+.2f})"))
            rows.append([tier, cell, *row])
    return markdown_table(pd.DataFrame(rows, columns=["tier", "cell", *(p["label"] for p in policies)]),
                          left=2).rstrip("\n")


def scores_notes(board: Mapping[str, Any]) -> list[str]:
    """What the protocol-3 tables' figures are."""
    s, b = board["scores"], board["bootstrap"]
    t = s["safety_thresholds"]
    return [f"Per tier: the scene-balanced mean of its cells' success (each scene the same weight, each cell within "
            f"a scene the same; a cell's success the mean over training runs) [95 % hierarchical bootstrap interval: "
            f"training runs, then the episodes of each run and cell, {b['reps']} resamples, seed {b['seed']}]. "
            f"score: the mean over the ranked tiers ({', '.join(s['ranked_tiers'])}; paper is reported, not ranked), "
            "which orders the rows; safe score likewise of safe success; P(> next): rliable's probability of "
            "improvement of the row over the next ranked row, over the ranked cells.",
            f"Safe success: the goal reached with the episode's smallest clearance >= {t['min_clearance'] * 1000:.0f} "
            f"mm and smallest ZMP margin >= {t['min_zmp_margin'] * 1000:.0f} mm (configs/eval.yaml says why); time to "
            "goal [s] over the successes (scene-balanced over the cells with one); normalised: (method - reactive) / "
            f"(privileged - reactive) on the tier's balanced means, the anchors per cell the best of "
            f"{', '.join(s['reactive_baselines'])} and the best privileged row (– without both); IQM: over runs x "
            "cells, where a row has at least 5 runs."]


def scene_markdown(board: Mapping[str, Any]) -> str:
    """Per tier and scene (rows) and policy (columns): the mean success over the scene's cells [pooled Wilson
    95 % CI]."""
    labels = {p["policy"]: p["label"] for p in board["policies"]}
    per_scene = pd.DataFrame(board["per_scene"], columns=["policy", "tier", "scene", "success_mean", "success_ci95",
                                                          "cells"])
    rows = []
    for tier in board["tiers"]:
        for scene in board["scenes"]:
            n = sum(c.split("/")[0] == scene for c in board["tier_cells"][tier])
            if not n:
                continue
            here = per_scene[(per_scene["tier"] == tier) & (per_scene["scene"] == scene)].set_index("policy")
            row = []
            for policy in labels:
                if policy not in here.index:
                    row.append(DASH)
                    continue
                s = here.loc[policy]
                row.append(interval(s["success_mean"], s["success_ci95"])
                           + ("" if len(s["cells"]) == n else f" ({len(s['cells'])}/{n} cells)"))
            rows.append([tier, scene, str(n), *row])
    table = pd.DataFrame(rows, columns=["tier", "scene", "cells", *labels.values()])
    return markdown_table(table, left=2).rstrip("\n")


def markdown(board: Mapping[str, Any]) -> str:
    """``leaderboard.md``: the headline table, the per-scene table, the figures and what was left out of them."""
    usual = _usual_protocol(board)
    n = usual.get("episodes_per_cell", board["protocol"].get("episodes_per_cell"))
    sha = usual.get("env_configs_sha256", board["protocol"].get("env_configs_sha256"))
    mixed = " (rows marked ‡: another protocol)" if any(_other_protocol(board, p) for p in board["policies"]) else ""
    version = board.get("protocol_version", PROTOCOL_VERSION)
    fp = board["protocol"].get("fingerprint")
    stated = [f"Protocol {version}" + (f", fingerprint `{fp}`" if isinstance(fp, str) else
                                      " (before the fingerprint: its rows were not checked against the simulator's "
                                      "source)" if version < 3 else "") + "."]
    if version >= 3 and board["protocol"].get("split") != row_protocol.TEST_SPLIT:
        stated.append("**Development board**: validation seeds, no release: not the board.")
    lines = ["# Leaderboard", "", " ".join(stated), "",
             f"{plural(len(board['policies']), 'policy')} on "
             f"{plural(sum(len(c) for c in board['tier_cells'].values()), 'cell')} "
             f"(tiers {', '.join(board['tiers'])}; scenes {', '.join(board['scenes'])}), {n} episodes per cell, "
             f"configs {str(sha)[:12]}{mixed}. Regenerate with "
             "`python baselines/make_leaderboard.py` (docs/benchmark.md §4).", "",
             "## IQM success per tier", "", headline_markdown(board), ""]
    lines += [note + "\n" for note in headline_notes(board)]
    protocol3 = ["## Scene-balanced success per tier", "", scores_markdown(board), "",
                 "## Safe success / time to goal / normalised score per tier", "", safety_markdown(board), ""]
    protocol3 += [note + "\n" for note in scores_notes(board) + fullbody_note(board)]
    protocol3 += ["## Every cell: success (normalised)", "", cells_markdown(board), ""]
    if version >= 3:  # the headline is protocol 3's; the IQM table follows as protocol 2's figure
        at = lines.index("## IQM success per tier")
        lines[at:at] = protocol3
    else:
        lines += protocol3
    if board.get("in_distribution"):
        lines += ["## In-distribution track", "", in_distribution_markdown(board), ""]
        lines += [note + "\n" for note in in_distribution_notes(board)]
    if training_markdown(board):
        lines += ["## Training budget of the learned rows", "", training_markdown(board), ""]
        lines += [note + "\n" for note in training_notes(board)]
    lines += ["## Per scene", "", scene_markdown(board), "",
              "Mean success over the scene's cells of the tier (each cell's success pooled over the training runs) "
              "[95 % Wilson interval of all those episodes pooled, runs and cells: it counts the episodes as "
              "independent, so it is narrower than an interval over training runs]; (k/n cells): a partial run "
              "covering k of them.", "",
              "## Figures", "",
              *([f"![Scene-balanced success per tier]({FIGURE_SCORES})", "",
                 f"`{FIGURE_SCORES}`: {FIGURE_SCORES_CAPTION}", ""] if version >= 3 else []),
              f"![IQM success per tier]({FIGURE_IQM})", "",
              f"`{FIGURE_IQM}`: per tier, the IQM of the success rates over the tier's cells (every scene), with "
              "stratified-bootstrap 95 % intervals over training runs (rliable); a planner is one run, its interval "
              "a point (a diamond). `iqm_optimality_gap_<tier>.png`: one tier's IQM and optimality gap (the mean of "
              "max(0, 1 - success)).", "",
              f"![Performance profiles]({FIGURE_PROFILES})", "",
              f"`{FIGURE_PROFILES}`: per tier, the share of the runs x cells whose success rate exceeds τ, with "
              "95 % stratified-bootstrap bands over training runs.", ""]
    left = []
    for tier in board["tiers"]:
        _, out = in_figure(board, tier)
        left += [f"{p['label']} from {tier} ({len(_aggregate(board, p['policy'], tier)['cells'])} of "
                 f"{len(board['tier_cells'][tier])} cells)" for p in out]
    lines.append("Each tier's figures show the policies that cover every cell of it"
                 + (f"; left out: {'; '.join(left)}." if left else " (all of them here)."))
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------- figures
def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


#: Line styles crossed with the palette's colours, so that no two policies of a figure are drawn alike.
LINESTYLES = ("solid", "dashed", "dotted", "dashdot")
#: The width a committed figure is drawn for (inches at :data:`DPI`: 900 px, a README's width).
WIDTH_IN, DPI = 9.0, 100


def policy_styles(board: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """One style per policy label, the same in every figure: the upper bounds black, each in its own broken line
    style (dashed, dotted, dash-dot, in the leaderboard's order), the null baselines
    thin grey lines (one legend entry for them all), every other policy a colour of seaborn's colour-blind palette
    (its grey left to the null baselines) crossed with a line style (:data:`LINESTYLES`), in the leaderboard's
    order."""
    import seaborn as sns

    from footstep_gym.planners.null import is_null

    palette = [c for k, c in enumerate(sns.color_palette("colorblind", n_colors=10)) if k != 7]  # 7: its grey
    styles, k, u = {}, 0, 0
    for p in board["policies"]:
        if p["upper_bound"]:
            styles[p["label"]] = {"color": "black", "linestyle": LINESTYLES[1 + u % (len(LINESTYLES) - 1)],
                                  "linewidth": 1.5, "group": "upper bound"}
            u += 1
        elif is_null(p["policy"]):
            styles[p["label"]] = {"color": "0.65", "linestyle": "solid", "linewidth": 0.8, "group": "null"}
        else:
            styles[p["label"]] = {"color": palette[k % len(palette)],
                                  "linestyle": LINESTYLES[(k // len(palette)) % len(LINESTYLES)], "linewidth": 1.5,
                                  "group": "learned" if p.get("learned") else "planner"}
            k += 1
    return styles


def _interval_panel(ax, board: Mapping[str, Any], tier: str, labels: Sequence[str], metric: str,
                    styles: Mapping[str, Mapping[str, Any]]) -> None:
    """One panel: per policy label (top to bottom), ``metric``'s point and 95 % interval on ``tier`` (a diamond
    where the interval is a point: one run, a planner's); nothing for a policy that does not cover the tier."""
    by_label = {p["label"]: p for p in board["policies"]}
    for row, label in enumerate(labels):
        a = _aggregate(board, by_label[label]["policy"], tier)
        if a is None or not a["covers_tier"]:
            continue
        point, (lo, hi) = a[metric], a[f"{metric}_ci95"]
        color = styles[label]["color"]
        if hi - lo > 1e-9:
            ax.plot([lo, hi], [row, row], color=color, linewidth=4, alpha=0.45, solid_capstyle="butt")
            ax.plot([point], [row], marker="|", markersize=9, markeredgewidth=2, color=color)
        else:
            ax.plot([point], [row], marker="D", markersize=4.5, color=color)
    _rate_axis(ax, len(labels), xlim=(-0.03, 1.03))


def _rate_axis(ax, rows: int, xlim: tuple[float, float]) -> None:
    """A panel's axes for rates: ``rows`` rows top to bottom, x over ``xlim``, ticks 0, 0.5, 1, a light vertical
    grid, no top or right spine."""
    ax.set_ylim(rows - 0.5, -0.5)
    ax.set_xlim(*xlim)
    ax.set_xticks([0.0, 0.5, 1.0])
    ax.set_xticklabels(["0", "0.5", "1"])
    ax.grid(axis="x", alpha=0.3)
    ax.tick_params(labelsize=8, length=2)
    for side in ("top", "right"):
        ax.spines[side].set_visible(False)


def _figure_rows(board: Mapping[str, Any]) -> tuple[list[str], list[str]]:
    """The policy labels shown in the IQM figures (those covering every cell of some tier), and those left out."""
    shown = [p["label"] for p in board["policies"] if any(p in in_figure(board, t)[0] for t in board["tiers"])]
    return shown, [p["label"] for p in board["policies"] if p["label"] not in shown]


def iqm_grid_figure(board: Mapping[str, Any], styles: Mapping[str, Mapping[str, Any]] | None = None):
    """The IQM success of every policy on every tier, one small panel per tier side by side (policies as rows, in
    the leaderboard's order), with the 95 % stratified-bootstrap intervals over training runs; None when no policy
    covers a whole tier."""
    plt = _pyplot()
    styles = dict(styles or policy_styles(board))
    labels, left_out = _figure_rows(board)
    if not labels:
        return None
    tiers = board["tiers"]
    fig, axes = plt.subplots(1, len(tiers), sharey=True, squeeze=False,
                             figsize=(WIDTH_IN, 0.9 + 0.19 * len(labels)))
    for ax, tier in zip(axes[0], tiers):
        _interval_panel(ax, board, tier, labels, "iqm", styles)
        ax.set_title(f"{tier} ({len(board['tier_cells'][tier])})", fontsize=9)
    axes[0][0].set_yticks(range(len(labels)))
    axes[0][0].set_yticklabels(labels, fontsize=8)
    caption = "IQM success per tier (cells), 95 % CI over training runs; diamond: one run"
    if left_out:
        caption += "; partial runs left out: " + ", ".join(left_out)
    fig.supxlabel(caption, fontsize=8)
    fig.tight_layout(w_pad=0.6)
    return fig


def iqm_gap_figure(board: Mapping[str, Any], tier: str, styles: Mapping[str, Mapping[str, Any]] | None = None):
    """One tier's IQM and optimality gap (the mean of max(0, 1 - success)) with their 95 % intervals, or None when
    no policy covers every cell of the tier."""
    plt = _pyplot()
    shown, left_out = in_figure(board, tier)
    if not shown:
        return None
    styles = dict(styles or policy_styles(board))
    labels = [p["label"] for p in shown]
    fig, axes = plt.subplots(1, 2, sharey=True, figsize=(WIDTH_IN * 0.7, 0.9 + 0.19 * len(labels)))
    for ax, metric, title in zip(axes, ("iqm", "optimality_gap"), ("IQM success", "optimality gap")):
        _interval_panel(ax, board, tier, labels, metric, styles)
        ax.set_title(title, fontsize=9)
    axes[0].set_yticks(range(len(labels)))
    axes[0].set_yticklabels(labels, fontsize=8)
    title = f"{tier} ({plural(len(board['tier_cells'][tier]), 'cell')})"
    if left_out:
        title += "; left out (partial): " + ", ".join(p["label"] for p in left_out)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout(w_pad=0.6)
    return fig


def _png(fig) -> bytes:
    plt = _pyplot()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, facecolor="white",
                metadata={"Software": None})  # no version stamp: the same bytes on a rerun
    plt.close(fig)
    return buf.getvalue()


def profiles_figure(board: Mapping[str, Any], styles: Mapping[str, Mapping[str, Any]] | None = None):
    """Performance profiles (rliable's score distributions, :func:`profile_estimates`, drawn by
    ``plot_performance_profiles``), one small panel per tier and the legend in the last one, of the policies
    covering every cell of the tier, with 95 % stratified-bootstrap bands over training runs."""
    plt = _pyplot()
    from rliable import plot_utils

    styles = dict(styles or policy_styles(board))
    tiers = board["tiers"]
    reps, seed = board["bootstrap"]["reps"], board["bootstrap"]["seed"]
    ncols = 3
    nrows = -(-(len(tiers) + 1) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(WIDTH_IN, 2.9 * nrows), squeeze=False)
    flat = list(axes.flat)
    handles: dict[str, Any] = {}
    for i, (ax, tier) in enumerate(zip(flat, tiers)):
        shown, left_out = in_figure(board, tier)
        curves, bands = {}, {}
        for p in shown:
            matrix = np.array(_aggregate(board, p["policy"], tier)["scores"], dtype=float)
            curves[p["label"]], bands[p["label"]] = profile_estimates(matrix, reps, seed)
        if curves:
            plot_utils.plot_performance_profiles(
                curves, TAUS, performance_profile_cis=bands, colors={k: styles[k]["color"] for k in curves},
                linestyles={k: styles[k]["linestyle"] for k in curves}, ax=ax, alpha=0.08,
                xlabel=r"success rate $\tau$" if i >= len(tiers) - ncols else "",
                ylabel="share of runs x cells > τ" if i % ncols == 0 else "",
                xticks=[0.0, 0.5, 1.0], yticks=[0.0, 0.5, 1.0], labelsize=8, ticklabelsize=8, grid_alpha=0.2)
            for line in ax.get_lines():
                label = line.get_label()
                if label in styles:
                    line.set_linewidth(styles[label]["linewidth"])
                    handles.setdefault("null baselines" if styles[label]["group"] == "null" else label, line)
        ax.set_title(f"{tier} ({plural(len(board['tier_cells'][tier]), 'cell')})", fontsize=9)
        del left_out  # the partial runs: named once, in the legend's title
    legend_ax = flat[len(tiers)]
    legend_ax.axis("off")
    for ax in flat[len(tiers) + 1:]:
        ax.axis("off")
    order = [p["label"] for p in board["policies"] if p["label"] in handles]
    if "null baselines" in handles:
        order.append("null baselines")
    partial = [p["label"] for p in board["policies"] if not p["complete"]]
    legend_ax.legend([handles[k] for k in order], order, loc="center", ncol=2, fontsize=7, frameon=False,
                     handlelength=2.6, columnspacing=1.0,
                     title=("partial runs left out: " + ", ".join(partial)) if partial else None,
                     title_fontsize=7)
    fig.tight_layout(h_pad=0.8, w_pad=0.8)
    return fig


def scores_figure(board: Mapping[str, Any], styles: Mapping[str, Mapping[str, Any]] | None = None):
    """Protocol 3's headline figure: one panel per tier, a row per generalisation policy in the board's order (the
    ranked rows best first, the privileged last, starred), its scene-balanced success as a bar with the
    hierarchical 95 % interval as a whisker and its safe success as an open circle; None before protocol 3 (no
    such scores) or when no policy covers a whole tier."""
    if board.get("protocol_version", PROTOCOL_VERSION) < 3:
        return None
    plt = _pyplot()
    styles = dict(styles or policy_styles(board))
    s = board["scores"]
    by = {(r["policy"], r["tier"]): r for r in s["tiers"] if r["trained_on_tier"] is None}
    rows = [p for p in _ranked_order(board) if any((p["policy"], t) in by for t in board["tiers"])]
    if not rows:
        return None
    labels = [f"{p['label']} *" if p["upper_bound"] else p["label"] for p in rows]
    tiers = board["tiers"]
    fig, axes = plt.subplots(1, len(tiers), sharey=True, squeeze=False,
                             figsize=(WIDTH_IN, 1.2 + 0.2 * len(rows)))
    for ax, tier in zip(axes[0], tiers):
        for y, p in enumerate(rows):
            r = by.get((p["policy"], tier))
            if r is None:
                continue
            color = styles[p["label"]]["color"]
            lo, hi = r["success_ci95"]
            ax.barh(y, r["success"], height=0.7, color=color, alpha=0.55, linewidth=0)
            ax.plot([lo, hi], [y, y], color="black", linewidth=0.9)
            if r["safe_success"] is not None:
                ax.plot([r["safe_success"]], [y], marker="o", markersize=4, markerfacecolor="white",
                        markeredgecolor="black", markeredgewidth=0.8)
        ranked = "" if tier in s["ranked_tiers"] else ", not ranked"
        ax.set_title(f"{tier} ({len(board['tier_cells'][tier])} cells{ranked})", fontsize=9)
        _rate_axis(ax, len(rows), xlim=(0.0, 1.02))
    axes[0][0].set_yticks(range(len(rows)))
    axes[0][0].set_yticklabels(labels, fontsize=8)
    t = s["safety_thresholds"]
    fig.supxlabel("bar: scene-balanced success, whisker: hierarchical 95 % CI; circle: safe success\n(clearance >= "
                  f"{t['min_clearance'] * 1000:.0f} mm, ZMP margin >= {t['min_zmp_margin'] * 1000:.0f} mm); "
                  "*: privileged upper bound; rows in rank order", fontsize=8)
    fig.tight_layout(w_pad=0.6)
    return fig


def write_figures(board: Mapping[str, Any], folder: Path) -> list[Path]:
    """``success_per_tier.png`` (protocol 3's scores, :func:`scores_figure`), ``iqm_per_tier.png`` (every tier side
    by side), ``iqm_optimality_gap_<tier>.png`` per tier and ``performance_profiles.png`` into ``folder``, each
    drawn for a width of 900 px."""
    styles = policy_styles(board)
    files = []
    scored = scores_figure(board, styles)
    if scored is not None:
        (folder / FIGURE_SCORES).write_bytes(_png(scored))
        files.append(folder / FIGURE_SCORES)
    grid = iqm_grid_figure(board, styles)
    if grid is not None:
        (folder / FIGURE_IQM).write_bytes(_png(grid))
        files.append(folder / FIGURE_IQM)
    for tier in board["tiers"]:
        fig = iqm_gap_figure(board, tier, styles)
        if fig is None:
            continue
        path = folder / tier_figure_name(tier)
        path.write_bytes(_png(fig))
        files.append(path)
    (folder / FIGURE_PROFILES).write_bytes(_png(profiles_figure(board, styles)))
    files.append(folder / FIGURE_PROFILES)
    return files


# ---------------------------------------------------------------- files
def check_out(out: Path) -> str | None:
    """Why ``out`` cannot take the leaderboard's files (one line), or None: it must be a folder or not exist
    (other files in it are kept)."""
    if out.exists() and not out.is_dir():
        return f"--out {out} is a file, not a folder"
    return None


def write_leaderboard(board: Mapping[str, Any], out: Path) -> list[Path]:
    """``leaderboard.md``, ``leaderboard.json`` and the figures, written into a temporary folder beside ``out``
    (``outfolder.new_run_folder``) and moved into ``out`` once all are written, file by file: the leaderboard's
    earlier files are replaced, nothing else in ``out`` is touched. A failure leaves ``out`` as it was."""
    folder = new_run_folder(out)
    try:
        (folder / "leaderboard.json").write_text(json.dumps(board, indent=2) + "\n", encoding="utf-8")
        (folder / "leaderboard.md").write_text(markdown(board), encoding="utf-8")
        write_figures(board, folder)
        out = out.absolute()
        out.mkdir(parents=True, exist_ok=True)
        names = sorted(p.name for p in folder.iterdir())
        for name in names:
            os.replace(folder / name, out / name)
        folder.rmdir()
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return [out / name for name in names]


def leaderboard(paths: Sequence[Path], allow_mixed: bool = False, reps: int = REPS, seed: int = SEED,
                fingerprint: str | None = None, access_log: Path | None = None,
                fullbody: Path | None = None, agents_dir: Path | None = None) -> dict[str, Any]:
    """The checked leaderboard of the files ``paths`` name (:func:`find_benchmarks`); raises
    :class:`LeaderboardError` on bad input (:func:`check_compatible`, :func:`check_rows`: ``fingerprint`` and
    ``access_log`` default to this checkout's). ``fullbody``: a full-body summary to show as a column
    (``baselines/results/fullbody/fullbody_paper_op3.json``), read before anything else. ``agents_dir``: the
    shipped agents the learned rows' training is read from (default :func:`default_agents_dir`)."""
    summary = None
    if fullbody is not None:
        try:
            summary = fullbody_column.load_summary(fullbody)
        except fullbody_column.FullBodyError as exc:
            raise LeaderboardError(str(exc)) from exc
    files = find_benchmarks(paths)
    if not files:
        raise LeaderboardError("no benchmark.json found in " + ", ".join(map(str, paths)))
    docs = [load_benchmark(p) for p in files]
    check_compatible(docs, files, allow_mixed)
    check_rows(docs, files, fingerprint, access_log)
    return build(docs, files, reps=reps, seed=seed, fullbody=summary, agents_dir=agents_dir)


def main_summary(board: Mapping[str, Any], files: Sequence[Path], out: Path) -> str:
    """What the script prints: the headline table and where the files went."""
    return "\n".join([headline_markdown(board), "", *headline_notes(board), "",
                      f"wrote {len(files)} files to {out}/ (leaderboard.md)"])


__all__ = ["LeaderboardError", "VERSIONS", "build", "check_compatible", "check_rows", "find_benchmarks", "headline_markdown", "in_figure",
           "interval_estimates", "iqm_and_gap", "leaderboard", "load_benchmark", "markdown", "per_scene", "profile",
           "scene_markdown", "score_matrix", "scores_figure", "tier_cells", "write_figures", "write_leaderboard"]
