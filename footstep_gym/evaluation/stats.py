"""Aggregating episodes of one evaluation cell into a record, and records over training seeds.

A *cell* is one (env, policy, parameter setting, and for an agent its training run); a
record is the row of ``results.json`` and ``results.csv`` that summarises its episodes.
Definitions:

* ``success_rate``, ``collision_rate``, ``fall_rate``, ``timeout_rate``: fractions of the
  episodes that ended on the goal, a collision, an infeasible step (fall) or were
  truncated (step or time limit); they sum to 1.
* ``success_ci95``: the 95 % Wilson score interval of the success rate.
* ``mean_steps``, ``mean_path_length`` [m], ``mean_time`` [s]: means over the
  *successful* episodes only (``None`` if there is none); the ``*_all`` variants are
  over every episode. The path length is the walked path of the robot centre (the
  midpoint of the two feet, which moves once per footstep), the paper's "length of path".
* ``min_clearance`` [m]: the smallest gap between the robot's body circle and any
  obstacle over an episode (at the env's collision checks; negative after a collision);
  ``min_clearance_median`` is its median over the cell's episodes and
  ``min_clearance_min`` the smallest (None where no obstacle ever came within reach).
* ``min_zmp_margin`` [m]: the smallest distance of the ZMP from the edge of the stable
  region over an episode (negative: the step was infeasible, a fall); median and min.
* ``plan_ms_median``/``_p95``/``_p99``/``_max``: wall-clock time of ``policy.act`` per
  footstep [ms] (planning for a planner, inference for an agent), pooled over every
  footstep of every episode of the cell. They are the only fields that depend on the
  machine and the load (``TIMING_FIELDS``).

:func:`over_runs` summarises the cells of one agent trained with several seeds: the
pooled success rate with its Wilson interval, and the interquartile mean (IQM) of the
per-run success rates with a stratified-bootstrap 95 % interval over the runs (rliable,
the field's standard for results over training seeds).
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: The outcomes of an episode, in the order of the rate fields.
OUTCOMES = ("goal", "collision", "fall", "timeout")
RATE_FIELDS = {"goal": "success_rate", "collision": "collision_rate", "fall": "fall_rate", "timeout": "timeout_rate"}

#: Fields that measure wall-clock time (differ between runs of the same seeds).
TIMING_FIELDS = ("plan_ms_median", "plan_ms_p95", "plan_ms_p99", "plan_ms_max")

Z_95 = 1.959963984540054  # standard normal quantile of 0.975


def wilson_interval(successes: int, n: int, z: float = Z_95) -> tuple[float, float]:
    """Wilson score interval ``(lo, hi)`` of a binomial proportion; ``(0, 1)`` when ``n == 0``."""
    if n < 0 or not 0 <= successes <= max(n, 0):
        raise ValueError(f"need 0 <= successes <= n, got {successes=} {n=}")
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    z2 = z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    # Clamp rounding noise so that lo <= p <= hi holds exactly at p = 0 and p = 1.
    return (max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half)))


@dataclass
class EpisodeResult:
    """What one episode reports back from a worker (plain data, cheap to pickle)."""

    cell_index: int
    seed: int
    outcome: str  # one of OUTCOMES
    steps: int
    time: float  # [s] simulated
    path_length: float  # [m] robot centre
    com_path_length: float  # [m] CoM ground projection
    plan_ms: list[float]  # per footstep, wall clock of policy.act
    periods: list[float]  # [s] T_SS + T_DS of each applied command
    pso_ran: list[bool | None]  # per footstep, from the policy's last_info (None: not reported)
    obstacle: str | None = None  # shape hit on a collision
    min_clearance: float | None = None  # [m] smallest body-obstacle gap (None: nothing came within reach)
    min_zmp_margin: float | None = None  # [m] smallest ZMP margin to the stable region's edge
    trace: Any = field(default=None, repr=False)  # runner.Trace for figures and tables


def _mean(values: list[float]) -> float | None:
    return float(np.mean(values)) if values else None


def _percentile(values: np.ndarray, q: float) -> float | None:
    return float(np.percentile(values, q)) if values.size else None


def _quantiles(values: list[float | None]) -> tuple[float | None, float | None]:
    """(median, min) of the values that were measured."""
    got = [v for v in values if v is not None]
    return (float(np.median(got)), float(min(got))) if got else (None, None)


def cell_record(env_id: str, scenario: str, policy: str, params: dict[str, Any],
                episodes: list[EpisodeResult], run: str | None = None) -> dict[str, Any]:
    """The summary record of one cell's episodes (sorted by seed); ``run``: the agent's training run."""
    episodes = sorted(episodes, key=lambda e: e.seed)
    n = len(episodes)
    if n == 0:
        raise ValueError(f"cell {env_id}/{policy}/{params} has no episodes")
    counts = {o: sum(e.outcome == o for e in episodes) for o in OUTCOMES}
    unknown = [e.outcome for e in episodes if e.outcome not in OUTCOMES]
    if unknown:
        raise ValueError(f"unknown episode outcome(s) {unknown}; expected one of {OUTCOMES}")
    won = [e for e in episodes if e.outcome == "goal"]
    plan = np.array([t for e in episodes for t in e.plan_ms], dtype=float)
    periods = [p for e in episodes for p in e.periods]
    pso = [bool(x) for e in episodes for x in e.pso_ran if x is not None]
    clearance = _quantiles([e.min_clearance for e in episodes])
    zmp_margin = _quantiles([e.min_zmp_margin for e in episodes])
    record: dict[str, Any] = {
        "env": env_id,
        "scenario": scenario,
        "policy": policy,
        "run": run,
        "params": dict(params),
        "episodes": n,
        "successes": counts["goal"],
    }
    for outcome, key in RATE_FIELDS.items():
        record[key] = counts[outcome] / n
    record["success_ci95"] = list(wilson_interval(counts["goal"], n))
    record.update({
        "mean_steps": _mean([e.steps for e in won]),
        "mean_path_length": _mean([e.path_length for e in won]),
        "mean_time": _mean([e.time for e in won]),
        "mean_steps_all": _mean([e.steps for e in episodes]),
        "mean_path_length_all": _mean([e.path_length for e in episodes]),
        "mean_time_all": _mean([e.time for e in episodes]),
        "mean_com_path_length": _mean([e.com_path_length for e in won]),
        "mean_period": _mean(periods),
        "min_period": float(min(periods)) if periods else None,
        "pso_step_rate": (sum(pso) / len(pso)) if pso else None,
        "min_clearance_median": clearance[0],
        "min_clearance_min": clearance[1],
        "min_zmp_margin_median": zmp_margin[0],
        "min_zmp_margin_min": zmp_margin[1],
        "plan_ms_median": _percentile(plan, 50),
        "plan_ms_p95": _percentile(plan, 95),
        "plan_ms_p99": _percentile(plan, 99),
        "plan_ms_max": float(plan.max()) if plan.size else None,
        "seeds": [e.seed for e in episodes],
        "outcomes": [e.outcome for e in episodes],
    })
    return record


@contextlib.contextmanager
def seeded_bootstrap(seed: int) -> Iterator[np.random.RandomState]:
    """A seeded rliable bootstrap: its ``StratifiedBootstrap`` draws the resamples from NumPy's global generator
    (``np.random.choice`` in ``update_indices``) whatever ``random_state`` it is given, so the global generator is
    seeded here and put back as it was afterwards. Yields the ``random_state`` to pass as well (arch checks it,
    and warns that it is deprecated: rliable offers no other way; the warning is silenced here)."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="random_state is deprecated", category=FutureWarning,
                                    module=r"arch\.bootstrap")
            yield np.random.RandomState(seed)
    finally:
        np.random.set_state(state)


def iqm_interval(rates: list[float], reps: int = 2000, seed: int = 0) -> tuple[float, float, float]:
    """IQM of per-run success rates and its stratified-bootstrap 95 % interval (rliable).

    ``rates``: one success rate per training run. With one run the interval is that run's
    rate (there is nothing to resample).
    """
    if not rates:
        raise ValueError("iqm_interval needs at least one run")
    if len(rates) == 1:
        return rates[0], rates[0], rates[0]
    from rliable import library as rly
    from rliable import metrics

    scores = {"agent": np.asarray(rates, dtype=float).reshape(-1, 1)}  # (runs, tasks)
    with seeded_bootstrap(seed) as random_state:
        point, interval = rly.get_interval_estimates(
            scores, lambda x: np.array([metrics.aggregate_iqm(x)]), reps=reps, random_state=random_state)
    return float(point["agent"][0]), float(interval["agent"][0, 0]), float(interval["agent"][1, 0])


def over_runs(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One summary per (env, setting, policy) over its training runs (planners: one record, unchanged).

    For a policy with runs, the record pools the runs' episodes: ``success_rate`` and
    ``success_ci95`` (Wilson) over all of them, the means weighted by episodes, plus
    ``runs``, ``run_success_rates`` and ``success_iqm`` with ``success_iqm_ci95``
    (stratified bootstrap over runs).
    """
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for r in records:
        key = (r["env"], tuple(sorted(r["params"].items())), r["policy"])
        groups.setdefault(key, []).append(r)
    out = []
    for group in groups.values():
        if group[0]["run"] is None:
            out.extend(group)
            continue
        n = sum(r["episodes"] for r in group)
        wins = sum(r["successes"] for r in group)
        pooled = dict(group[0], run=None, episodes=n, successes=wins, success_ci95=list(wilson_interval(wins, n)))
        for key in RATE_FIELDS.values():
            pooled[key] = sum(r[key] * r["episodes"] for r in group) / n
        for key in ("mean_steps", "mean_path_length", "mean_time", "mean_com_path_length"):
            vals = [(r[key], r["successes"]) for r in group if r[key] is not None]
            pooled[key] = sum(v * w for v, w in vals) / sum(w for _, w in vals) if vals else None
        for key in ("mean_steps_all", "mean_path_length_all", "mean_time_all", "mean_period"):
            vals = [(r[key], r["episodes"]) for r in group if r[key] is not None]
            pooled[key] = sum(v * w for v, w in vals) / sum(w for _, w in vals) if vals else None
        for key in ("min_period", "min_clearance_min", "min_zmp_margin_min"):
            vals = [r[key] for r in group if r[key] is not None]
            pooled[key] = min(vals) if vals else None
        for key in ("min_clearance_median", "min_zmp_margin_median", *TIMING_FIELDS):
            vals = [r[key] for r in group if r[key] is not None]
            pooled[key] = float(np.median(vals)) if vals else None  # median of the runs' figures
        rates = [r["success_rate"] for r in group]
        iqm, lo, hi = iqm_interval(rates)
        pooled.update(runs=[r["run"] for r in group], run_success_rates=rates,
                      success_iqm=iqm, success_iqm_ci95=[lo, hi],
                      seeds=group[0]["seeds"], outcomes=[o for r in group for o in r["outcomes"]])
        out.append(pooled)
    return out


def iqm_over_tasks(scores: Any, reps: int = 2000, seed: int = 0) -> tuple[float, float, float]:
    """IQM of a ``(runs, tasks)`` matrix of scores and its stratified-bootstrap 95 % interval over runs (rliable).

    The benchmark's aggregate of a tier (:mod:`footstep_gym.evaluation.benchmark`): one column per
    cell of the tier (every scene's), one row per training run, each entry a success rate. The IQM is
    the mean of the middle half of all ``runs x tasks`` entries (``scipy.stats.trim_mean`` cutting 25 %
    each side, rliable's ``aggregate_iqm``); the interval resamples the runs of each task with
    replacement (rliable's stratified bootstrap, ``reps`` resamples, seeded). With one run there is
    nothing to resample: the interval is the point ``(iqm, iqm)``.
    """
    matrix = np.asarray(scores, dtype=float)
    if matrix.ndim != 2 or matrix.size == 0:
        raise ValueError(f"iqm_over_tasks needs a non-empty (runs, tasks) matrix, got shape {matrix.shape}")
    from rliable import library as rly
    from rliable import metrics

    point = float(metrics.aggregate_iqm(matrix))
    if matrix.shape[0] == 1:
        return point, point, point
    with seeded_bootstrap(seed) as random_state:
        _, interval = rly.get_interval_estimates(
            {"policy": matrix}, lambda x: np.array([metrics.aggregate_iqm(x)]), reps=reps, random_state=random_state)
    return point, float(interval["policy"][0, 0]), float(interval["policy"][1, 0])
