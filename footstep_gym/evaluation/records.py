"""The record of one evaluation cell, :class:`CellRecord`: one type for the rows of ``results.json``,
``benchmark.json`` and every table drawn from them, whose fields each say how they pool over training runs.

A *cell* is one env setting and policy (and, for a trained agent, one training run); its record summarises
its episodes (:func:`cell_record`). Definitions:

* ``success_rate``, ``collision_rate``, ``fall_rate``, ``timeout_rate``: fractions of the episodes that ended on the
  goal, a collision, an infeasible step (fall) or were truncated (step or time limit); they sum to 1;
  ``success_ci95``: the 95 % Wilson score interval of the success rate.
* ``mean_steps``, ``mean_path_length`` [m], ``mean_time`` [s], ``mean_com_path_length`` [m]: means over the
  *successful* episodes only (``None`` if there is none); the ``*_all`` variants are over every episode. The path
  is the walked path of the robot centre (the midpoint of the two feet), the paper's "length of path".
* ``mean_period`` / ``min_period`` [s]: the walking period ``T_SS + T_DS`` over every footstep; ``pso_step_rate``:
  the share of footsteps on which the policy ran PSO (``None``: it does not say).
* ``min_clearance_median`` / ``_min`` [m]: median and smallest over the episodes of an episode's smallest gap
  between the body circle and any obstacle (``None`` where nothing came within reach); ``min_zmp_margin_*`` [m]
  likewise for the ZMP's distance to the stable region's edge (negative: an infeasible step).
* ``safe_successes`` / ``safe_success_rate``: the episodes (the share of them) that reached the goal with their
  smallest clearance and smallest ZMP margin at least ``configs/eval.yaml``'s ``safe_success`` thresholds
  (:func:`~footstep_gym.evaluation.scores.safe_success`; absent from records written before they were kept).
* ``plan_ms_median`` / ``_p95`` / ``_p99`` / ``_max``: wall clock of ``policy.act`` per footstep [ms], pooled over
  the cell's footsteps: the only fields that depend on the machine
  (:data:`~footstep_gym.evaluation.stats.TIMING_FIELDS`).
* a benchmark cell adds where it is (``scene``, ``tier``, ``cell``, ``env_kwargs``) and ``upper_bound``.

Each field is declared with :func:`pooled`, which says how :func:`over_runs` combines the records of one cell's
training runs (:data:`POOLING`); a field declared without it is refused when the class is defined, and a dict with
a key the type does not have is refused by :meth:`CellRecord.from_dict`, so no metric is pooled by accident. A
pooled record also carries ``runs``, ``run_success_rates`` and the interquartile mean of the runs' success rates
with its stratified-bootstrap 95 % interval (``success_iqm``, ``success_iqm_ci95``; rliable).

:func:`frame` turns records into a pandas DataFrame, from which the tables that pivot records are drawn.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import MISSING, dataclass, field
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from footstep_gym.evaluation.scores import safe_success
from footstep_gym.evaluation.stats import OUTCOMES, RATE_FIELDS, EpisodeResult, iqm_over_tasks, wilson_interval

#: How a field pools over the training runs of one cell (the ``pool`` of :func:`pooled`).
POOLING = {
    "key": "what the cell is: the same in every run (checked)",
    "run": "the training run: None once pooled (the runs are listed in `runs`)",
    "sum": "the sum over the runs",
    "mean": "the mean of the runs' values weighted by `weight` (over the runs that have one)",
    "min": "the smallest of the runs' values",
    "median": "the median of the runs' values",
    "concat": "the runs' lists, one after the other",
    "wilson": "the Wilson 95 % interval of the pooled successes",
    "over_runs": "set when runs are pooled; None on a run's record",
}
#: The weights of a ``mean``: a record's episodes, successful episodes or footsteps.
WEIGHTS = ("episodes", "successes", "footsteps")


def pooled(pool: str, weight: str | None = None, *, optional: bool = False) -> Any:
    """A :class:`CellRecord` field that pools over runs as ``pool`` (a key of :data:`POOLING`; ``weight`` for a
    ``mean``). ``optional``: defaults to None and is left out of :meth:`CellRecord.to_dict` while None (the benchmark's
    fields on an evaluation's record, the over-runs fields on a run's)."""
    if pool not in POOLING:
        raise TypeError(f"unknown pooling {pool!r}; choose from {', '.join(POOLING)}")
    if (pool == "mean") != (weight is not None) or weight not in (None, *WEIGHTS):
        raise TypeError(f"a 'mean' takes one weight of {WEIGHTS}, and only a mean does (got {pool!r}, {weight!r})")
    metadata = {"pool": pool, "weight": weight, "optional": optional}
    return field(default=None, metadata=metadata) if optional else field(metadata=metadata)


def _is_pooled(value: Any) -> bool:
    return isinstance(value, dataclasses.Field) and "pool" in value.metadata


@dataclass
class CellRecord:
    """The result of one cell's episodes (see the module's docstring for each field)."""

    env: str = pooled("key")
    scenario: str = pooled("key")
    policy: str = pooled("key")
    run: str | None = pooled("run")
    params: dict[str, Any] = pooled("key")
    episodes: int = pooled("sum")
    successes: int = pooled("sum")
    success_rate: float = pooled("mean", "episodes")
    collision_rate: float = pooled("mean", "episodes")
    fall_rate: float = pooled("mean", "episodes")
    timeout_rate: float = pooled("mean", "episodes")
    success_ci95: list[float] = pooled("wilson")
    mean_steps: float | None = pooled("mean", "successes")
    mean_path_length: float | None = pooled("mean", "successes")  # [m]
    mean_time: float | None = pooled("mean", "successes")  # [s]
    mean_steps_all: float = pooled("mean", "episodes")
    mean_path_length_all: float = pooled("mean", "episodes")  # [m]
    mean_time_all: float = pooled("mean", "episodes")  # [s]
    mean_com_path_length: float | None = pooled("mean", "successes")  # [m]
    mean_period: float | None = pooled("mean", "footsteps")  # [s]
    min_period: float | None = pooled("min")  # [s]
    pso_step_rate: float | None = pooled("mean", "footsteps")
    min_clearance_median: float | None = pooled("median")  # [m]
    min_clearance_min: float | None = pooled("min")  # [m]
    min_zmp_margin_median: float | None = pooled("median")  # [m]
    min_zmp_margin_min: float | None = pooled("min")  # [m]
    plan_ms_median: float | None = pooled("median")  # [ms]
    plan_ms_p95: float | None = pooled("median")  # [ms]
    plan_ms_p99: float | None = pooled("median")  # [ms]
    plan_ms_max: float | None = pooled("median")  # [ms]
    seeds: list[int] = pooled("key")
    outcomes: list[str] = pooled("concat")
    # A benchmark cell (footstep_gym.evaluation.benchmark).
    scene: str | None = pooled("key", optional=True)
    tier: str | None = pooled("key", optional=True)
    cell: str | None = pooled("key", optional=True)
    env_kwargs: dict[str, Any] | None = pooled("key", optional=True)
    upper_bound: bool | None = pooled("key", optional=True)
    # Safe success (footstep_gym.evaluation.scores): kept since protocol 3.
    safe_successes: int | None = pooled("sum", optional=True)
    safe_success_rate: float | None = pooled("mean", "episodes", optional=True)
    # A record pooled over training runs (over_runs).
    runs: list[str] | None = pooled("over_runs", optional=True)
    run_success_rates: list[float] | None = pooled("over_runs", optional=True)
    success_iqm: float | None = pooled("over_runs", optional=True)
    success_iqm_ci95: list[float] | None = pooled("over_runs", optional=True)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        _check_pooling(cls.__name__, {name: cls.__dict__.get(name, MISSING)
                                      for name in cls.__dict__.get("__annotations__", {})})

    @property
    def footsteps(self) -> int:
        """Footsteps over every episode of the cell."""
        return round(self.mean_steps_all * self.episodes)

    @property
    def params_key(self) -> tuple[tuple[str, Any], ...]:
        """``params`` as a hashable tuple, in their order."""
        return tuple(self.params.items())

    def to_dict(self) -> dict[str, Any]:
        """The record as ``results.json`` / ``benchmark.json`` hold it (optional fields left out while None)."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)
                if not (f.metadata["optional"] and getattr(self, f.name) is None)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "CellRecord":
        """A record from ``results.json`` / ``benchmark.json``; a key the type does not have, or a missing one,
        raises ``ValueError`` naming it."""
        names = {f.name: f for f in dataclasses.fields(cls)}
        unknown = [k for k in data if k not in names]
        if unknown:
            raise ValueError(f"a cell record has no field {', '.join(map(repr, unknown))} (a new metric is a "
                             f"field of {cls.__name__}, declared with how it pools over runs)")
        missing = [n for n, f in names.items() if not f.metadata["optional"] and n not in data]
        if missing:
            raise ValueError(f"a cell record lacks {', '.join(missing)}")
        return cls(**dict(data))


def _plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return list(value)
    if isinstance(value, dict):
        return dict(value)
    return value


def _check_pooling(owner: str, declared: Mapping[str, Any]) -> None:
    for name, value in declared.items():
        if not _is_pooled(value):
            raise TypeError(f"{owner}.{name}: a cell record's field says how it pools over training runs: declare "
                            f"it as `{name}: ... = pooled(...)` (one of {', '.join(POOLING)})")


_check_pooling("CellRecord", {f.name: f for f in dataclasses.fields(CellRecord)})


def load_records(data: Iterable[Mapping[str, Any]]) -> list[CellRecord]:
    """Records from the parsed JSON of ``results.json`` (a list) or a ``benchmark.json``'s ``records``."""
    return [CellRecord.from_dict(d) for d in data]


def dump_records(records: Iterable[CellRecord]) -> str:
    """``results.json``'s text: the records as a JSON list."""
    return json.dumps([r.to_dict() for r in records], indent=2) + "\n"


# ---------------------------------------------------------------- a cell's episodes
def _mean(values: list[float]) -> float | None:
    return float(np.mean(values)) if values else None


def _percentile(values: np.ndarray, q: float) -> float | None:
    return float(np.percentile(values, q)) if values.size else None


def _quantiles(values: list[float | None]) -> tuple[float | None, float | None]:
    """(median, min) of the values that were measured."""
    got = [v for v in values if v is not None]
    return (float(np.median(got)), float(min(got))) if got else (None, None)


def cell_record(env_id: str, scenario: str, policy: str, params: Mapping[str, Any],
                episodes: Sequence[EpisodeResult], run: str | None = None, **where: Any) -> CellRecord:
    """The record of one cell's episodes (sorted by seed); ``run``: the agent's training run; ``where``: a
    benchmark cell's ``scene``, ``tier``, ``cell``, ``env_kwargs`` and ``upper_bound``."""
    episodes = sorted(episodes, key=lambda e: e.seed)
    n = len(episodes)
    if n == 0:
        raise ValueError(f"cell {env_id}/{policy}/{dict(params)} has no episodes")
    unknown = [e.outcome for e in episodes if e.outcome not in OUTCOMES]
    if unknown:
        raise ValueError(f"unknown episode outcome(s) {unknown}; expected one of {OUTCOMES}")
    counts = {o: sum(e.outcome == o for e in episodes) for o in OUTCOMES}
    won = [e for e in episodes if e.outcome == "goal"]
    plan = np.array([t for e in episodes for t in e.plan_ms], dtype=float)
    periods = [p for e in episodes for p in e.periods]
    pso = [bool(x) for e in episodes for x in e.pso_ran if x is not None]
    safe = sum(safe_success(e.outcome, e.min_clearance, e.min_zmp_margin) for e in episodes)
    clearance = _quantiles([e.min_clearance for e in episodes])
    zmp_margin = _quantiles([e.min_zmp_margin for e in episodes])
    return CellRecord(
        env=env_id, scenario=scenario, policy=policy, run=run, params=dict(params), episodes=n,
        successes=counts["goal"], **{key: counts[o] / n for o, key in RATE_FIELDS.items()},
        success_ci95=list(wilson_interval(counts["goal"], n)),
        mean_steps=_mean([e.steps for e in won]), mean_path_length=_mean([e.path_length for e in won]),
        mean_time=_mean([e.time for e in won]), mean_steps_all=_mean([e.steps for e in episodes]),
        mean_path_length_all=_mean([e.path_length for e in episodes]),
        mean_time_all=_mean([e.time for e in episodes]),
        mean_com_path_length=_mean([e.com_path_length for e in won]),
        mean_period=_mean(periods), min_period=float(min(periods)) if periods else None,
        pso_step_rate=(sum(pso) / len(pso)) if pso else None,
        min_clearance_median=clearance[0], min_clearance_min=clearance[1],
        min_zmp_margin_median=zmp_margin[0], min_zmp_margin_min=zmp_margin[1],
        safe_successes=safe, safe_success_rate=safe / n, plan_ms_median=_percentile(plan, 50), plan_ms_p95=_percentile(plan, 95), plan_ms_p99=_percentile(plan, 99),
        plan_ms_max=float(plan.max()) if plan.size else None,
        seeds=[e.seed for e in episodes], outcomes=[e.outcome for e in episodes], **where)


# ---------------------------------------------------------------- over training runs
def _cell_key(r: CellRecord) -> str:
    """What one cell is, all runs alike: its ``key`` fields but the seeds (checked when pooling)."""
    return json.dumps({f.name: getattr(r, f.name) for f in dataclasses.fields(r)
                       if f.metadata["pool"] == "key" and f.name != "seeds"}, sort_keys=True, default=str)


def pool_runs(group: Sequence[CellRecord]) -> CellRecord:
    """One record for the records of one cell's training runs, each field pooled as it declares
    (:data:`POOLING`), with the runs, their success rates and the IQM of those (rliable)."""
    cls = type(group[0])
    weights = {"episodes": [r.episodes for r in group], "successes": [r.successes for r in group],
               "footsteps": [r.footsteps for r in group]}
    n, wins = sum(weights["episodes"]), sum(weights["successes"])
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        pool, got = f.metadata["pool"], [getattr(r, f.name) for r in group]
        measured = [v for v in got if v is not None]
        if pool == "key":
            if any(v != got[0] for v in got):
                raise ValueError(f"the runs of {group[0].policy} on {group[0].env} {group[0].params} differ in "
                                 f"{f.name}: {got}")
            values[f.name] = got[0]
        elif pool == "sum":
            values[f.name] = sum(got) if len(measured) == len(got) else None
        elif pool == "mean":
            pairs = [(v, w) for v, w in zip(got, weights[f.metadata["weight"]]) if v is not None]
            total = sum(w for _, w in pairs)
            values[f.name] = sum(v * w for v, w in pairs) / total if pairs and total else None
        elif pool == "min":
            values[f.name] = min(measured) if measured else None
        elif pool == "median":
            values[f.name] = float(np.median(measured)) if measured else None
        elif pool == "concat":
            values[f.name] = [x for v in got for x in v]
        elif pool == "wilson":
            values[f.name] = list(wilson_interval(wins, n))
        elif pool == "run":
            values[f.name] = None
    rates = [r.success_rate for r in group]
    iqm, lo, hi = iqm_over_tasks(np.asarray(rates, dtype=float).reshape(-1, 1))
    values.update(runs=[r.run for r in group], run_success_rates=rates, success_iqm=iqm, success_iqm_ci95=[lo, hi])
    return cls(**values)


def over_runs(records: Sequence[CellRecord]) -> list[CellRecord]:
    """One record per cell over its training runs (:func:`pool_runs`), in the order cells first appear; a planner's
    record (no run) as it is."""
    groups: dict[str, list[CellRecord]] = {}
    for r in records:
        groups.setdefault(_cell_key(r), []).append(r)
    out: list[CellRecord] = []
    for group in groups.values():
        out.extend(group if group[0].run is None else [pool_runs(group)])
    return out


# ---------------------------------------------------------------- tables
def frame(records: Iterable[CellRecord]) -> "Any":
    """A pandas DataFrame, one row per record: every field (``params`` as a dict), and ``setting`` (the params as a
    hashable tuple), ``ci_lo`` / ``ci_hi`` (``success_ci95``) and ``n_runs`` (training runs pooled; 0 for a run's
    or a planner's record)."""
    import pandas as pd

    rows = [{**{f.name: getattr(r, f.name) for f in dataclasses.fields(r)}, "setting": r.params_key,
             "ci_lo": r.success_ci95[0], "ci_hi": r.success_ci95[1], "n_runs": len(r.runs or ())} for r in records]
    columns = [f.name for f in dataclasses.fields(CellRecord)] + ["setting", "ci_lo", "ci_hi", "n_runs"]
    return pd.DataFrame(rows, columns=columns, dtype=object)
