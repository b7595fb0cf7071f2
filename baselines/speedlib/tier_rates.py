"""Per-tier figures: env steps/s and the period-aware planner's time per footstep on every cell of
every benchmark tier of every scene (``configs/benchmark.yaml``, :mod:`footstep_gym.tiers`), beside ``paper``
(:func:`bench_tiers`).

The cells are the benchmark's (:func:`footstep_gym.evaluation.benchmark.benchmark_cells`): each is
``gymnasium.make(env_id, tier=TIER, tier_cell=CELL)``. For each cell, in this order:

1. **planning time**: the period-aware planner through the evaluation runner, as the planners section
   times it (:class:`~speedlib.planner_times.PlannerRun` on the runner cell with the tier's selector:
   the runner's warm-up of that cell first, then one episode per seed, the same seeds for every cell), its
   commands recorded;
2. **env steps/s**: those commands replayed from the same seeds, resets inside the timed loop, with the env
   section's machinery (:func:`~speedlib.env_rates.measure_singles`: every cell built and warmed up,
   then their repetitions interleaved round by round, so ratios between cells pair per round). The env
   section makes its cells by id; each tier cell gets a temporary id in the namespace
   :data:`NAMESPACE` (the scene's spec with ``tier`` and ``tier_cell`` added to its kwargs), removed from
   gymnasium's registry when the section ends.

A tier's rate per scene is, round by round, the median over its cells' rates (``rates``); its planning
time pools its cells' footsteps. The ratios against ``paper`` (paired per round) and the targets are
in :mod:`.targets`.
"""

from __future__ import annotations

import statistics
import time
import warnings
from typing import Any

from .env_rates import measure_singles
from .planner_times import WARMUP_SEED_OFFSET, PlannerRun, make_policy_fn
from .settings import Settings, error, log
from .timing import summary, tail_summary

#: The planner timed on every tier cell (and whose commands the env replays).
PLANNER = "period-aware"
#: gymnasium namespace of the section's temporary env ids (one per tier cell).
NAMESPACE = "footstep_bench_tiers"
#: The tier the others are compared with.
BASE_TIER = "paper"


class TierPlannerRun(PlannerRun):
    """:class:`PlannerRun` on a benchmark cell: the runner's cell carries the tier's selector
    (``tier=TIER, tier_cell=CELL``), as the evaluation's benchmark runs it."""

    def __init__(self, planner: str, bcell: Any, max_steps: int | None) -> None:
        from footstep_gym.evaluation.runner import Cell

        super().__init__(planner, bcell.env_id, max_steps)
        self.cell = Cell(bcell.env_id, bcell.scene, planner, tuple(bcell.selector))


def select_cells(scenes: list[str] | None = None, tiers: list[str] | None = None,
                 max_cells: int | None = None) -> list[Any]:
    """The benchmark's cells (tier by tier, scene by scene, in the file's order), of ``scenes`` / ``tiers`` only
    if given, and at most ``max_cells`` per scene and tier (the first ones)."""
    from footstep_gym.evaluation.benchmark import benchmark_cells

    kept: list[Any] = []
    count: dict[tuple[str, str], int] = {}
    for bc in benchmark_cells(scenes, tiers):
        key = (bc.scene, bc.tier)
        if max_cells is not None and count.get(key, 0) >= max_cells:
            continue
        count[key] = count.get(key, 0) + 1
        kept.append(bc)
    return kept


def register_cell(bcell: Any) -> str:
    """A temporary gymnasium id for ``bcell``: the scene's spec with its selector in the kwargs."""
    import gymnasium as gym

    base = gym.spec(bcell.env_id)
    new_id = f"{NAMESPACE}/{base.name}-{bcell.tier}-{bcell.name}-v{base.version or 0}"
    gym.register(id=new_id, entry_point=base.entry_point, reward_threshold=base.reward_threshold,
                 nondeterministic=base.nondeterministic, max_episode_steps=base.max_episode_steps,
                 order_enforce=base.order_enforce, disable_env_checker=base.disable_env_checker,
                 additional_wrappers=base.additional_wrappers, vector_entry_point=base.vector_entry_point,
                 kwargs={**base.kwargs, **dict(bcell.selector)})
    return new_id


def unregister(ids: list[str]) -> None:
    import gymnasium as gym

    for env_id in ids:
        gym.registry.pop(env_id, None)


def _plan_cell(bcell: Any, settings: Settings, seed: int, seeds: list[int]
               ) -> tuple[dict[str, Any], list, list[float]]:
    """The planner on one cell: ``(result, recorded episodes, act times)``; a failure gives ``{"skipped": why}``."""
    try:
        run = TierPlannerRun(PLANNER, bcell, settings.planner_max_steps)
        run.warm_up(seed + WARMUP_SEED_OFFSET, settings.planner_warmup_steps)
        t0 = time.perf_counter()
        budget_hit = False
        for i, s in enumerate(seeds):
            if settings.tier_budget_s is not None and i >= 1 and time.perf_counter() - t0 > settings.tier_budget_s:
                budget_hit = True
                break
            run.episode(s)
    except Exception as exc:  # noqa: BLE001 - one broken cell must not lose the rest
        return {"skipped": error(exc)}, [], []
    result = {**run.result(), "seeds_planned": list(seeds), "budget_exhausted": budget_hit}
    log(f"  tiers {bcell.label:32s} planner: {len(run.episodes)} episodes, {len(run.plan_s)} footsteps, "
        f"median {1e3 * result['plan_time_s']['median']:.2f} ms, {time.perf_counter() - t0:.1f} s")
    return result, run.recorded, list(run.plan_s)


def _aggregate(records: dict[str, dict[str, Any]], plan_s: dict[str, list[float]]) -> dict[str, dict[str, Any]]:
    """Per scene and tier: the per-round median over the tier's cells' rates, the median of the cells' medians,
    the planning time pooled over the cells' footsteps, and the episodes."""
    groups: dict[str, dict[str, list[str]]] = {}
    for label, r in records.items():
        groups.setdefault(r["scene"], {}).setdefault(r["tier"], []).append(label)
    out: dict[str, dict[str, Any]] = {}
    for scene, by_tier in groups.items():
        for tier, labels in by_tier.items():
            live = [lb for lb in labels if "rates" in records[lb]["env"]]
            n_rounds = min((len(records[lb]["env"]["rates"]) for lb in live), default=0)
            rates = [statistics.median(records[lb]["env"]["rates"][k] for lb in live) for k in range(n_rounds)]
            steps = sum(records[lb]["env"]["steps"] for lb in live)
            episodes = sum(records[lb]["env"]["episodes"] for lb in live)
            planned = [records[lb]["planner"] for lb in labels if "plan_time_s" in records[lb]["planner"]]
            pooled = [t for lb in labels for t in plan_s.get(lb, [])]
            successes = sum(p["successes"] for p in planned)
            n_eps = sum(p["episodes"] for p in planned)
            out.setdefault(scene, {})[tier] = {
                "cells": [records[lb]["cell"] for lb in labels],
                "cells_measured": [records[lb]["cell"] for lb in live],
                "steps_per_s": summary(rates), "rates": rates,
                "median_of_cells_steps_per_s": (statistics.median(records[lb]["env"]["steps_per_s"]["median"]
                                                                  for lb in live) if live else None),
                "mean_episode_steps": steps / episodes if episodes else None,
                "replay_matches_recording": all(records[lb]["env"].get("replay_matches_recording", False)
                                                for lb in live) if live else None,
                "plan_time_s": tail_summary(pooled), "footsteps": len(pooled),
                "episodes": n_eps, "successes": successes, "success_rate": successes / n_eps if n_eps else None,
            }
    return out


def bench_tiers(settings: Settings, seed: int, scenes: list[str] | None = None,
                tiers: list[str] | None = None) -> dict[str, Any]:
    """Env steps/s (the planner's commands replayed, cells interleaved) and the period-aware planner's time per
    footstep on every cell of every tier of every scene (``scenes`` / ``tiers``: those only), per cell and per
    scene and tier (:func:`_aggregate`). The seeds are the planners section's: ``seed, seed + 1, ...``."""
    make_policy, reason = make_policy_fn()
    if make_policy is None:
        return {"skipped": reason}
    cells = select_cells(scenes, tiers, settings.tier_max_cells)
    seeds = [seed + i for i in range(max(settings.planner_episodes, 1))]
    records: dict[str, dict[str, Any]] = {}
    plan_s: dict[str, list[float]] = {}
    replays: dict[str, list] = {}
    ids: dict[str, str] = {}
    try:
        for bc in cells:
            ids[bc.label] = register_cell(bc)
            kwargs = dict(bc.env_kwargs)
            records[bc.label] = {"scene": bc.scene, "tier": bc.tier, "cell": bc.name, "env_id": bc.env_id,
                                 "selector": dict(bc.selector), "env_kwargs": kwargs,
                                 "crowd_model": kwargs.get("crowd_model"),
                                 "orca": kwargs.get("crowd_model") == "orca"}
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                records[bc.label]["planner"], replays[ids[bc.label]], plan_s[bc.label] = _plan_cell(
                    bc, settings, seed, seeds)
        log(f"  tiers: env steps/s of {len(cells)} cells (the planner's commands replayed)")
        singles = measure_singles([(ids[bc.label], "planner") for bc in cells], settings, seed, replays)
        for bc in cells:
            records[bc.label]["env"] = singles[(ids[bc.label], "planner")]
    finally:
        unregister(list(ids.values()))
    return {"planner": PLANNER, "base_tier": BASE_TIER, "seeds": seeds, "cells": records,
            "scenes": _aggregate(records, plan_s)}
