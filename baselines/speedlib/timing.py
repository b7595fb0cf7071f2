"""Summaries of repeated measurements: :func:`summary` (rates), :func:`tail_summary` (many single
timings), :func:`median_ratio_interval` (a bootstrap interval of a ratio of medians, clusters resampled
in pairs). numpy only."""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np


def summary(samples: Sequence[float]) -> dict[str, float]:
    """Median and spread of repeated measurements: ``median, q1, q3, min, max, n``."""
    a = np.asarray(list(samples), dtype=float)
    if a.size == 0:
        return {"median": math.nan, "q1": math.nan, "q3": math.nan, "min": math.nan, "max": math.nan, "n": 0}
    q1, med, q3 = np.percentile(a, [25, 50, 75])
    return {"median": float(med), "q1": float(q1), "q3": float(q3),
            "min": float(a.min()), "max": float(a.max()), "n": int(a.size)}


def median_ratio_interval(numerator: Sequence[Sequence[float]], denominator: Sequence[Sequence[float]],
                          rng: np.random.Generator, n_boot: int = 2000, level: float = 0.95) -> tuple[float, float]:
    """Bootstrap interval of ``median(numerator) / median(denominator)`` resampling *clusters* in pairs.

    ``numerator[i]`` and ``denominator[i]`` are the timings of cluster ``i`` (one seed's episode,
    run by each of two planners): a footstep's time depends on its episode, so episodes, not
    footsteps, are the independent draws. Each of ``n_boot`` resamples draws clusters with
    replacement, the same ones for both sides. Returns the ``level`` percentile interval.
    """
    if len(numerator) != len(denominator) or not len(numerator):
        raise ValueError(f"need the same number (> 0) of clusters on both sides, got {len(numerator)} and "
                         f"{len(denominator)}")
    num = [np.asarray(c, dtype=float) for c in numerator]
    den = [np.asarray(c, dtype=float) for c in denominator]
    k = len(num)
    ratios = np.empty(n_boot)
    for b in range(n_boot):
        pick = rng.integers(0, k, k)
        top, bottom = np.concatenate([num[i] for i in pick]), np.concatenate([den[i] for i in pick])
        ratios[b] = np.median(top) / np.median(bottom) if top.size and bottom.size else np.nan
    lo, hi = np.nanpercentile(ratios, [50 * (1 - level), 50 * (1 + level)])
    return float(lo), float(hi)


def tail_summary(samples: Sequence[float]) -> dict[str, float]:
    """Distribution of many single timings: ``median, p95, p99, mean, max, n`` (same unit as the input)."""
    a = np.asarray(list(samples), dtype=float)
    if a.size == 0:
        return {"median": math.nan, "p95": math.nan, "p99": math.nan, "mean": math.nan, "max": math.nan, "n": 0}
    med, p95, p99 = np.percentile(a, [50, 95, 99])
    return {"median": float(med), "p95": float(p95), "p99": float(p99),
            "mean": float(a.mean()), "max": float(a.max()), "n": int(a.size)}
