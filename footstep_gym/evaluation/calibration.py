"""Calibration of the benchmark's cells: the null baselines' and the oracle's success on validation seeds.

The protocol keeps a cell outside the ``paper`` tier only if the best null baseline
(:mod:`footstep_gym.planners.null`) succeeds in at most :data:`NULL_MAX` of its episodes (the cell
is not trivial) and the oracle (:mod:`footstep_gym.planners.oracle`) in at least
:data:`ORACLE_MIN` (the cell is solvable), both on the **validation** split; no other score
decides whether a cell stays (docs/benchmark.md, "How the cells are chosen").
``python baselines/calibrate.py`` runs it and writes the table docs/benchmark.md quotes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from footstep_gym import registry
from footstep_gym.evaluation.benchmark import BenchmarkCell, benchmark_cells
from footstep_gym.evaluation.runner import Cell, Task, run_tasks
from footstep_gym.evaluation.splits import split_seeds
from footstep_gym.planners.null import NULL_POLICIES

#: The split the calibration reads (never the test split).
SPLIT = "validation"
#: A cell is trivial above this success of its best null baseline, and unsolvable below :data:`ORACLE_MIN` of the
#: oracle's.
NULL_MAX = 0.1
ORACLE_MIN = 0.9
#: The tier exempt from the null rule: the paper's scenes, kept exactly (its table says which cells a null solves).
EXEMPT_TIERS = ("paper",)


@dataclass(frozen=True)
class CellScore:
    """One policy's successes on one benchmark cell (``cell.label``: ``scene/tier/cell``)."""

    cell: BenchmarkCell
    policy: str
    successes: int
    episodes: int

    @property
    def rate(self) -> float:
        return self.successes / self.episodes


def calibration_tasks(cells: Sequence[BenchmarkCell], policies: Sequence[str], episodes: int, offset: int = 0
                      ) -> tuple[list[Task], list[tuple[BenchmarkCell, str]]]:
    """The episodes of every ``policy`` on every cell, on ``episodes`` validation seeds from the ``offset``-th on;
    and, per runner cell index, ``(benchmark cell, policy)``."""
    seeds = split_seeds(SPLIT, episodes, offset)
    entries = {p: registry.resolve(p) for p in policies}
    owners = [(bc, p) for bc in cells for p in policies]
    tasks = [Task(i, Cell(bc.env_id, bc.scene, p, bc.selector, entry=entries[p]), s)
             for i, (bc, p) in enumerate(owners) for s in seeds]
    return tasks, owners


def score(cells: Sequence[BenchmarkCell], policies: Sequence[str], episodes: int, offset: int = 0,
          workers: int = 1, progress: bool = True) -> list[CellScore]:
    """Success counts of each policy on each cell over ``episodes`` validation seeds (cell by cell, then policy)."""
    tasks, owners = calibration_tasks(cells, policies, episodes, offset)
    results = run_tasks(tasks, workers, progress=progress)
    wins = [0] * len(owners)
    for r in results:
        wins[r.cell_index] += r.outcome == "goal"
    return [CellScore(bc, p, w, episodes) for (bc, p), w in zip(owners, wins)]


def best_null(scores: Sequence[CellScore]) -> dict[str, CellScore]:
    """Per cell label, the null baseline with the most successes (the first such in :data:`NULL_POLICIES`' order)."""
    best: dict[str, CellScore] = {}
    for s in scores:
        if s.policy in NULL_POLICIES and (s.cell.label not in best or s.successes > best[s.cell.label].successes):
            best[s.cell.label] = s
    return best


def oracle_scores(scores: Sequence[CellScore]) -> dict[str, CellScore]:
    """Per cell label, the oracle's score (cells it did not run on are left out)."""
    return {s.cell.label: s for s in scores if s.policy == "oracle"}


def broken(scores: Sequence[CellScore]) -> list[str]:
    """One line per cell (outside :data:`EXEMPT_TIERS`) that breaks the protocol's rule in ``scores``."""
    out = []
    for label, s in best_null(scores).items():
        if s.cell.tier not in EXEMPT_TIERS and s.rate > NULL_MAX:
            out.append(f"{label}: {s.policy} succeeds in {s.successes}/{s.episodes} > {NULL_MAX:g}")
    for label, s in oracle_scores(scores).items():
        if s.cell.tier not in EXEMPT_TIERS and s.rate < ORACLE_MIN:
            out.append(f"{label}: the oracle succeeds in {s.successes}/{s.episodes} < {ORACLE_MIN:g}")
    return out


def markdown_table(scores: Sequence[CellScore]) -> str:
    """The calibration table: per cell (in the benchmark's order) its rule, the best null baseline's and the
    oracle's success on validation seeds, and whether the cell keeps the protocol's rule."""
    from footstep_gym import tiers

    nulls, oracle = best_null(scores), oracle_scores(scores)
    lines = ["| cell | rule | best null (validation) | oracle (validation) | rule kept |", "|---|---|---|---|---|"]
    seen = list(dict.fromkeys(s.cell.label for s in scores))
    by_label = {s.cell.label: s.cell for s in scores}
    for label in seen:
        c = by_label[label]
        rule = tiers.cells(c.scene, c.tier, c.name)[0].rule
        n, o = nulls.get(label), oracle.get(label)
        null_text = "–" if n is None else f"{n.rate:.2f} ({n.successes}/{n.episodes}, {n.policy})"
        oracle_text = "–" if o is None else f"{o.rate:.2f} ({o.successes}/{o.episodes})"
        if c.tier in EXEMPT_TIERS:
            kept = "exempt (paper)" + (": a null baseline solves it" if n is not None and n.rate > NULL_MAX else "")
        else:
            ok = (n is None or n.rate <= NULL_MAX) and (o is None or o.rate >= ORACLE_MIN)
            kept = ("yes" if ok else "**no**") + ("" if o is not None and n is not None else " (partial)")
        lines.append(f"| {c.tier}/{c.scene}/{c.name} | {rule} | {null_text} | {oracle_text} | {kept} |")
    return "\n".join(lines)


def null_policies() -> list[str]:
    """Every null baseline's name."""
    return list(NULL_POLICIES)


__all__ = ["EXEMPT_TIERS", "NULL_MAX", "ORACLE_MIN", "SPLIT", "CellScore", "benchmark_cells", "best_null", "broken",
           "calibration_tasks", "markdown_table", "null_policies", "oracle_scores", "score", "split_seeds"]
