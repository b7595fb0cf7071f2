"""The cell record: one type whose every field says how it pools over training runs.

A metric declared without its pooling rule is refused when the class is defined, a record with a key the type does
not have is refused when it is read, and a new metric is one field (pooled as it declares, with nothing else to
edit). Every committed results file still reads into the type and writes back the same.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from footstep_gym.evaluation import records as rec
from footstep_gym.evaluation.records import CellRecord, cell_record, over_runs, pool_runs, pooled
from footstep_gym.evaluation.stats import EpisodeResult, wilson_interval

REPO = Path(__file__).resolve().parents[1]


def episode(seed: int, outcome: str, steps: int, pso: bool | None = None, clearance: float | None = 0.05,
            period: float = 0.8) -> EpisodeResult:
    return EpisodeResult(cell_index=0, seed=seed, outcome=outcome, steps=steps, time=0.5 * steps,
                         path_length=0.1 * steps, com_path_length=0.1 * steps, plan_ms=[1.0 + seed] * steps,
                         periods=[period] * steps, pso_ran=[pso] * steps, min_clearance=clearance,
                         min_zmp_margin=0.01 * (seed + 1))


def run(name: str, eps: list[EpisodeResult]) -> CellRecord:
    return cell_record("FootstepDoor-v0", "door", "agent:x", {"door_speed": 8.0}, eps, run=name)


def test_every_field_declares_how_it_pools():
    for f in dataclasses.fields(CellRecord):
        assert f.metadata["pool"] in rec.POOLING, f.name
        assert (f.metadata["pool"] == "mean") == (f.metadata["weight"] in rec.WEIGHTS), f.name


def test_a_metric_without_a_pooling_rule_is_refused_at_definition():
    with pytest.raises(TypeError, match=r"Mine\.energy: .*pooled\(\.\.\.\)"):
        @dataclasses.dataclass
        class Mine(CellRecord):
            energy: float | None = None
    with pytest.raises(TypeError, match=r"Bare\.energy"):
        @dataclasses.dataclass
        class Bare(CellRecord):
            energy: float = dataclasses.field(default=0.0)
    with pytest.raises(TypeError, match="a 'mean' takes one weight"):
        pooled("mean")
    with pytest.raises(TypeError, match="unknown pooling 'first'"):
        pooled("first")


def test_a_record_with_an_unknown_metric_is_refused_not_pooled_from_its_first_run():
    a, b = run("r1", [episode(0, "goal", 10)]), run("r2", [episode(0, "collision", 10)])
    data = [dict(a.to_dict(), energy=1.0), dict(b.to_dict(), energy=2.0)]
    with pytest.raises(ValueError, match="no field 'energy'"):
        over_runs(rec.load_records(data))
    with pytest.raises(ValueError, match="lacks success_rate"):
        CellRecord.from_dict({k: v for k, v in a.to_dict().items() if k != "success_rate"})


def test_a_new_metric_is_one_field_and_pools_as_it_says():
    @dataclasses.dataclass
    class WithEnergy(CellRecord):
        energy_min: float | None = pooled("min", optional=True)
        energy_mean: float | None = pooled("mean", "episodes", optional=True)

    runs = [WithEnergy(**{**dataclasses.asdict(run("r1", [episode(0, "goal", 10)])), "energy_min": 3.0,
                          "energy_mean": 1.0}),
            WithEnergy(**{**dataclasses.asdict(run("r2", [episode(0, "goal", 10), episode(1, "goal", 10)])),
                          "energy_min": 2.0, "energy_mean": 4.0})]
    with pytest.raises(ValueError, match="differ in seeds"):
        pool_runs(runs)  # the runs of one cell run the same seeds
    runs[0] = dataclasses.replace(runs[0], seeds=[0, 1])
    out = pool_runs(runs)
    assert isinstance(out, WithEnergy) and out.energy_min == 2.0 and out.energy_mean == pytest.approx(3.0)
    assert out.to_dict()["energy_mean"] == pytest.approx(3.0)


def test_over_runs_pools_each_field_by_its_rule():
    r1 = run("r1", [episode(0, "goal", 10, pso=True, clearance=None), episode(1, "collision", 30, pso=True)])
    r2 = run("r2", [episode(0, "goal", 20, pso=False, period=0.5), episode(1, "goal", 20, pso=False, period=0.5)])
    planner = cell_record("FootstepDoor-v0", "door", "fixed-period", {"door_speed": 8.0}, [episode(0, "goal", 9)])
    pooled_, same = over_runs([r1, planner, r2])
    assert same is planner
    assert (pooled_.episodes, pooled_.successes, pooled_.success_rate) == (4, 3, 0.75)
    assert pooled_.success_ci95 == list(wilson_interval(3, 4)) and pooled_.run is None
    assert pooled_.mean_steps == pytest.approx((10 * 1 + 20 * 2) / 3)  # over the successes
    assert pooled_.mean_steps_all == pytest.approx(20.0)  # over the episodes
    # Per footstep: 40 footsteps with PSO, 40 without; periods 0.8 over 40 and 0.5 over 40.
    assert pooled_.pso_step_rate == pytest.approx(0.5) and pooled_.mean_period == pytest.approx(0.65)
    assert pooled_.min_period == 0.5 and pooled_.min_clearance_min == 0.05
    assert pooled_.plan_ms_median == pytest.approx((r1.plan_ms_median + r2.plan_ms_median) / 2)
    assert pooled_.outcomes == ["goal", "collision", "goal", "goal"] and pooled_.seeds == [0, 1]
    assert pooled_.runs == ["r1", "r2"] and pooled_.run_success_rates == [0.5, 1.0]
    assert pooled_.success_iqm == pytest.approx(0.75)
    assert set(pooled_.to_dict()) == {f.name for f in dataclasses.fields(CellRecord)} - {
        "scene", "tier", "cell", "env_kwargs", "upper_bound"}
    assert "runs" not in planner.to_dict() and "tier" not in planner.to_dict()


def _committed() -> list[tuple[str, list[dict]]]:
    found = [(str(p.relative_to(REPO)), json.loads(p.read_text(encoding="utf-8")))
             for p in sorted((REPO / "baselines" / "results").glob("*/results.json"))]
    for p in sorted((REPO / "baselines" / "results" / "benchmark-protocol2").glob("*/benchmark.json")):
        doc = json.loads(p.read_text(encoding="utf-8"))
        name = str(p.relative_to(REPO))
        found += [(f"{name}:records", doc["records"]), (f"{name}:summary", doc["summary"])]
    return found


def test_every_committed_results_file_reads_into_records_and_writes_back_the_same():
    files = _committed()
    assert len(files) >= 10
    for name, data in files:
        records = rec.load_records(data)
        assert [r.to_dict() for r in records] == data, name
        assert [list(r.to_dict()) for r in records] == [list(d) for d in data], name  # the keys' order too


def test_a_benchmarks_summary_is_its_records_over_runs():
    for p in sorted((REPO / "baselines" / "results" / "benchmark-protocol2").glob("*/benchmark.json")):
        doc = json.loads(p.read_text(encoding="utf-8"))
        assert [r.to_dict() for r in over_runs(rec.load_records(doc["records"]))] == doc["summary"], p.parent.name


@pytest.mark.parametrize("policy", ["ppo", "fixed-period"])
def test_a_benchmarks_aggregates_are_its_records_score_matrix(policy):
    """The tier aggregates (IQM over the tier's cells with the bootstrap over runs, from the one score matrix) of a
    committed file are what its committed records give."""
    from footstep_gym.evaluation import benchmark

    doc = json.loads((REPO / "baselines" / "results" / "benchmark-protocol2" / policy / "benchmark.json").read_text())
    again = benchmark.tier_aggregates(rec.load_records(doc["records"]))
    # A file written before protocol 3 lacks the scene-balanced fields: its own fields must come back the same.
    assert [{k: a[k] for k in old} for a, old in zip(again, doc["aggregates"])] == doc["aggregates"]
    assert len(again) == len(doc["aggregates"])
