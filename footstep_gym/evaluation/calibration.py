"""Calibration of the benchmark's cells: the null baselines' and the privileged solvers' success on validation seeds.

The protocol keeps a cell outside the ``paper`` tier only if the best null baseline
(:mod:`footstep_gym.planners.null`) succeeds in at most :data:`NULL_MAX` of its episodes (the cell
is not trivial) and the best privileged solver (:data:`PRIVILEGED`: ``oracle``, ``oracle-lookahead``,
both told the truth) in at least :data:`ORACLE_MIN` (the cell is solvable), both on the **validation**
split; a cell is *certified* solvable when that score rests on at least :data:`CERTIFY_EPISODES`
episodes (protocol 3). No other score decides whether a cell stays (docs/benchmark.md, "How the cells
are chosen").
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
#: The privileged solvers (they read the truth: upper bounds), the best of which decides solvability.
PRIVILEGED = ("oracle", "oracle-lookahead")
#: Protocol 3: a cell's solvability is certified on at least this many validation episodes.
CERTIFY_EPISODES = 100
#: The tier exempt from the null rule: the paper's scenes, kept exactly (its table says which cells a null solves).
EXEMPT_TIERS = ("paper",)


@dataclass(frozen=True)
class CellScore:
    """One policy's successes on one benchmark cell (``cell.label``: ``scene/tier/cell``)."""

    cell: BenchmarkCell
    policy: str
    successes: int
    episodes: int
    failed: tuple[tuple[int, str], ...] = ()  # (seed, outcome) of each episode that did not reach the goal

    @property
    def rate(self) -> float:
        return self.successes / self.episodes


def cell_name(cell: BenchmarkCell) -> str:
    """``tier/scene/cell``: how the calibration's table and ``calibrate.py --cell`` name a cell."""
    return f"{cell.tier}/{cell.scene}/{cell.name}"


def select_cells(cells: Sequence[BenchmarkCell], names: Sequence[str] | None) -> list[BenchmarkCell]:
    """The cells of ``cells`` named in ``names`` (:func:`cell_name`; all of them if ``names`` is None), in
    ``cells``' order; ``ValueError`` naming any name that is not one of them."""
    if names is None:
        return list(cells)
    known = {cell_name(c) for c in cells}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"unknown cell(s) {', '.join(map(repr, unknown))}: a cell is TIER/SCENE/CELL, one of "
                         f"{', '.join(sorted(known))}")
    return [c for c in cells if cell_name(c) in set(names)]


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
    failed: list[list[tuple[int, str]]] = [[] for _ in owners]
    for r in results:
        wins[r.cell_index] += r.outcome == "goal"
        if r.outcome != "goal":
            failed[r.cell_index].append((int(r.seed), str(r.outcome)))
    return [CellScore(bc, p, w, episodes, tuple(sorted(f))) for (bc, p), w, f in zip(owners, wins, failed)]


def best_null(scores: Sequence[CellScore]) -> dict[str, CellScore]:
    """Per cell label, the null baseline with the most successes (the first such in :data:`NULL_POLICIES`' order)."""
    best: dict[str, CellScore] = {}
    for s in scores:
        if s.policy in NULL_POLICIES and (s.cell.label not in best or s.successes > best[s.cell.label].successes):
            best[s.cell.label] = s
    return best


def oracle_scores(scores: Sequence[CellScore], policy: str = "oracle") -> dict[str, CellScore]:
    """Per cell label, ``policy``'s score (the oracle's by default; cells it did not run on are left out)."""
    return {s.cell.label: s for s in scores if s.policy == policy}


def best_privileged(scores: Sequence[CellScore]) -> dict[str, CellScore]:
    """Per cell label, the privileged solver (:data:`PRIVILEGED`) with the highest success rate (the first such in
    that order)."""
    best: dict[str, CellScore] = {}
    for s in scores:
        if s.policy in PRIVILEGED and (s.cell.label not in best or s.rate > best[s.cell.label].rate):
            best[s.cell.label] = s
    return best


def certified(score: CellScore) -> bool:
    """Whether a privileged score certifies its cell solvable: at least :data:`ORACLE_MIN` on at least
    :data:`CERTIFY_EPISODES` episodes."""
    return score.rate >= ORACLE_MIN and score.episodes >= CERTIFY_EPISODES


def broken(scores: Sequence[CellScore]) -> list[str]:
    """One line per cell (outside :data:`EXEMPT_TIERS`) that breaks the protocol's rule in ``scores``."""
    out = []
    for label, s in best_null(scores).items():
        if s.cell.tier not in EXEMPT_TIERS and s.rate > NULL_MAX:
            out.append(f"{label}: {s.policy} succeeds in {s.successes}/{s.episodes} > {NULL_MAX:g}")
    for label, s in best_privileged(scores).items():
        if s.cell.tier not in EXEMPT_TIERS and s.rate < ORACLE_MIN:
            out.append(f"{label}: the best privileged solver ({s.policy}) succeeds in {s.successes}/{s.episodes} "
                       f"< {ORACLE_MIN:g}")
    return out


def markdown_table(scores: Sequence[CellScore]) -> str:
    """The calibration table: per cell (in the benchmark's order) its rule, the best null baseline's and each
    privileged solver's success on validation seeds, whether the cell keeps the protocol's rule, and whether its
    solvability is certified (:func:`certified`)."""
    from footstep_gym import tiers

    nulls, best = best_null(scores), best_privileged(scores)
    solvers = [p for p in PRIVILEGED if any(s.policy == p for s in scores)] or ["oracle"]
    by_solver = {p: oracle_scores(scores, p) for p in solvers}
    lines = ["| cell | rule | best null (validation) | " + " | ".join(f"{p} (validation)" for p in solvers)
             + " | rule kept | certified |", "|---|---|---|" + "---|" * len(solvers) + "---|---|"]
    seen = list(dict.fromkeys(s.cell.label for s in scores))
    by_label = {s.cell.label: s.cell for s in scores}
    for label in seen:
        c = by_label[label]
        rule = tiers.cells(c.scene, c.tier, c.name)[0].rule
        n, o = nulls.get(label), best.get(label)
        null_text = "–" if n is None else f"{n.rate:.2f} ({n.successes}/{n.episodes}, {n.policy})"
        solver_texts = ["–" if by_solver[p].get(label) is None else
                        f"{by_solver[p][label].rate:.2f} ({by_solver[p][label].successes}/{by_solver[p][label].episodes})"
                        for p in solvers]
        if c.tier in EXEMPT_TIERS:
            kept = "exempt (paper)" + (": a null baseline solves it" if n is not None and n.rate > NULL_MAX else "")
        else:
            ok = (n is None or n.rate <= NULL_MAX) and (o is None or o.rate >= ORACLE_MIN)
            kept = ("yes" if ok else "**no**") + ("" if o is not None and n is not None else " (partial)")
        cert = "–" if o is None else ("yes" if certified(o) else
                                      f"no ({o.episodes} < {CERTIFY_EPISODES} episodes)" if o.rate >= ORACLE_MIN
                                      else "no")
        lines.append(f"| {cell_name(c)} | {rule} | {null_text} | {' | '.join(solver_texts)} | {kept} | "
                     f"{cert} |")
    return "\n".join(lines)


def scores_from_runs(docs: Sequence[dict]) -> tuple[list[CellScore], dict[tuple[str, str], float]]:
    """The scores of several ``calibrate.py`` runs (their ``calibration.json`` documents) as one list, and each
    (cell name, policy)'s cost in wall seconds per episode (its runs', weighted by episodes).

    Runs of a (cell, policy) on disjoint seed ranges (``offset``, ``episodes``: a calibration split over
    processes) add up; on the same range they must agree (the episodes are seeded) and the score that keeps its
    failures' seeds is kept. ``ValueError`` where two runs disagree, their ranges overlap otherwise, or a run
    names a cell the benchmark does not have."""
    cells = {cell_name(c): c for c in benchmark_cells()}
    parts: dict[tuple[str, str], list[tuple[CellScore, int, float]]] = {}
    for doc in docs:
        offset = int(doc.get("offset", 0))
        for row in doc["scores"]:
            name = f"{row['tier']}/{row['scene']}/{row['cell']}"
            if name not in cells:
                raise ValueError(f"a calibration run scores {name!r}, which is no cell of the benchmark")
            score = CellScore(cells[name], row["policy"], int(row["successes"]), int(row["episodes"]),
                              tuple((int(f["seed"]), str(f["outcome"])) for f in row.get("failed", ())))
            run_cost = doc.get("cost", {}).get(row["policy"], doc.get("cost", {}).get("null baselines", {}))
            spent = float(run_cost.get("s_per_episode", float("nan")))
            key = (name, score.policy)
            kept = parts.setdefault(key, [])
            same = [i for i, (old, old_offset, _) in enumerate(kept)
                    if (old_offset, old.episodes) == (offset, score.episodes)]
            if same:
                old = kept[same[0]][0]
                if old.successes != score.successes:
                    raise ValueError(f"two calibration runs of {score.policy} on {name} disagree: "
                                     f"{old.successes}/{old.episodes} and {score.successes}/{score.episodes} "
                                     f"(offset {offset})")
                if score.failed and not old.failed:
                    kept[same[0]] = (score, offset, spent)
                continue
            for old, old_offset, _ in kept:
                if offset < old_offset + old.episodes and old_offset < offset + score.episodes:
                    raise ValueError(f"two calibration runs of {score.policy} on {name} overlap: seeds "
                                     f"{old_offset}+{old.episodes} and {offset}+{score.episodes} into the split")
            kept.append((score, offset, spent))
    scores, cost = [], {}
    for key, kept in parts.items():
        first = kept[0][0]
        episodes = sum(k[0].episodes for k in kept)
        scores.append(CellScore(first.cell, first.policy, sum(k[0].successes for k in kept), episodes,
                                tuple(sorted(f for k in kept for f in k[0].failed))))
        cost[key] = sum(k[0].episodes * k[2] for k in kept) / episodes
    return scores, cost


def certification_table(scores: Sequence[CellScore], cost: dict[tuple[str, str], float]) -> str:
    """Protocol 3's certification: per cell outside :data:`EXEMPT_TIERS` (the benchmark's order), each privileged
    solver's success on validation seeds and its cost (wall seconds per episode, ``cost`` per (cell name, policy)),
    the best of them, and whether it certifies the cell (:func:`certified`)."""
    best = best_privileged(scores)
    solvers = [p for p in PRIVILEGED if any(s.policy == p for s in scores)]
    by_solver = {p: {cell_name(s.cell): s for s in scores if s.policy == p} for p in solvers}
    lines = ["| cell | " + " | ".join(f"{p} (validation)" for p in solvers)
             + " | best privileged | s per episode | certified |",
             "|---|" + "---:|" * len(solvers) + "---|---|---|"]
    for c in benchmark_cells():
        name = cell_name(c)
        if c.tier in EXEMPT_TIERS or c.label not in best:
            continue
        texts = [f"{by_solver[p][name].rate:.2f} ({by_solver[p][name].successes}/{by_solver[p][name].episodes})"
                 if name in by_solver[p] else "–" for p in solvers]
        b = best[c.label]
        spent = ", ".join(f"{p} {cost[(name, p)]:.1f}" for p in solvers if (name, p) in cost)
        verdict = "yes" if certified(b) else ("**no**" if b.rate < ORACLE_MIN else
                                             f"no ({b.episodes} < {CERTIFY_EPISODES} episodes)")
        lines.append(f"| {name} | {' | '.join(texts)} | {b.policy} {b.rate:.2f} | {spent} | {verdict} |")
    return "\n".join(lines)


def null_policies() -> list[str]:
    """Every null baseline's name."""
    return list(NULL_POLICIES)


__all__ = ["CERTIFY_EPISODES", "EXEMPT_TIERS", "NULL_MAX", "ORACLE_MIN", "PRIVILEGED", "SPLIT", "CellScore",
           "benchmark_cells", "best_null", "best_privileged", "broken", "certified",
           "calibration_tasks", "cell_name", "certification_table", "markdown_table", "null_policies", "oracle_scores", "score", "scores_from_runs", "select_cells", "split_seeds"]
