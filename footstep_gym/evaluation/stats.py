"""The statistics of an evaluation: episodes' outcomes, the Wilson interval, and rliable's interval estimates over
training runs.

* :class:`EpisodeResult`: what one episode reports; :data:`OUTCOMES` its endings;
* :func:`wilson_interval`: the 95 % interval of a success rate over independent episodes;
* :func:`interval_estimates`: any aggregate of a ``(runs, tasks)`` score matrix with rliable's stratified-bootstrap
  95 % interval over runs, seeded (:func:`seeded_bootstrap`); :func:`iqm_over_tasks` is its interquartile mean;
* :func:`score_matrix`: the ``(runs, cells)`` success rates of one policy on one tier's cells.

A cell's record (:class:`~footstep_gym.evaluation.records.CellRecord`) is built from these.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

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


#: Bootstrap resamples and seed of every interval over training runs.
REPS = 2000
SEED = 0


def interval_estimates(matrix: Any, func: Callable[[np.ndarray], np.ndarray], reps: int = REPS, seed: int = SEED
                       ) -> tuple[np.ndarray, np.ndarray]:
    """``func``'s point estimates on a ``(runs, tasks)`` matrix and their stratified-bootstrap 95 % intervals over
    runs (``rliable.library.get_interval_estimates``, ``reps`` resamples, :func:`seeded_bootstrap` afresh for each
    call: the same on every rerun, and one policy's interval does not depend on another's):
    ``(point (k,), interval (2, k) lower/upper)``. With one run there is nothing to resample: the interval is the
    point."""
    matrix = np.asarray(matrix, dtype=float)
    if matrix.ndim != 2 or matrix.size == 0:
        raise ValueError(f"need a non-empty (runs, tasks) matrix, got shape {matrix.shape}")
    if matrix.shape[0] == 1:
        point = np.asarray(func(matrix), dtype=float)
        return point, np.stack([point, point])
    from rliable import library as rly

    with seeded_bootstrap(seed) as random_state:
        point, interval = rly.get_interval_estimates({"policy": matrix}, func, reps=reps, random_state=random_state)
    return np.asarray(point["policy"], dtype=float), np.asarray(interval["policy"], dtype=float)


def iqm(matrix: np.ndarray) -> np.ndarray:
    """``[IQM]`` of a ``(runs, tasks)`` matrix: the mean of the middle half of all its entries (rliable's
    ``aggregate_iqm``, ``scipy.stats.trim_mean`` cutting 25 % each side)."""
    from rliable import metrics

    return np.array([metrics.aggregate_iqm(matrix)])


def iqm_over_tasks(scores: Any, reps: int = REPS, seed: int = SEED) -> tuple[float, float, float]:
    """``(IQM, lo, hi)``: the IQM of a ``(runs, tasks)`` matrix of success rates and its stratified-bootstrap 95 %
    interval over runs (:func:`interval_estimates`). A tier's aggregate has one column per cell of the tier (every
    scene's); a cell's summary over training runs has one column. One run: the interval is the point."""
    point, interval = interval_estimates(scores, iqm, reps, seed)
    return float(point[0]), float(interval[0, 0]), float(interval[1, 0])


def score_matrix(records: Sequence[Any], cells: Sequence[str]) -> tuple[np.ndarray, list[str]]:
    """The ``(runs, cells)`` success rates of one policy's records on ``cells`` (``scene/cell`` labels) it has records
    of, and those cells (in ``cells``' order). ``records``: benchmark records of one tier, objects with ``scene``,
    ``cell``, ``run`` and ``success_rate``.

    The ``k``-th run (in name order) of each cell is in row ``k`` (an agent shipped per scene pairs its runs by
    order); a policy with fewer runs for some cell is cut to the fewest. A planner is one run: one row.
    """
    by_cell: dict[str, list[Any]] = {}
    for r in records:
        by_cell.setdefault(f"{r.scene}/{r.cell}", []).append(r)
    covered = [c for c in cells if c in by_cell]
    if not covered:
        return np.zeros((0, 0)), []
    columns = [sorted(by_cell[c], key=lambda r: r.run or "") for c in covered]
    n_runs = min(len(col) for col in columns)
    return np.array([[col[k].success_rate for col in columns] for k in range(n_runs)], dtype=float), covered
