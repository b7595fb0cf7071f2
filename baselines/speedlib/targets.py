"""The speed targets (PASS / MISS / N/A in its report; never asserted in timed tests) and the ratios
they are read from (:func:`evaluate_targets`)."""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from .env_rates import BEFORE_ID
from .fmt import fmt_num
from .timing import median_ratio_interval, summary

#: FootstepDoor-v0 steps/s over BipedalWalker-v3's, per kind of commands: 2x on a steady walk;
#: random commands fall within a few footsteps, so that row mostly times reset; the planner's commands walk.
DOOR_VS_BIPEDAL = {"near_nominal": 2.0, "random": 1.0, "planner": 1.0}
LIPM_TARGET_PER_S = 1_000_000
PLAN_MEDIAN_FRACTION = 0.01  # of the nominal period
PLAN_P99_FRACTION = 0.05
PSO_SPEEDUP_TARGET = 10.0
#: The tiers section: the structure tier's env steps/s of each scene (and of each ORCA crowd cell) over the
#: paper tier's scripted crowd (the slowest paper scene: the yardstick), and the period-aware planner on
#: structure. Each tier's rate over its own scene's paper tier is reported beside, as a ratio with no target.
TIER_VS_PAPER = 0.5
#: The tier those targets are on: new structure (second door, two-way traffic, ORCA crowds).
TARGET_TIER = "structure"
TIER_PLAN_MEDIAN_S = 0.002
TIER_PLAN_P99_S = 0.020


def evaluate_targets(res: dict[str, Any], nominal_period: float) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """``(targets, ratios)`` of a speed result ``res``: each target with its threshold, measured value and
    status, and the ratios between cells (paired per interleaved round where they were interleaved)."""
    targets: list[dict[str, Any]] = []
    ratios: dict[str, Any] = {}

    def add(name: str, threshold: str, shown: str, ok: bool | None, **extra: Any) -> None:
        targets.append({"target": name, "threshold": threshold, "measured": shown,
                        "status": "N/A" if ok is None else ("PASS" if ok else "MISS"), **extra})

    envs = res.get("env_steps", {})
    bw_cell = envs.get("BipedalWalker-v3", {}).get("random", {}).get("single", {})
    door = envs.get("FootstepDoor-v0", {})
    for commands in ("random", "near_nominal", "planner"):
        d_cell = door.get(commands, {}).get("single", {})
        key = f"FootstepDoor_{commands}/BipedalWalker"
        goal = DOOR_VS_BIPEDAL[commands]
        name = (f"FootstepDoor-v0 steps/s >= {goal:g}x BipedalWalker-v3 (1 process, "
                f"{commands.replace('_', '-')} commands)")
        if "rates" in d_cell and "rates" in bw_cell:
            # Paired per interleaved round (the same background load on both), then the median.
            r = summary([d / b for d, b in zip(d_cell["rates"], bw_cell["rates"])])
            ratios[key] = r
            add(name, f"paired ratio >= {goal:g}", f"{r['median']:.2f} (IQR {r['q1']:.2f}–{r['q3']:.2f})",
                r["median"] >= goal, value=r["median"])
        else:
            ratios[key] = None
            if envs:
                why = d_cell.get("skipped") or bw_cell.get("skipped") or "not measured"
                add(name, f"paired ratio >= {goal:g}", f"n/a ({why})"[:120], None)
    before = envs.get(BEFORE_ID, {}).get("near_nominal", {}).get("single", {})
    now = door.get("near_nominal", {}).get("single", {})
    if "rates" in before:  # --compare-with: the same steady walk on another checkout's env, same rounds
        if "rates" in now:
            ratios["FootstepDoor_near_nominal/before"] = summary([a / b for a, b in zip(now["rates"], before["rates"])])
        if "rates" in bw_cell:
            ratios["FootstepDoor_near_nominal_before/BipedalWalker"] = summary(
                [a / b for a, b in zip(before["rates"], bw_cell["rates"])])

    lipm_res = res.get("lipm", {})
    if lipm_res:
        v = lipm_res["check_steps"][str(1024)]["commands_per_s"]["median"]
        add("LIPM check_steps, batch 1024", f">= {fmt_num(LIPM_TARGET_PER_S)} commands/s", f"{fmt_num(v)} /s",
            v >= LIPM_TARGET_PER_S, value=v)

    plans = res.get("planners", {})
    if plans and "skipped" not in plans:
        med_lim, p99_lim = PLAN_MEDIAN_FRACTION * nominal_period, PLAN_P99_FRACTION * nominal_period
        for env_id, by_planner in plans.items():
            pa, pso = by_planner.get("period-aware", {}), by_planner.get("pso-only", {})
            if "plan_time_s" not in pa:
                add(f"period-aware planning on {env_id}", "runs", pa.get("skipped", "n/a"), False)
                continue
            m, p99 = pa["plan_time_s"]["median"], pa["plan_time_s"]["p99"]
            add(f"period-aware median plan time, {env_id}", f"<= {med_lim * 1e3:.0f} ms (1% of T_n)",
                f"{m * 1e3:.2f} ms", m <= med_lim, value=m)
            add(f"period-aware p99 plan time, {env_id}", f"<= {p99_lim * 1e3:.0f} ms (5% of T_n)",
                f"{p99 * 1e3:.2f} ms", p99 <= p99_lim, value=p99)
            if "plan_time_s" in pso:
                speedup = pso["plan_time_s"]["median"] / m if m > 0 else math.inf
                ratios[f"pso-only/period-aware median plan time, {env_id}"] = speedup
                interval = ""
                if pa.get("seeds") and pa.get("seeds") == pso.get("seeds") and "plan_time_by_episode_s" in pa:
                    lo, hi = median_ratio_interval(pso["plan_time_by_episode_s"], pa["plan_time_by_episode_s"],
                                                   np.random.default_rng(0))
                    ratios[f"pso-only/period-aware median plan time, {env_id}, 95% CI"] = [lo, hi]
                    interval = f" (95% CI {lo:.1f}–{hi:.1f}, episodes resampled)"
                ok = speedup >= PSO_SPEEDUP_TARGET and pa["success_rate"] >= pso["success_rate"]
                add(f"period-aware vs pso-only, {env_id}",
                    f">= {PSO_SPEEDUP_TARGET:.0f}x faster, success >= pso-only's",
                    f"{speedup:.1f}x{interval}, success {pa['successes']}/{pa['episodes']} vs "
                    f"{pso['successes']}/{pso['episodes']}", ok, value=speedup)
            else:
                add(f"period-aware vs pso-only, {env_id}", f">= {PSO_SPEEDUP_TARGET:.0f}x faster, success >= "
                    "pso-only's", f"n/a (pso-only: {pso.get('skipped', 'not measured')})"[:120], None)
    elif plans:
        add("period-aware planning", "runs", f"n/a ({plans['skipped']})"[:120], None)

    tiers = res.get("tiers", {})
    if tiers:
        _tier_targets(tiers, add, ratios)
    return targets, ratios


def tier_ratio_key(scene: str, tier: str, cell: str | None = None) -> str:
    """The key in ``ratios`` of a tier's (or one of its cells') env steps/s over the scene's paper tier's."""
    return f"tiers {scene}/{tier}{'/' + cell if cell else ''} / {scene}/paper"


def _tier_targets(tiers: dict[str, Any], add: Callable[..., None], ratios: dict[str, Any]) -> None:
    """The tiers section's ratios (every tier and cell over its scene's paper tier, paired per interleaved round)
    and targets (hard >= TIER_VS_PAPER x paper per scene and per ORCA crowd cell; the planner on hard)."""
    if "skipped" in tiers:
        add("tiers section", "runs", f"n/a ({tiers['skipped']})"[:120], None)
        return
    base = tiers.get("base_tier", "paper")
    cells = tiers.get("cells", {})

    def paired(num: list[float] | None, den: list[float] | None) -> dict[str, float] | None:
        return summary([a / b for a, b in zip(num, den)]) if num and den else None

    for scene, by_tier in tiers.get("scenes", {}).items():
        paper = by_tier.get(base, {}).get("rates")
        for tier, agg in by_tier.items():
            if tier != base:
                ratios[tier_ratio_key(scene, tier)] = paired(agg.get("rates"), paper)
        for c in cells.values():
            if c["scene"] == scene and c["tier"] != base:
                ratios[tier_ratio_key(scene, c["tier"], c["cell"])] = paired(c.get("env", {}).get("rates"), paper)
        hard = by_tier.get(TARGET_TIER)
        if hard is None:
            continue
        scripted = tiers.get("scenes", {}).get("crowd", {}).get(base, {}).get("rates")
        key = f"tiers {scene}/{TARGET_TIER} / crowd/{base}"
        ratios[key] = paired(hard.get("rates"), scripted)
        checks = [(f"{TARGET_TIER} tier env steps/s >= {TIER_VS_PAPER:g}x the paper (scripted) crowd's, {scene} (1 process, "
                   "planner commands; median over the cells per round)", key)]
        checks += [(f"{TARGET_TIER}/{c['cell']} (ORCA crowd) env steps/s >= {TIER_VS_PAPER:g}x paper (scripted) crowd",
                    tier_ratio_key(scene, TARGET_TIER, c["cell"]))
                   for c in cells.values() if c["scene"] == scene and c["tier"] == TARGET_TIER and c.get("orca")]
        for name, key in checks:
            r = ratios.get(key)
            if r is None:
                add(name, f"paired ratio >= {TIER_VS_PAPER:g}", "n/a (not measured)", None)
            else:
                add(name, f"paired ratio >= {TIER_VS_PAPER:g}",
                    f"{r['median']:.2f} (IQR {r['q1']:.2f}–{r['q3']:.2f})", r["median"] >= TIER_VS_PAPER,
                    value=r["median"])
        p = hard.get("plan_time_s", {})
        if p.get("n"):
            add(f"period-aware median plan time, {TARGET_TIER} tier, {scene}", f"<= {TIER_PLAN_MEDIAN_S * 1e3:g} ms",
                f"{p['median'] * 1e3:.2f} ms ({p['n']} footsteps)", p["median"] <= TIER_PLAN_MEDIAN_S,
                value=p["median"])
            add(f"period-aware p99 plan time, {TARGET_TIER} tier, {scene}", f"<= {TIER_PLAN_P99_S * 1e3:g} ms",
                f"{p['p99'] * 1e3:.2f} ms ({p['n']} footsteps)", p["p99"] <= TIER_PLAN_P99_S, value=p["p99"])
        else:
            add(f"period-aware plan time, {TARGET_TIER} tier, {scene}", f"median <= {TIER_PLAN_MEDIAN_S * 1e3:g} ms, p99 <= "
                f"{TIER_PLAN_P99_S * 1e3:g} ms", "n/a (not measured)", None)
