"""The speed run's ``tiers`` section (``speedlib.tier_rates``): a tiny in-process run (one
scene, its paper cell and one structure cell, a few footsteps) gives well-formed records, ratios, targets and a
table; the targets' PASS/MISS logic on made-up figures.

No timing thresholds here: the targets live in the speed run's own PASS/MISS table.
"""

from __future__ import annotations

import dataclasses
import math
import statistics

import gymnasium as gym
import pytest

from speedlib import timing
from speedlib.machine import loadavg, machine_info
from speedlib.reports import speed_report
from speedlib.settings import MODES, SECTIONS
from speedlib.targets import TIER_PLAN_MEDIAN_S, TIER_PLAN_P99_S, evaluate_targets, tier_ratio_key
from speedlib.tier_rates import NAMESPACE, bench_tiers, select_cells

TINY = dataclasses.replace(MODES["smoke"], tier_max_cells=1)
CELLS = ("crowd/paper/default", "crowd/structure/counter_flow")  # the scripted crowd and the first ORCA cell


@pytest.fixture(scope="module")
def tiny():
    return bench_tiers(TINY, 0, scenes=["crowd"], tiers=["paper", "structure"])


def _positive_finite(x, what: str) -> None:
    assert isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x > 0, f"{what}: {x!r}"


def test_the_section_is_registered():
    assert "tiers" in SECTIONS
    assert MODES["smoke"].tier_max_cells == 1 and MODES["full"].tier_max_cells is None


def test_select_cells_keeps_the_first_cells_of_each_scene_and_tier():
    every = select_cells(["crowd"], ["structure"])
    assert [c.name for c in every][:2] == ["counter_flow", "crossing_flows"] and len(every) >= 2
    assert [c.label for c in select_cells(["crowd"], ["paper", "structure"], max_cells=1)] == list(CELLS)
    assert all(dict(c.selector) == {"tier": c.tier, "tier_cell": c.name} for c in every)


def test_a_tiny_run_gives_well_formed_records(tiny):
    assert "skipped" not in tiny, tiny.get("skipped")
    assert tiny["planner"] == "period-aware" and tiny["base_tier"] == "paper"
    assert tiny["seeds"] == [0]
    assert list(tiny["cells"]) == list(CELLS)
    for label, c in tiny["cells"].items():
        scene, tier, cell = label.split("/")
        assert (c["scene"], c["tier"], c["cell"], c["env_id"]) == (scene, tier, cell, "FootstepCrowd-v0")
        assert c["selector"] == {"tier": tier, "tier_cell": cell}
        assert c["orca"] is (tier == "structure")  # counter_flow: crowd_model orca; the paper crowd is scripted
        env, pl = c["env"], c["planner"]
        assert "skipped" not in env and "skipped" not in pl, (env.get("skipped"), pl.get("skipped"))
        assert len(env["rates"]) == env["steps_per_s"]["n"] == TINY.repetitions
        for r in env["rates"]:
            _positive_finite(r, f"{label} rate")
        assert env["replay_matches_recording"] is True  # the recorded episodes replay as they ran
        assert env["mean_episode_steps"] >= 1
        assert 1 <= pl["footsteps"] <= TINY.planner_max_steps * pl["episodes"]
        assert pl["plan_time_s"]["n"] == pl["footsteps"] and pl["seeds"] == [0]
        _positive_finite(pl["plan_time_s"]["median"], f"{label} plan median")
    # The section's temporary env ids are gone from gymnasium's registry.
    assert not [k for k in gym.registry if k.startswith(NAMESPACE + "/")]


def test_a_tiny_run_aggregates_per_scene_and_tier(tiny):
    assert set(tiny["scenes"]) == {"crowd"} and list(tiny["scenes"]["crowd"]) == ["paper", "structure"]
    for tier, agg in tiny["scenes"]["crowd"].items():
        cell = tiny["cells"][f"crowd/{tier}/{agg['cells'][0]}"]
        assert agg["cells"] == agg["cells_measured"] and len(agg["cells"]) == 1
        # One cell: the per-round median over the tier's cells is that cell's rates.
        assert agg["rates"] == pytest.approx(cell["env"]["rates"])
        assert agg["steps_per_s"]["median"] == pytest.approx(statistics.median(cell["env"]["rates"]))
        assert agg["footsteps"] == agg["plan_time_s"]["n"] == cell["planner"]["footsteps"]
        assert agg["episodes"] == cell["planner"]["episodes"]
        assert agg["replay_matches_recording"] is True


def test_a_tiny_run_gives_ratios_targets_and_a_table(tiny):
    res = {"meta": {"mode": "smoke", "machine": machine_info(), "load_average_start": loadavg(),
                    "load_average_end": loadavg(), "duration_s": 1.0}, "tiers": tiny}
    res["targets"], res["ratios"] = evaluate_targets(res, 0.8)
    paper = tiny["cells"]["crowd/paper/default"]["env"]["rates"]
    orca = tiny["cells"]["crowd/structure/counter_flow"]["env"]["rates"]
    paired = timing.summary([a / b for a, b in zip(orca, paper)])
    assert res["ratios"][tier_ratio_key("crowd", "structure")]["median"] == pytest.approx(paired["median"])
    assert res["ratios"][tier_ratio_key("crowd", "structure", "counter_flow")]["median"] == pytest.approx(paired["median"])
    names = [t["target"] for t in res["targets"]]
    assert names == ["structure tier env steps/s >= 0.5x the paper (scripted) crowd's, crowd (1 process, planner "
                     "commands; median over the cells per round)",
                     "structure/counter_flow (ORCA crowd) env steps/s >= 0.5x paper (scripted) crowd",
                     "period-aware median plan time, structure tier, crowd", "period-aware p99 plan time, structure tier, crowd"]
    assert {t["status"] for t in res["targets"]} <= {"PASS", "MISS"}
    text = speed_report(res)
    assert "## Tiers: env steps per second and planning time per tier" in text
    assert "| crowd | structure | counter_flow (ORCA) |" in text and "| crowd | paper | 1 |" in text
    for t in res["targets"]:
        assert f"| {t['target']} | {t['threshold']} | {t['measured']} | {t['status']} |" in text


def _cell(scene: str, tier: str, name: str, rates: list[float], orca: bool = False) -> dict:
    return {"scene": scene, "tier": tier, "cell": name, "orca": orca, "env": {"rates": rates}}


def test_tier_targets_pass_miss_logic():
    cells = {"door/paper/default": _cell("door", "paper", "default", [10.0, 10.0, 10.0]),
             "door/structure/a": _cell("door", "structure", "a", [5.0, 6.0, 4.0]),
             "crowd/paper/default": _cell("crowd", "paper", "default", [4.0, 2.0, 4.0]),
             "crowd/structure/orca": _cell("crowd", "structure", "orca", [1.0, 1.0, 1.0], orca=True),
             "crowd/structure/noisy": _cell("crowd", "structure", "noisy", [4.0, 2.0, 4.0])}
    plan = lambda m, p99, n=40: {"median": m, "p95": p99, "p99": p99, "mean": m, "max": p99, "n": n}  # noqa: E731
    tiers = {"base_tier": "paper", "cells": cells, "scenes": {
        "door": {"paper": {"rates": [10.0, 10.0, 10.0], "plan_time_s": plan(0.001, 0.002)},
                 "structure": {"rates": [5.0, 6.0, 4.0], "plan_time_s": plan(TIER_PLAN_MEDIAN_S, TIER_PLAN_P99_S)}},
        "crowd": {"paper": {"rates": [4.0, 2.0, 4.0], "plan_time_s": plan(0.001, 0.002)},
                  # per round, the median over the two hard cells: 2.5, 1.5, 2.5
                  "structure": {"rates": [2.5, 1.5, 2.5], "plan_time_s": plan(0.0021, 0.025)}}}}
    targets, ratios = evaluate_targets({"tiers": tiers}, 0.8)
    status = {t["target"]: t["status"] for t in targets}
    door = ("structure tier env steps/s >= 0.5x the paper (scripted) crowd's, door (1 process, planner commands; median "
            "over the cells per round)")
    crowd = door.replace(", door (", ", crowd (")
    # Reported beside: each tier over its own scene's paper tier (no target).
    assert ratios[tier_ratio_key("door", "structure")]["median"] == pytest.approx(0.5)  # 0.5, 0.6, 0.4 paired
    assert ratios[tier_ratio_key("crowd", "structure")]["median"] == pytest.approx(0.625)  # 0.625, 0.75, 0.625
    # The target: each scene's hard tier over the scripted (paper) crowd, paired per round.
    assert ratios["tiers door/structure / crowd/paper"]["median"] == pytest.approx(1.25)  # 1.25, 3.0, 1.0
    assert status[door] == "PASS"
    assert ratios["tiers crowd/structure / crowd/paper"]["median"] == pytest.approx(0.625)
    assert status[crowd] == "PASS"
    tiers["scenes"]["crowd"]["structure"]["rates"] = [2.0, 1.0, 1.0]  # 0.5, 0.5, 0.25: exactly 0.5 passes
    assert {t["target"]: t["status"] for t in evaluate_targets({"tiers": tiers}, 0.8)[0]}[crowd] == "PASS"
    tiers["scenes"]["crowd"]["structure"]["rates"] = [1.9, 1.0, 1.0]  # 0.475, 0.5, 0.25
    assert {t["target"]: t["status"] for t in evaluate_targets({"tiers": tiers}, 0.8)[0]}[crowd] == "MISS"
    tiers["scenes"]["crowd"]["structure"]["rates"] = [2.5, 1.5, 2.5]
    assert ratios[tier_ratio_key("crowd", "structure", "orca")]["median"] == pytest.approx(0.25)  # 0.25, 0.5, 0.25
    assert status["structure/orca (ORCA crowd) env steps/s >= 0.5x paper (scripted) crowd"] == "MISS"
    assert not any("structure/noisy (ORCA" in n for n in status)  # only ORCA cells get a target of their own
    assert status["period-aware median plan time, structure tier, door"] == "PASS"  # at the limits: PASS
    assert status["period-aware p99 plan time, structure tier, door"] == "PASS"
    assert status["period-aware median plan time, structure tier, crowd"] == "MISS"
    assert status["period-aware p99 plan time, structure tier, crowd"] == "MISS"
    # Without the scripted crowd's rates (not measured) the target is N/A, never a failure.
    tiers["scenes"]["crowd"]["paper"]["rates"] = []
    status = {t["target"]: t["status"] for t in evaluate_targets({"tiers": tiers}, 0.8)[0]}
    assert status[door] == "N/A"
    assert [t["status"] for t in evaluate_targets({"tiers": {"skipped": "no planners"}}, 0.8)[0]] == ["N/A"]
