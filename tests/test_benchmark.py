"""baselines/benchmark.py runs end to end (tiny ``--smoke`` mode) and writes a well-formed JSON.

No timing thresholds here: the speed targets live in the benchmark's own PASS/MISS table.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "baselines" / "benchmark.py"
FOOTSTEP_ENVS = ("FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0")
REFERENCE_ENVS = ("CartPole-v1", "Pendulum-v1", "BipedalWalker-v3")
PLANNERS = ("period-aware", "fixed-period", "pso-only")


def _positive_finite(x, what: str) -> None:
    assert isinstance(x, (int, float)) and not isinstance(x, bool), f"{what}: {x!r} is not a number"
    assert math.isfinite(x) and x > 0, f"{what}: {x!r} is not positive and finite"


def _check_spread(s: dict, what: str, keys=("median", "q1", "q3", "min", "max")) -> None:
    for k in keys:
        _positive_finite(s[k], f"{what}.{k}")
    assert s["n"] >= 1
    if "q1" in s:
        assert s["min"] <= s["q1"] <= s["median"] <= s["q3"] <= s["max"], f"{what}: spread out of order {s}"


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    proc = subprocess.run([sys.executable, str(SCRIPT), "--smoke", "--out", str(out)],
                          capture_output=True, text=True, timeout=300, cwd=str(ROOT))
    assert proc.returncode == 0, proc.stderr[-3000:]
    data = json.loads((out / "benchmark.json").read_text())
    return data, proc.stdout


def test_machine_and_meta(smoke):
    data, _ = smoke
    meta = data["meta"]
    assert meta["mode"] == "smoke"
    m = meta["machine"]
    for key in ("cpu", "cores_logical", "python", "numpy", "pymunk", "gymnasium"):
        assert m[key], key
    _positive_finite(meta["duration_s"], "duration_s")
    _positive_finite(meta["nominal_period_s"], "nominal_period_s")


def test_env_steps_per_second(smoke):
    data, _ = smoke
    envs = data["env_steps"]
    for env_id in FOOTSTEP_ENVS:
        for commands in ("random", "near_nominal", "planner"):
            for mode in ("single", "sync", "async"):
                cell = envs[env_id][commands][mode]
                if commands == "planner" and "skipped" in cell:
                    # Only when the planners are unavailable or fail; the reason is recorded.
                    assert "planner" in cell["skipped"] or "Error" in cell["skipped"]
                    continue
                assert "skipped" not in cell, f"{env_id} {commands} {mode}: {cell.get('skipped')}"
                _check_spread(cell["steps_per_s"], f"{env_id}.{commands}.{mode}")
                _positive_finite(cell["steps"], f"{env_id}.{commands}.{mode}.steps")
    for env_id in REFERENCE_ENVS:
        for mode in ("single", "sync", "async"):
            cell = envs[env_id]["random"][mode]
            if "skipped" in cell:  # the optional dependency (e.g. box2d) is not installed
                assert isinstance(cell["skipped"], str) and cell["skipped"]
                continue
            _check_spread(cell["steps_per_s"], f"{env_id}.random.{mode}")
    ratio = data["ratios"]["FootstepDoor_near_nominal/BipedalWalker"]
    if "skipped" not in envs["BipedalWalker-v3"]["random"]["single"]:
        _check_spread(ratio, "door/bipedal ratio")


def test_lipm_checks_per_second(smoke):
    data, _ = smoke
    lipm = data["lipm"]
    _check_spread(lipm["check_step"]["commands_per_s"], "check_step")
    for batch in ("1", "32", "1024"):
        _check_spread(lipm["check_steps"][batch]["commands_per_s"], f"check_steps[{batch}]")


def test_planners(smoke):
    data, _ = smoke
    planners = data["planners"]
    if "skipped" in planners:
        pytest.skip(f"planners unavailable: {planners['skipped']}")
    for env_id in FOOTSTEP_ENVS:
        for name in PLANNERS:
            r = planners[env_id][name]
            assert "skipped" not in r, f"{env_id} {name}: {r.get('skipped')}"
            _check_spread(r["plan_time_s"], f"{env_id}.{name}.plan_time_s", keys=("median", "p95", "p99", "max"))
            assert r["plan_time_s"]["median"] <= r["plan_time_s"]["p95"] <= r["plan_time_s"]["p99"]
            assert r["episodes"] >= 1 and r["footsteps"] >= 1
            assert 0.0 <= r["success_rate"] <= 1.0
            assert r["seeds"] == planners[env_id]["period-aware"]["seeds"]  # the same seeds for every planner


def test_memory(smoke):
    data, _ = smoke
    mem = data["memory"]
    for env_id in FOOTSTEP_ENVS:
        r = mem["env"][env_id]
        _positive_finite(r["tracemalloc"]["tracemalloc_peak_bytes"], f"{env_id} tracemalloc peak")
        _positive_finite(r["rss"]["max_rss_bytes"], f"{env_id} max rss")
        assert isinstance(r["rss"]["rss_delta_bytes"], int)
    pa = mem["planner"]["period-aware"]
    if "skipped" not in pa["tracemalloc"]:
        _positive_finite(pa["tracemalloc"]["tracemalloc_peak_bytes"], "planner tracemalloc peak")


def test_targets_and_table(smoke):
    data, stdout = smoke
    statuses = {t["status"] for t in data["targets"]}
    assert statuses <= {"PASS", "MISS", "N/A"}
    names = " ".join(t["target"] for t in data["targets"])
    assert "BipedalWalker" in names and "batch 1024" in names
    assert "| env | commands |" in stdout and "## Targets" in stdout
    assert "PASS" in stdout or "MISS" in stdout
