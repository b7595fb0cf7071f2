"""Scores that hide no cell (docs/benchmark.md §2): the scene-balanced tier score with a hierarchical bootstrap
interval, the normalised score, the probability of improvement, and safe success.

Pure functions of arrays (numpy, rliable):

* :func:`balanced_weights` / :func:`balanced_mean`: a tier's score is the mean over its scenes of the mean over each
  scene's cells, so every scene weighs the same and every cell within a scene the same (5 crowd cells and 2 door
  cells: each door cell weighs 1/4 of a 2-scene tier, each crowd cell 1/10);
* :func:`hierarchical_bootstrap`: that score's 95 % percentile interval from resampling the training runs (one
  draw of runs for every cell: a run is one trained policy) and then the episodes within each run and cell (a
  binomial draw at the cell's observed rate, the same as resampling its 0/1 outcomes with replacement), so a
  one-run planner's interval shows its episode noise;
* :func:`normalised`: ``(method - reactive) / (privileged - reactive)``, between the best reactive baseline and
  the best privileged solver (Atari's human-normalised score); NaN where the two anchors are equal;
* :func:`probability_of_improvement`: rliable's P(X > Y) averaged over cells (Mann-Whitney over runs per cell);
* :func:`safe_success` (:class:`SafetyThresholds`, ``configs/eval.yaml``): the goal reached with the episode's
  smallest clearance and smallest ZMP margin at least the stated thresholds.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Sequence

import numpy as np

from footstep_gym.errors import ConfigError

#: Bootstrap resamples and seed of every hierarchical interval.
REPS = 2000
SEED = 0


def _scene(cell: str) -> str:
    return cell.split("/", 1)[0]


def balanced_weights(cells: Sequence[str]) -> np.ndarray:
    """Each cell's weight in a scene-balanced mean: ``1 / (scenes x cells of its scene)``; ``cells`` are
    ``scene/cell`` labels. The weights sum to 1."""
    if not cells:
        raise ValueError("need at least one cell")
    scenes = [_scene(c) for c in cells]
    counts = {s: scenes.count(s) for s in scenes}
    return np.array([1.0 / (len(counts) * counts[s]) for s in scenes])


def balanced_mean(values: Sequence[float] | np.ndarray, cells: Sequence[str]) -> float:
    """The scene-balanced mean of per-cell ``values`` (index for index with ``cells``)."""
    values = np.asarray(values, dtype=float)
    if values.shape != (len(cells),):
        raise ValueError(f"need one value per cell, got {values.shape} for {len(cells)} cells")
    return float(balanced_weights(cells) @ values)


def hierarchical_bootstrap(successes: Any, episodes: Any, cells: Sequence[str], reps: int = REPS, seed: int = SEED
                           ) -> tuple[float, float, float]:
    """``(score, lo, hi)``: the scene-balanced mean over ``cells`` of the success rate averaged over training runs,
    and its 95 % percentile interval from a two-level bootstrap.

    ``successes`` and ``episodes``: ``(runs, cells)`` counts. Each of ``reps`` resamples draws ``runs`` training runs
    with replacement (the same draw for every cell; with one run, that run), then for each drawn run and cell a
    success count ``Binomial(episodes, successes / episodes)`` (resampling that cell's episodes), and takes the
    balanced mean of the cells' mean rates over the drawn runs. Seeded (``seed``), and independent of NumPy's global
    generator.
    """
    k = np.asarray(successes, dtype=float)
    n = np.asarray(episodes, dtype=float)
    if k.ndim != 2 or k.shape != n.shape or k.shape[1] != len(cells) or k.size == 0:
        raise ValueError(f"need (runs, cells) successes and episodes for {len(cells)} cells, got {k.shape} and "
                         f"{n.shape}")
    if np.any(n < 1) or np.any(k < 0) or np.any(k > n):
        raise ValueError("need 0 <= successes <= episodes and at least one episode per run and cell")
    if reps < 1:
        raise ValueError(f"reps must be at least 1, got {reps}")
    weights = balanced_weights(cells)
    rates = k / n
    score = float(weights @ rates.mean(axis=0))
    rng = np.random.default_rng(seed)
    runs = k.shape[0]
    drawn = rng.integers(0, runs, size=(reps, runs)) if runs > 1 else np.zeros((reps, 1), dtype=int)
    p, m = rates[drawn], n[drawn]  # (reps, runs, cells)
    resampled = rng.binomial(m.astype(np.int64), p) / m
    scores = resampled.mean(axis=1) @ weights
    lo, hi = np.percentile(scores, [2.5, 97.5])
    return score, float(lo), float(hi)


def normalised(method: float, reactive: float, privileged: float) -> float:
    """``(method - reactive) / (privileged - reactive)``: 0 at the best reactive baseline, 1 at the best privileged
    solver; NaN where the two are equal (nothing to normalise by)."""
    span = privileged - reactive
    return float("nan") if abs(span) < 1e-12 else (method - reactive) / span


def probability_of_improvement(x: Any, y: Any) -> float:
    """rliable's probability that X beats Y: per cell, P(X > Y) over the pairs of their training runs (ties count
    a half; the Mann-Whitney U statistic over ``runs_x x runs_y``), averaged over the cells. ``x``, ``y``:
    ``(runs, cells)`` success rates on the same cells."""
    from rliable import metrics

    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.ndim != 2 or y.ndim != 2 or x.shape[1] != y.shape[1] or x.size == 0 or y.size == 0:
        raise ValueError(f"need (runs, cells) matrices on the same cells, got {x.shape} and {y.shape}")
    return float(metrics.probability_of_improvement(x, y))


# ---------------------------------------------------------------- safe success
@dataclass(frozen=True)
class SafetyThresholds:
    """What safe success asks of an episode besides the goal: its smallest body-obstacle clearance [m] and its
    smallest ZMP margin [m] at least these (``configs/eval.yaml``, ``safe_success``)."""

    min_clearance: float
    min_zmp_margin: float


@lru_cache(maxsize=1)
def safety_thresholds() -> SafetyThresholds:
    """The thresholds of ``configs/eval.yaml``'s ``safe_success`` (checked: two finite numbers >= 0)."""
    from footstep_gym.config import read_yaml

    raw = read_yaml("eval.yaml").get("safe_success")
    if not isinstance(raw, dict) or set(raw) != {"min_clearance", "min_zmp_margin"}:
        raise ConfigError("eval.yaml: safe_success must be {min_clearance: M, min_zmp_margin: M}")
    for key, value in raw.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value < 0:
            raise ConfigError(f"eval.yaml: safe_success.{key} must be a finite number >= 0 [m], got {value!r}")
    return SafetyThresholds(float(raw["min_clearance"]), float(raw["min_zmp_margin"]))


def safe_success(outcome: str, min_clearance: float | None, min_zmp_margin: float | None,
                 thresholds: SafetyThresholds | None = None) -> bool:
    """Whether an episode is a safe success: it reached the goal, its smallest clearance is at least
    ``thresholds.min_clearance`` (None: nothing came within reach, which is clear) and its smallest ZMP margin at
    least ``thresholds.min_zmp_margin`` (None: no step was taken, which is refused: a success takes steps)."""
    t = thresholds or safety_thresholds()
    return (outcome == "goal" and (min_clearance is None or min_clearance >= t.min_clearance)
            and min_zmp_margin is not None and min_zmp_margin >= t.min_zmp_margin)


# ---------------------------------------------------------------- a board's scores
#: Tiers reported but not ranked: ``paper`` is the reproduction (a blind walker solves its crossing).
UNRANKED_TIERS = ("paper",)
#: The reactive baselines (sense, do not plan): the lower anchor of the normalised score.
REACTIVE_BASELINES = ("wait-until-clear", "straight-stop")
#: A row's IQM over runs is kept, as a secondary figure, from this many training runs on.
IQM_MIN_RUNS = 5


def count_matrices(records: Sequence[Any], cells: Sequence[str]
                   ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
    """``(successes, safe_successes or None, episodes, mean_time)``: ``(runs, cells)`` arrays of one policy's
    records on ``cells`` (``scene/cell``; records with ``scene``, ``cell``, ``run``, ``successes``, ``episodes``,
    ``safe_successes``, ``mean_time``). The ``k``-th run of each cell (by name) is row ``k``, cut to the fewest runs
    (as :func:`~footstep_gym.evaluation.stats.score_matrix`); safe successes are None unless every record has
    them; a time is NaN where a run had no success. ``ValueError`` for a cell without a record."""
    by_cell: dict[str, list[Any]] = {}
    for r in records:
        by_cell.setdefault(f"{r.scene}/{r.cell}", []).append(r)
    missing = [c for c in cells if c not in by_cell]
    if missing:
        raise ValueError(f"no record of {', '.join(missing)}")
    columns = [sorted(by_cell[c], key=lambda r: r.run or "") for c in cells]
    runs = min(len(col) for col in columns)
    grid = [[col[k] for col in columns] for k in range(runs)]
    k = np.array([[r.successes for r in row] for row in grid], dtype=float)
    n = np.array([[r.episodes for r in row] for row in grid], dtype=float)
    times = np.array([[np.nan if r.mean_time is None else r.mean_time for r in row] for row in grid], dtype=float)
    safe = None
    if all(getattr(r, "safe_successes", None) is not None for row in grid for r in row):
        safe = np.array([[r.safe_successes for r in row] for row in grid], dtype=float)
    return k, safe, n, times


def tier_score(records: Sequence[Any], cells: Sequence[str], reps: int = REPS, seed: int = SEED) -> dict[str, Any]:
    """One policy's scores on one tier's ``cells`` (:func:`count_matrices`): the scene-balanced success and safe
    success with their hierarchical intervals (:func:`hierarchical_bootstrap`), the time to goal (the balanced mean
    over the cells with a success of their mean time over the runs' successes; None without any), the per-cell
    success (mean over runs), the runs, and with at least :data:`IQM_MIN_RUNS` runs the IQM over runs x cells."""
    k, safe, n, times = count_matrices(records, cells)
    score, lo, hi = hierarchical_bootstrap(k, n, cells, reps, seed)
    out: dict[str, Any] = {"success": score, "success_ci95": [lo, hi], "safe_success": None,
                           "safe_success_ci95": None, "runs": int(k.shape[0]),
                           "cell_success": (k / n).mean(axis=0).tolist(), "iqm": None}
    if safe is not None:
        s, slo, shi = hierarchical_bootstrap(safe, n, cells, reps, seed)
        out.update(safe_success=s, safe_success_ci95=[slo, shi])
    timed = [(c, float(np.nanmean(times[:, j]))) for j, c in enumerate(cells) if not np.all(np.isnan(times[:, j]))]
    out["time_to_goal"] = balanced_mean([v for _, v in timed], [c for c, _ in timed]) if timed else None
    if k.shape[0] >= IQM_MIN_RUNS:
        from rliable import metrics

        out["iqm"] = float(metrics.aggregate_iqm(k / n))
    return out


def board_scores(entries: Sequence[tuple[str, bool, Sequence[Any]]], tier_cells: dict[str, list[str]],
                 reps: int = REPS, seed: int = SEED,
                 in_distribution: Sequence[tuple[str, str, Sequence[Any]]] = ()) -> dict[str, Any]:
    """The board's scores. ``entries``: ``(policy, upper_bound, records)`` per generalisation row; ``tier_cells``:
    each tier's ``scene/cell`` labels; ``in_distribution``: ``(policy, trained_on_tier, records)`` per row of the
    in-distribution track (scored on its tier only, never ranked nor an anchor). Returns

    * ``tiers``: per policy and tier it covers wholly, :func:`tier_score` and ``normalised``: the tier's
      ``(method - reactive) / (privileged - reactive)`` on scene-balanced means, the anchors per cell being the best
      reactive baseline (:data:`REACTIVE_BASELINES`) and the best privileged row (``upper_bound``), each cell's
      success the mean over runs (None without both anchors); an in-distribution row's entry carries its
      ``trained_on_tier`` (the others ``None``);
    * ``cells``: per policy and cell, its success and normalised score;
    * ``ranking``: the rows that are not privileged and cover every ranked tier (all but :data:`UNRANKED_TIERS`),
      best first by ``score``, the mean over the ranked tiers of the tier success (``safe_score`` likewise), with
      ``p_improvement``: rliable's probability that the row beats the next one, over the ranked cells."""
    rows, cell_rows = [], []
    covered: dict[str, dict[str, dict[str, Any]]] = {}
    for policy, upper, records in entries:
        for tier, cells in tier_cells.items():
            mine = [r for r in records if r.tier == tier]
            have = {f"{r.scene}/{r.cell}" for r in mine}
            if not set(cells) <= have:
                continue
            s = tier_score(mine, cells, reps, seed)
            covered.setdefault(policy, {})[tier] = s
            rows.append({"policy": policy, "tier": tier, "upper_bound": upper, "trained_on_tier": None, **s})
    anchors: dict[str, dict[str, list[float]]] = {}
    for kind, chosen in (("reactive", [p for p, u, _ in entries if p in REACTIVE_BASELINES and not u]),
                         ("privileged", [p for p, u, _ in entries if u])):
        for tier, cells in tier_cells.items():
            got = [covered[p][tier]["cell_success"] for p in chosen if tier in covered.get(p, {})]
            if got:
                anchors.setdefault(tier, {})[kind] = np.max(np.array(got), axis=0).tolist()
    for policy, tier, records in in_distribution:  # after the anchors: they come from the generalisation track
        cells = tier_cells[tier]
        mine = [r for r in records if r.tier == tier]
        if set(cells) <= {f"{r.scene}/{r.cell}" for r in mine}:
            rows.append({"policy": policy, "tier": tier, "upper_bound": False, "trained_on_tier": tier,
                         **tier_score(mine, cells, reps, seed)})
    for row in rows:
        tier, cells = row["tier"], tier_cells[row["tier"]]
        a = anchors.get(tier, {})
        both = "reactive" in a and "privileged" in a
        row["normalised"] = (normalised(row["success"], balanced_mean(a["reactive"], cells),
                                        balanced_mean(a["privileged"], cells)) if both else None)
        for j, cell in enumerate(cells):
            cell_rows.append({"policy": row["policy"], "tier": tier, "cell": cell,
                              "success": row["cell_success"][j],
                              "normalised": normalised(row["cell_success"][j], a["reactive"][j], a["privileged"][j])
                              if both else None})
    ranked = [t for t in tier_cells if t not in UNRANKED_TIERS]
    ranking = []
    for policy, upper, records in entries:
        mine = covered.get(policy, {})
        if upper or not ranked or any(t not in mine for t in ranked):
            continue
        safe = [mine[t]["safe_success"] for t in ranked]
        ranking.append({"policy": policy, "score": float(np.mean([mine[t]["success"] for t in ranked])),
                        "safe_score": None if any(v is None for v in safe) else float(np.mean(safe)),
                        "records": records})
    ranking.sort(key=lambda r: (-r["score"], r["policy"]))
    cells_ranked = [(t, c) for t in ranked for c in tier_cells[t]]
    for row, nxt in zip(ranking, ranking[1:] + [None]):
        row["p_improvement"] = None
        if nxt is not None:
            x, y = (_rates(r["records"], cells_ranked) for r in (row, nxt))
            row["p_improvement"] = probability_of_improvement(x, y)
    for row in ranking:
        del row["records"]
    return {"tiers": rows, "cells": cell_rows, "ranking": ranking, "ranked_tiers": ranked,
            "reactive_baselines": list(REACTIVE_BASELINES),
            "safety_thresholds": {"min_clearance": safety_thresholds().min_clearance,
                                  "min_zmp_margin": safety_thresholds().min_zmp_margin}}


def _rates(records: Sequence[Any], cells: Sequence[tuple[str, str]]) -> np.ndarray:
    """``(runs, cells)`` success rates over ``(tier, scene/cell)`` pairs, cut to the fewest runs."""
    columns = []
    for tier, cell in cells:
        k, _, n, _ = count_matrices([r for r in records if r.tier == tier], [cell])
        columns.append((k / n)[:, 0])
    runs = min(len(c) for c in columns)
    return np.stack([c[:runs] for c in columns], axis=1)


__all__ = ["IQM_MIN_RUNS", "REACTIVE_BASELINES", "UNRANKED_TIERS", "board_scores", "count_matrices", "tier_score",
           "REPS", "SEED", "SafetyThresholds", "balanced_mean", "balanced_weights", "hierarchical_bootstrap",
           "normalised", "probability_of_improvement", "safe_success", "safety_thresholds"]
