"""One command, one leaderboard row: ``eval_planner.py --benchmark``.

The command runs end to end on one episode per cell (every cell of every tier in process; a partial run
of two scenes and two tiers as a user runs it, in a subprocess; the same on a local Ray), writes
``benchmark.json`` / ``benchmark.md`` into a temporary folder moved into place, and refuses bad options
before touching ``--out``. The records carry every field of the protocol; the tier aggregate (IQM with a
stratified-bootstrap interval over training runs) is checked against hand-worked cases.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.stats

from script_helpers import load_script

from footstep_gym import tiers
from footstep_gym.evaluation import benchmark, report
from footstep_gym.evaluation.splits import split_seeds
from footstep_gym.evaluation.records import cell_record
from footstep_gym.evaluation.stats import EpisodeResult, iqm_over_tasks

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "baselines" / "eval_planner.py"
FAST = "fixed-period"  # the quickest planner per footstep
#: Every field a benchmark record has, with its type (None allowed where a cell may have no success).
RECORD_FIELDS = {
    "scene": str, "tier": str, "cell": str, "env_kwargs": dict, "upper_bound": bool, "env": str, "policy": str,
    "params": dict, "episodes": int, "successes": int, "success_rate": float, "success_ci95": list,
    "collision_rate": float, "fall_rate": float, "timeout_rate": float, "mean_time": (float, type(None)),
    "mean_path_length": (float, type(None)), "min_clearance_median": (float, type(None)),
    "min_clearance_min": (float, type(None)), "min_zmp_margin_median": float, "min_zmp_margin_min": float,
    "plan_ms_median": float, "plan_ms_p99": float, "seeds": list, "outcomes": list,
}
AGGREGATE_FIELDS = {"tier": str, "policy": str, "upper_bound": bool, "success": float, "success_ci95": list,
                    "safe_success": float, "safe_success_ci95": list, "success_iqm": float, "success_iqm_ci95": list,
                    "success_mean": float, "runs": int, "cells": list, "scenes": list, "episodes": int}


def squash(text: str) -> str:
    """Markdown without the padding around table cells."""
    return re.sub(r" *\| *", " | ", text)


def episodes(wins: int, n: int = 10) -> list[EpisodeResult]:
    return [EpisodeResult(cell_index=0, seed=20000 + i, outcome="goal" if i < wins else "collision", steps=20,
                          time=10.0, path_length=2.5, com_path_length=2.6, plan_ms=[1.0], periods=[0.8],
                          pso_ran=[None], min_clearance=0.03, min_zmp_margin=0.01) for i in range(n)]


def run_cli(*args: str, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=REPO, capture_output=True, text=True,
                          timeout=timeout)


def check_document(doc: dict, episodes: int, labels: list[str]) -> None:
    assert doc["benchmark"] == "footstep_gym" and doc["protocol"]["split"] == "validation"  # no --release
    assert doc["protocol"]["seeds"] == split_seeds("validation", episodes)
    assert [f"{c['scene']}/{c['tier']}/{c['cell']}" for c in doc["protocol"]["cells"]] == labels
    assert [f"{r['scene']}/{r['tier']}/{r['cell']}" for r in doc["records"]] == labels  # a planner: one run
    for r in doc["records"]:
        for key, kind in RECORD_FIELDS.items():
            assert isinstance(r[key], kind), (key, r[key])
        assert r["params"] == {"tier": r["tier"], "tier_cell": r["cell"]}
        assert r["env_kwargs"] == tiers.plain(tiers.cells(r["scene"], r["tier"], r["cell"])[0].kwargs)
        assert r["episodes"] == episodes and r["seeds"] == split_seeds("validation", episodes)
        assert sum(r[k] for k in ("success_rate", "collision_rate", "fall_rate", "timeout_rate")) == pytest.approx(1)
        lo, hi = r["success_ci95"]
        assert 0 <= lo <= r["success_rate"] <= hi <= 1
    by_tier = {a["tier"]: a for a in doc["aggregates"]}
    assert list(by_tier) == list(dict.fromkeys(label.split("/")[1] for label in labels))
    for tier, a in by_tier.items():
        for key, kind in AGGREGATE_FIELDS.items():
            assert isinstance(a[key], kind), (key, a[key])
        rates = sorted(r["success_rate"] for r in doc["records"] if r["tier"] == tier)
        assert a["runs"] == 1 and a["success_iqm_ci95"] == [a["success_iqm"]] * 2  # a planner: one run
        assert a["success_iqm"] == pytest.approx(iqm_over_tasks([rates])[0])
        # The headline: each scene weighs the same, each cell within its scene the same (by hand, from the records).
        mine = [r for r in doc["records"] if r["tier"] == tier]
        scenes = sorted({r["scene"] for r in mine})
        by_scene = [np.mean([r["success_rate"] for r in mine if r["scene"] == sc]) for sc in scenes]
        assert a["success"] == pytest.approx(np.mean(by_scene))
        lo, hi = a["success_ci95"]
        assert lo <= a["success"] <= hi and a["iqm_runs"] is None  # one run: no IQM over runs
        if any(0 < r["success_rate"] < 1 for r in mine):  # a planner's interval is its episodes' noise, not a point
            assert lo < hi
        assert a["safe_success"] <= a["success"] + 1e-12


# ---------------------------------------------------------------- the cells
def test_the_benchmark_is_every_cell_of_every_tier_of_every_scene():
    cells = benchmark.benchmark_cells()
    expected = [f"{scene}/{tier}/{c.name}" for tier in tiers.tier_names() for scene in ("door", "crossing", "crowd")
                for c in tiers.cells(scene, tier)]
    assert [c.label for c in cells] == expected and benchmark.is_complete(cells)
    assert all(c.selector == (("tier", c.tier), ("tier_cell", c.name)) for c in cells)
    partial = benchmark.benchmark_cells(["crowd"], ["structure"])
    assert [c.label for c in partial] == [c.label for c in cells if c.scene == "crowd" and c.tier == "structure"]
    assert not benchmark.is_complete(partial)
    with pytest.raises(ValueError, match="unknown benchmark tier"):
        benchmark.benchmark_cells(tiers=["impossible"])


# ---------------------------------------------------------------- end to end
def test_every_cell_end_to_end_in_process(tmp_path, capsys):
    """The whole benchmark at one episode per cell, written over an earlier run (a user's file beside it kept)."""
    out = tmp_path / "bench"
    out.mkdir()
    (out / "run.json").write_text('{"mode": "benchmark"}\n')
    (out / "benchmark.json").write_text("{}\n")
    (out / "notes.txt").write_text("keep")
    script = load_script("eval_planner")
    argv = ["--benchmark", "--policy", FAST, "--episodes", "1", "--workers", "1", "--out", str(out)]
    assert script.main(argv) == 0
    doc = json.loads((out / "benchmark.json").read_text())
    labels = [c.label for c in benchmark.benchmark_cells()]
    check_document(doc, 1, labels)
    assert doc["complete"] and doc["policy"] == FAST and doc["label"] == FAST and not doc["upper_bound"]
    text = squash((out / "benchmark.md").read_text())
    assert "## Leaderboard row" in text and "Partial run" not in text
    for tier in tiers.tier_names():
        assert f"| **{tier}** | **all** |" in text
    assert (out / "notes.txt").read_text() == "keep" and (out / "episodes.csv").is_file()
    assert json.loads((out / "run.json").read_text())["complete"]
    assert f"| {FAST} |" in squash(capsys.readouterr().out)  # the row printed
    assert not list(tmp_path.glob(".bench.*"))  # no temporary folder left


def test_a_partial_run_from_the_command_line(tmp_path):
    out = tmp_path / "bench"
    proc = run_cli("--benchmark", "--policy", FAST, "--episodes", "1", "--env", "crossing", "--env", "crowd",
                   "--tier", "paper", "--tier", "structure", "--workers", "2", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((out / "benchmark.json").read_text())
    labels = [c.label for c in benchmark.benchmark_cells(["crossing", "crowd"], ["paper", "structure"])]
    check_document(doc, 1, labels)
    assert not doc["complete"] and "Partial run" in (out / "benchmark.md").read_text()


def _walk_forward(scene: str, seed: int):
    return lambda observation: [0.04, 0.08, 0.0, 0.6, 0.2]


def test_an_in_distribution_row_is_its_tier_only(tmp_path):
    """A method trained on a tier's cells runs on that tier's cells only, and is a complete row of that track."""
    doc = benchmark.evaluate(_walk_forward, name="walker-noise", out=tmp_path / "id", episodes=1, workers=1,
                             trained_on_tier="noise")
    assert [f"{c['scene']}/{c['tier']}/{c['cell']}" for c in doc["protocol"]["cells"]] == \
        [c.label for c in benchmark.benchmark_cells(tiers=["noise"])]
    assert doc["track"] == benchmark.IN_DISTRIBUTION and doc["trained_on_tier"] == "noise" and doc["complete"]
    assert [a["tier"] for a in doc["aggregates"]] == ["noise"]
    assert "**In-distribution track**: trained on the noise tier" in (tmp_path / "id" / "benchmark.md").read_text()
    some = benchmark.evaluate(_walk_forward, name="walker-noise", out=tmp_path / "some", episodes=1, workers=1,
                              trained_on_tier="noise", scenes=["door"])
    assert not some["complete"]  # one scene of the tier: a partial row


@pytest.mark.parametrize("kwargs, message", [
    ({"trained_on_tier": "paper"}, "'paper' has no distribution to train on"),
    ({"trained_on_tier": "train"}, "is on the generalisation track"),
    ({"trained_on_tier": "hard"}, "unknown tier 'hard'"),
    ({"trained_on_tier": "noise", "tiers": ["structure"]}, "tested on it only"),
])
def test_a_bad_in_distribution_tier_is_refused_before_anything_runs(kwargs, message, tmp_path):
    with pytest.raises(ValueError, match=re.escape(message)):
        benchmark.evaluate(_walk_forward, name="walker", out=tmp_path / "x", episodes=1, workers=1, **kwargs)
    assert not (tmp_path / "x").exists()


def test_a_shipped_agent_registered_with_a_tier_runs_there_only(tmp_path):
    """ppo-structure (registered with tier structure) gets the structure tier's cells without an option; a
    registered policy cannot be moved to another track."""
    for env_id in ("FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"):
        run = tmp_path / "agents" / "ppo-structure" / f"{env_id}_1"
        run.mkdir(parents=True)
        (run / f"{env_id}.zip").write_bytes(b"")
    common = dict(agents=None, name=None, episodes=1, envs=None, out=tmp_path / "x", workers=1,
                  backend="local", ray_address=None, agents_dir=tmp_path / "agents")
    settings = benchmark.benchmark_settings(policies=["ppo-structure"], tiers=None, **common)
    assert settings.trained_on_tier == "structure" and settings.tiers == ("structure",)
    assert {c.tier for c in settings.cells} == {"structure"}
    with pytest.raises(benchmark.OptionError, match="tested on it only"):
        benchmark.benchmark_settings(policies=["ppo-structure"], tiers=["noise"], **common)
    with pytest.raises(benchmark.OptionError, match="registered as trained on tier 'structure'"):
        benchmark.benchmark_settings(policies=["ppo-structure"], tiers=None, trained_on_tier="noise", **common)


def test_the_ray_backend_gives_the_same_records(tmp_path):
    pytest.importorskip("ray")
    script = load_script("eval_planner")
    common = ["--benchmark", "--policy", FAST, "--episodes", "2", "--env", "crossing", "--tier", "paper",
              "--tier", "structure"]
    assert script.main([*common, "--workers", "1", "--out", str(tmp_path / "local")]) == 0
    assert script.main([*common, "--workers", "2", "--backend", "ray", "--out", str(tmp_path / "ray")]) == 0
    local, remote = (json.loads((tmp_path / name / "benchmark.json").read_text()) for name in ("local", "ray"))
    timing = ("plan_ms_median", "plan_ms_p95", "plan_ms_p99", "plan_ms_max")
    strip = lambda doc: [{k: v for k, v in r.items() if k not in timing} for r in doc["records"]]  # noqa: E731
    assert strip(local) == strip(remote) and local["aggregates"] == remote["aggregates"]
    assert json.loads((tmp_path / "ray" / "run.json").read_text())["backend"] == "ray"


@pytest.mark.parametrize("args, message", [
    (["--policy", FAST, "--policy", "period-aware"], "one method"),
    ([], "one method"),
    (["--policy", FAST, "--paper"], "--paper does not apply"),
    (["--policy", FAST, "--paper", "--video"], "--paper, --video do not apply"),
    (["--policy", FAST, "--door-speed", "8"], "--door-speed"),
    (["--policy", FAST, "--split", "train"], "--split train"),
    (["--policy", FAST, "--release", "--tier", "paper"], "--release runs a whole row"),
    (["--policy", FAST, "--release", "--episodes", "3"], "--release runs 100 episodes per cell"),
    (["--policy", FAST, "--tier", "impossible"], "unknown benchmark tier"),
    (["--policy", "teleport"], "unknown policy 'teleport'"),
    (["--policy", FAST, "--name", "x"], "--name names an --agent"),
    (["--policy", FAST, "--trained-on-tier", "noise"], "fixed-period is registered on the generalisation track"),
])
def test_bad_benchmark_options_exit_2_before_touching_out(args, message, tmp_path):
    proc = run_cli("--benchmark", *args, "--out", str(tmp_path / "x"), timeout=120)
    assert proc.returncode == 2 and message in proc.stderr, proc.stderr
    assert not (tmp_path / "x").exists()


def test_benchmark_options_need_benchmark(tmp_path):
    proc = run_cli("--tier", "paper", "--out", str(tmp_path / "x"), timeout=120)
    assert proc.returncode == 2 and "--tier goes with --benchmark only" in proc.stderr
    assert not (tmp_path / "x").exists()


# ---------------------------------------------------------------- the aggregate, by hand
def test_iqm_over_tasks_hand_worked():
    # One run, four cells: the IQM drops the lowest and the highest quarter (one value each): (0.5 + 0.6) / 2.
    assert iqm_over_tasks([[0.0, 0.5, 0.6, 1.0]]) == (0.55, 0.55, 0.55)
    # Two runs, four cells, eight values 0.2 ... 0.9: the middle four 0.4, 0.5, 0.6, 0.7 give 0.55. Each resample
    # draws each cell's two runs from {run a, run b}: all-a gives IQM 0.5, all-b 0.6, and every mix lies between.
    iqm, lo, hi = iqm_over_tasks([[0.2, 0.4, 0.6, 0.8], [0.3, 0.5, 0.7, 0.9]])
    assert iqm == pytest.approx(0.55) and 0.5 - 1e-12 <= lo <= iqm <= hi <= 0.6 + 1e-12 and lo < hi
    # Identical runs: every resample is the same matrix, so the interval is the point.
    assert iqm_over_tasks([[0.2, 0.4, 0.6, 0.8]] * 3) == pytest.approx((0.5, 0.5, 0.5))
    with pytest.raises(ValueError):
        iqm_over_tasks([])


def test_tier_aggregates_over_training_runs_and_scenes():
    def record(tier, scene, cell, run, rate, policy="agent:mine"):
        return cell_record(f"Footstep{scene.title()}-v0", scene, policy, {"tier": tier, "tier_cell": cell},
                           episodes(round(10 * rate)), run=run, scene=scene, tier=tier, cell=cell, env_kwargs={},
                           upper_bound=False)

    rates = {("door", "a"): (0.2, 0.3), ("door", "b"): (0.4, 0.5), ("crowd", "a"): (0.6, 0.7),
             ("crowd", "b"): (0.8, 0.9)}
    records = [record("hard", scene, cell, run, r[k]) for (scene, cell), r in rates.items()
               for k, run in enumerate(("run_2", "run_1"))]  # the runs out of name order: paired by name
    records.append(record("paper", "door", "default", None, 1.0, policy=FAST))
    hard, paper = benchmark.tier_aggregates(records)
    assert (hard["tier"], hard["runs"], hard["scenes"], hard["episodes"]) == ("hard", 2, ["crowd", "door"], 80)
    assert hard["success_iqm"] == pytest.approx(0.55) and hard["success_mean"] == pytest.approx(0.55)
    lo, hi = hard["success_iqm_ci95"]
    assert 0.5 - 1e-12 <= lo < hi <= 0.6 + 1e-12
    assert hard["runs_used"] == ["run_1", "run_2"]
    assert (paper["policy"], paper["success_iqm"], paper["success_iqm_ci95"], paper["runs"]) == (FAST, 1.0,
                                                                                                 [1.0, 1.0], 1)
    assert hard["success"] == pytest.approx(0.55) and hard["iqm_runs"] is None  # 2 runs: no IQM over runs


def test_tier_aggregates_headline_weighs_each_scene_the_same():
    """Two door cells and four crowd cells: the headline is the mean of the two scenes' means, not of the six cells,
    and no cell is dropped (an IQM over the six would drop the 0.0 door cell)."""
    def record(scene, cell, successes, run=None):
        return cell_record(f"Footstep{scene.title()}-v0", scene, FAST, {"tier": "hard", "tier_cell": cell},
                           episodes(successes), run=run, scene=scene, tier="hard", cell=cell, env_kwargs={},
                           upper_bound=False)

    rates = {("door", "a"): 0, ("door", "b"): 10, ("crowd", "a"): 10, ("crowd", "b"): 10, ("crowd", "c"): 10,
             ("crowd", "d"): 6}
    (hard,) = benchmark.tier_aggregates([record(sc, c, k) for (sc, c), k in rates.items()])
    assert hard["success"] == pytest.approx(0.5 * (0.0 + 1.0) / 2 + 0.5 * (1.0 + 1.0 + 1.0 + 0.6) / 4)
    assert hard["success_mean"] == pytest.approx(4.6 / 6)
    lo, hi = hard["success_ci95"]
    assert lo < hard["success"] < hi  # one run: the interval is the episodes' noise (the 0.6 cell's)
    # Five runs of the same record: the IQM over runs appears, and equals the IQM of the 30 rates.
    (five,) = benchmark.tier_aggregates([record(sc, c, k, run=f"run_{i}") for i in range(5)
                                         for (sc, c), k in rates.items()])
    assert five["runs"] == 5 and five["iqm_runs"] == pytest.approx(
        scipy.stats.trim_mean([k / 10 for _ in range(5) for k in rates.values()], 0.25))
    assert five["success"] == pytest.approx(hard["success"])


# ---------------------------------------------------------------- the oracle is labelled, never a baseline
def test_the_oracle_is_marked_upper_bound_and_not_run_by_default():
    assert report.policy_label("oracle") == "oracle (upper bound)" and report.policy_label(FAST) == FAST
    assert report.policy_label("agent:mine") == "agent:mine"
    script = load_script("eval_planner")
    assert "oracle" not in script.parse_settings([]).policies  # the quick default: every policy but the oracle
    assert script.parse_settings(["--policy", "oracle"]).policies == ("oracle",)
    record = cell_record("FootstepDoor-v0", "door", "oracle", {}, episodes(1, 1))
    assert "| oracle (upper bound) |" in squash(report.markdown_table([record]))


def test_the_config_hash_is_of_the_content_not_the_bytes(tmp_path, monkeypatch):
    """A comment or spacing in an env config keeps the benchmark's config hash; a value or a key order changes it."""
    import shutil

    from footstep_gym.config import config_dir

    folder = tmp_path / "configs"
    shutil.copytree(config_dir(), folder)
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(folder))
    release = benchmark.env_configs_sha256()
    door = folder / "scenarios" / "door.yaml"
    text = door.read_text(encoding="utf-8")
    door.write_text("# a comment of one's own\n" + text.replace(": ", ":   ", 3), encoding="utf-8")
    assert benchmark.env_configs_sha256() == release
    lines = text.splitlines(keepends=True)
    first, second = [i for i, line in enumerate(lines) if line[:1].isalpha() and ":" in line][:2]
    swapped = lines.copy()
    swapped[first], swapped[second] = lines[second], lines[first]
    door.write_text("".join(swapped), encoding="utf-8")
    assert benchmark.env_configs_sha256() != release  # the order of the keys is the order of the draws
    door.write_text(text.replace("drum_segments: 8", "drum_segments: 6"), encoding="utf-8")
    assert "drum_segments: 8" in text and benchmark.env_configs_sha256() != release
