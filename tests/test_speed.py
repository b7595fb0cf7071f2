"""baselines/speed.py runs end to end (tiny ``--smoke`` mode) and writes a well-formed JSON; its code,
``baselines/speedlib``, is tested here in-process (the planners timed through the evaluation runner).

No timing thresholds here: the speed targets live in the speed run's own PASS/MISS table.
These tests check structure, keys and the sanity of the values (positive, finite, ordered
spreads, consistent counts, two worker processes for the async vectoriser, ...), and the
PASS/MISS logic on made-up figures.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from speedlib import fmt, memory_use, timing
from speedlib.env_rates import BEFORE_ID
from speedlib.settings import MODES, SECTIONS
from speedlib.targets import LIPM_TARGET_PER_S, evaluate_targets

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "baselines" / "speed.py"

FOOTSTEP_ENVS = ("FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0")
REFERENCE_ENVS = ("CartPole-v1", "Pendulum-v1", "BipedalWalker-v3")
PLANNERS = ("period-aware", "fixed-period", "pso-only")
COMMANDS = ("random", "near_nominal", "planner")
SMOKE = MODES["smoke"]


def _positive_finite(x, what: str) -> None:
    assert isinstance(x, (int, float)) and not isinstance(x, bool), f"{what}: {x!r} is not a number"
    assert math.isfinite(x) and x > 0, f"{what}: {x!r} is not positive and finite"


def _check_spread(s: dict, what: str, keys=("median", "q1", "q3", "min", "max")) -> None:
    for k in keys:
        _positive_finite(s[k], f"{what}.{k}")
    assert s["n"] >= 1
    if "q1" in s:
        assert s["min"] <= s["q1"] <= s["median"] <= s["q3"] <= s["max"], f"{what}: spread out of order {s}"


def _reject_constant(name: str):
    raise ValueError(f"non-standard JSON constant {name}")


@pytest.fixture(scope="module")
def before_checkout(tmp_path_factory):
    """A copy of this checkout's package and configs: what ``--compare-with`` times as "before"."""
    import shutil

    root = tmp_path_factory.mktemp("before")
    shutil.copytree(ROOT / "footstep_gym", root / "footstep_gym", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "configs", root / "configs")
    return root


@pytest.fixture(scope="module")
def smoke(tmp_path_factory, before_checkout):
    out = tmp_path_factory.mktemp("speed")
    proc = subprocess.run([sys.executable, str(SCRIPT), "--smoke", "--out", str(out), "--compare-with",
                           str(before_checkout)], capture_output=True, text=True, timeout=600, cwd=str(ROOT))
    assert proc.returncode == 0, proc.stderr[-3000:]
    # Strict JSON: NaN / Infinity must have become null.
    data = json.loads((out / "speed.json").read_text(), parse_constant=_reject_constant)
    assert (out / "speed.md").read_text().strip() == proc.stdout.strip()
    return data, proc.stdout, proc.stderr


def _live(cell: dict, what: str) -> bool:
    """Whether a cell was measured; a skipped cell must say why."""
    if "skipped" in cell:
        assert isinstance(cell["skipped"], str) and cell["skipped"], what
        return False
    return True


# ------------------------------------------------------------------ the smoke run
def test_machine_meta_and_progress(smoke):
    data, _, stderr = smoke
    meta = data["meta"]
    assert meta["mode"] == "smoke"
    assert meta["sections"] == list(SECTIONS)
    m = meta["machine"]
    for key in ("cpu", "cores_logical", "cores_usable", "python", "numpy", "pymunk", "gymnasium"):
        assert m[key], key
    _positive_finite(meta["duration_s"], "duration_s")
    _positive_finite(meta["nominal_period_s"], "nominal_period_s")
    assert meta["torch_imported"] is False, "the benchmarked code paths must not import torch"
    for section in ("planners ...", "lipm ...", "env steps ...", "memory ...", "ppo ...", "wrote "):
        assert section in stderr, f"no progress line {section!r}"


def test_env_steps_per_second(smoke):
    data, _, _ = smoke
    envs = data["env_steps"]
    assert set(envs) == set(FOOTSTEP_ENVS) | set(REFERENCE_ENVS) | {BEFORE_ID}
    for env_id in FOOTSTEP_ENVS + REFERENCE_ENVS:
        commands = COMMANDS if env_id in FOOTSTEP_ENVS else ("random",)
        assert set(envs[env_id]) == set(commands)
        for c in commands:
            assert set(envs[env_id][c]) == {"single", "sync", "async"}
            for mode in ("single", "sync", "async"):
                cell, what = envs[env_id][c][mode], f"{env_id}.{c}.{mode}"
                if env_id in FOOTSTEP_ENVS and c != "planner":
                    assert "skipped" not in cell, f"{what}: {cell.get('skipped')}"
                if not _live(cell, what):  # reference env not installed, or planners unavailable
                    continue
                _check_spread(cell["steps_per_s"], what)
                assert cell["steps_per_s"]["median"] < 1e8, f"{what}: implausible rate"
                assert len(cell["rates"]) == cell["steps_per_s"]["n"]
                assert cell["steps_per_s"]["n"] == (SMOKE.repetitions if mode == "single"
                                                    else SMOKE.vec_repetitions)
                _positive_finite(cell["steps"], f"{what}.steps")
                assert cell["mean_episode_steps"] is None or cell["mean_episode_steps"] >= 1.0
                if mode != "single":
                    assert cell["num_envs"] == 2
                    assert cell["autoreset_steps"] >= 0
    for env_id in ("FootstepCrossing-v0", "CartPole-v1"):  # always installed
        assert "skipped" not in envs[env_id]["random"]["single"]


def test_make_vec_uses_two_workers_sync_and_async(smoke):
    data, stdout, _ = smoke
    seen = set()
    for env_id, by_cmd in data["env_steps"].items():
        if env_id == BEFORE_ID:  # single-process only
            continue
        for c, cell in by_cmd.items():
            for mode in ("sync", "async"):
                if "skipped" in cell[mode]:
                    continue
                v = cell[mode]["vector"]
                assert v["num_envs"] == 2
                if mode == "async":
                    assert v["class"] == "AsyncVectorEnv", (env_id, c)
                    assert v["worker_processes"] == 2 and v["workers_alive"] == 2, (env_id, c, v)
                    assert v["worker_pids_distinct_from_parent"] is True
                else:
                    assert v["class"] == "SyncVectorEnv", (env_id, c)
                    assert v["worker_processes"] == 0
                seen.add(mode)
    assert seen == {"sync", "async"}
    assert "AsyncVectorEnv" in stdout and "SyncVectorEnv" in stdout


def test_planner_replay_and_ratios(smoke):
    data, _, _ = smoke
    envs = data["env_steps"]
    for env_id in FOOTSTEP_ENVS:
        single = envs[env_id]["planner"]["single"]
        if _live(single, env_id):
            assert isinstance(single["replay_matches_recording"], bool)
    bw, ratios = envs["BipedalWalker-v3"]["random"]["single"], data["ratios"]
    for c in COMMANDS:
        key, door = f"FootstepDoor_{c}/BipedalWalker", envs["FootstepDoor-v0"][c]["single"]
        assert key in ratios
        if "rates" in bw and "rates" in door:
            _check_spread(ratios[key], key)
            # Paired per interleaved round, then the median.
            paired = sorted(d / b for d, b in zip(door["rates"], bw["rates"]))
            assert ratios[key]["median"] == pytest.approx(timing.summary(paired)["median"])
        else:
            assert ratios[key] is None


def test_lipm_checks_per_second(smoke):
    data, _, _ = smoke
    lipm = data["lipm"]
    _check_spread(lipm["check_step"]["commands_per_s"], "check_step")
    assert set(lipm["check_steps"]) == {"1", "32", "1024"}
    for batch in ("1", "32", "1024"):
        cell = lipm["check_steps"][batch]
        assert cell["batch"] == int(batch)
        _check_spread(cell["commands_per_s"], f"check_steps[{batch}]")
    c = lipm["commands"]
    assert c["pool"] >= 1024
    assert 0.0 < c["feasible_fraction"] < 1.0  # the timed commands mix feasible and infeasible ones
    assert c["scalar_batched_agreement"] >= 0.99


def test_planners(smoke):
    data, _, _ = smoke
    planners = data["planners"]
    if "skipped" in planners:
        pytest.skip(f"planners unavailable: {planners['skipped']}")
    assert set(planners) == set(FOOTSTEP_ENVS)
    for env_id in FOOTSTEP_ENVS:
        assert set(planners[env_id]) == set(PLANNERS)
        for name in PLANNERS:
            r, what = planners[env_id][name], f"{env_id}.{name}"
            assert "skipped" not in r, f"{what}: {r.get('skipped')}"
            _check_spread(r["plan_time_s"], f"{what}.plan_time_s", keys=("median", "p95", "p99", "max"))
            p = r["plan_time_s"]
            assert p["median"] <= p["p95"] <= p["p99"] <= p["max"]
            assert p["n"] == r["footsteps"] == sum(e["steps"] for e in r["per_episode"])
            _check_spread(r["sensing_time_s"], f"{what}.sensing_time_s", keys=("median", "p95", "p99", "max"))
            assert r["episodes"] == len(r["per_episode"]) >= 2
            assert r["successes"] == sum(e["success"] for e in r["per_episode"])
            assert r["success_rate"] == pytest.approx(r["successes"] / r["episodes"])
            assert 0.0 <= r["pso_ran_fraction"] <= 1.0
            # The same seeds for every planner.
            assert r["seeds"] == planners[env_id]["period-aware"]["seeds"] == [e["seed"] for e in r["per_episode"]]
            assert all(e["steps"] <= SMOKE.planner_max_steps for e in r["per_episode"])


def test_memory(smoke):
    data, _, _ = smoke
    mem = data["memory"]
    assert set(mem["env"]) == set(FOOTSTEP_ENVS)
    for env_id in FOOTSTEP_ENVS:
        rss, tm = mem["env"][env_id]["rss"], mem["env"][env_id]["tracemalloc"]
        assert "skipped" not in rss and "skipped" not in tm, (rss, tm)
        assert rss["steps"] == tm["steps"] == SMOKE.memory_steps
        _positive_finite(tm["tracemalloc_peak_bytes"], f"{env_id} tracemalloc peak")
        assert tm["tracemalloc_peak_bytes"] >= tm["tracemalloc_current_bytes"] >= 0
        assert tm["tracemalloc_peak_bytes"] < 1 << 30
        _positive_finite(rss["max_rss_bytes"], f"{env_id} max rss")
        if rss["peak_rss_bytes"] is not None:  # /proc available
            assert isinstance(rss["rss_delta_bytes"], int)
            assert rss["peak_rss_bytes"] >= rss["rss_before_bytes"]
            assert 0 <= rss["peak_rss_delta_bytes"] < 1 << 30
            assert rss["peak_rss_method"]
        assert rss["torch_imported"] is False and tm["torch_imported"] is False
        assert rss["process"] == "fresh interpreter"  # RSS growth is only meaningful there
        assert tm["process"]
    if "skipped" in data["planners"]:
        return
    by_env = mem["planner"]["period-aware"]
    assert set(by_env) == set(FOOTSTEP_ENVS)
    for env_id, r in by_env.items():
        assert r["env_id"] == env_id
        tm, rss = r["tracemalloc"], r["rss"]
        assert "skipped" not in tm and "skipped" not in rss, (tm, rss)
        _positive_finite(tm["tracemalloc_peak_bytes"], f"planner on {env_id}: tracemalloc peak")
        assert 0 <= tm["tracemalloc_peak_per_act_bytes"] <= tm["tracemalloc_peak_bytes"]
        assert 1 <= rss["steps"] <= SMOKE.memory_acts


def test_targets_and_table(smoke):
    data, stdout, _ = smoke
    targets = data["targets"]
    assert {t["status"] for t in targets} <= {"PASS", "MISS", "N/A"}
    names = [t["target"] for t in targets]
    assert sum("BipedalWalker" in n for n in names) == len(COMMANDS)
    assert "FootstepDoor-v0 steps/s >= 2x BipedalWalker-v3 (1 process, near-nominal commands)" in names
    assert "LIPM check_steps, batch 1024" in names
    if "skipped" not in data["planners"]:
        for env_id in FOOTSTEP_ENVS:
            for prefix in ("period-aware median plan time", "period-aware p99 plan time", "period-aware vs pso-only"):
                assert f"{prefix}, {env_id}" in names
    # Each target is printed with its measured value and status.
    assert "## Targets" in stdout and "| env | commands |" in stdout
    for t in targets:
        assert f"| {t['target']} | {t['threshold']} | {t['measured']} | {t['status']} |" in stdout
    lipm_t = next(t for t in targets if t["target"] == "LIPM check_steps, batch 1024")
    v = data["lipm"]["check_steps"]["1024"]["commands_per_s"]["median"]
    assert lipm_t["value"] == pytest.approx(v)
    assert lipm_t["status"] == ("PASS" if v >= LIPM_TARGET_PER_S else "MISS")
    for section in ("## Env steps per second", "## LIPM feasibility checks", "## Planning time per footstep",
                    "## Peak memory", "## PPO training throughput"):
        assert section in stdout


def test_compare_with_times_the_other_checkout_in_the_same_rounds(smoke, before_checkout):
    data, stdout, _ = smoke
    cell = data["env_steps"][BEFORE_ID]["near_nominal"]["single"]
    assert Path(cell["footstep_gym"]) == before_checkout / "footstep_gym"  # imported from there, not from here
    assert data["meta"]["compare_with"] == str(before_checkout)
    now = data["env_steps"]["FootstepDoor-v0"]["near_nominal"]["single"]
    assert len(cell["rates"]) == len(now["rates"]) == SMOKE.repetitions
    _check_spread(cell["steps_per_s"], "before")
    paired = [a / b for a, b in zip(now["rates"], cell["rates"])]
    assert data["ratios"]["FootstepDoor_near_nominal/before"]["median"] == pytest.approx(
        timing.summary(paired)["median"])
    assert f"| {BEFORE_ID} | near_nominal |" in stdout


def test_ppo_throughput_beside_cartpole(smoke):
    data, stdout, _ = smoke
    ppo = data["ppo"]
    assert "skipped" not in ppo, ppo.get("skipped")
    assert set(ppo["cells"]) == {"FootstepDoor-v0", "CartPole-v1"}
    assert ppo["hyperparameters"]["CartPole-v1"] == "FootstepDoor-v0"
    for env_id, by_n in ppo["cells"].items():
        assert set(by_n) == {"1", "2"}
        for n, cell in by_n.items():
            assert len(cell["rates"]) == SMOKE.ppo_rounds
            _check_spread(cell["steps_per_s"], f"ppo {env_id} {n}")
    for n in ("1", "2"):
        door, pole = ppo["cells"]["FootstepDoor-v0"][n]["rates"], ppo["cells"]["CartPole-v1"][n]["rates"]
        assert ppo["ratios"][n]["median"] == pytest.approx(timing.summary(
            [a / b for a, b in zip(door, pole)])["median"])
    assert "FootstepDoor-v0 / CartPole-v1 (paired per round)" in stdout


def test_tiers_section_one_cell_per_scene_and_tier(smoke):
    """The tiers section in the smoke run (speedlib.tier_rates; tests/test_speed_tiers.py tests it in depth):
    smoke keeps the first cell of every scene and tier."""
    from footstep_gym import tiers as tier_config

    data, stdout, stderr = smoke
    tiers = data["tiers"]
    assert "tiers ..." in stderr
    if "skipped" in tiers:  # the planners cannot be imported here
        return
    for scene in ("door", "crossing", "crowd"):
        assert list(tiers["scenes"][scene]) == tier_config.tier_names()
        for tier, agg in tiers["scenes"][scene].items():
            assert len(agg["cells"]) == 1 and len(agg["rates"]) == SMOKE.repetitions, (scene, tier)
            assert f"{scene}/{tier}/{agg['cells'][0]}" in tiers["cells"]
    assert "## Tiers: env steps per second and planning time per tier" in stdout
    assert sum("structure tier env steps/s" in t["target"] for t in data["targets"]) == 3


# ------------------------------------------------------------------ in-process, no timing
def _plan(median: float, p99: float, successes: int, episodes: int = 4) -> dict:
    return {"plan_time_s": {"median": median, "p95": p99, "p99": p99, "max": p99, "mean": median, "n": 50},
            "successes": successes, "episodes": episodes, "success_rate": successes / episodes}


def test_evaluate_targets_pass_miss_logic():
    T = 0.8  # nominal period: 8 ms median and 40 ms p99 limits
    res = {
        "env_steps": {"FootstepDoor-v0": {c: {"single": {"rates": [2.0, 3.0, 4.0]}} for c in COMMANDS},
                      "BipedalWalker-v3": {"random": {"single": {"rates": [1.0, 4.0, 2.0]}}}},
        "lipm": {"check_steps": {"1024": {"commands_per_s": {"median": 999_999.0}}}},
        "planners": {
            "A": {"period-aware": _plan(0.005, 0.030, 3), "pso-only": _plan(0.060, 0.2, 3)},  # all PASS
            "B": {"period-aware": _plan(0.009, 0.041, 2), "pso-only": _plan(0.060, 0.2, 3)},  # all MISS
            "C": {"period-aware": {"skipped": "boom"}, "pso-only": _plan(0.060, 0.2, 3)},
            "D": {"period-aware": _plan(0.001, 0.002, 1), "pso-only": {"skipped": "boom"}},
        },
    }
    targets, ratios = evaluate_targets(res, T)
    status = {t["target"]: t["status"] for t in targets}
    # Paired per round: 2/1, 3/4, 4/2 -> median 2.
    assert ratios["FootstepDoor_random/BipedalWalker"]["median"] == pytest.approx(2.0)
    assert status["FootstepDoor-v0 steps/s >= 1x BipedalWalker-v3 (1 process, random commands)"] == "PASS"
    # The steady walk's target is 2x: a median of exactly 2 passes, 1.9 misses.
    assert status["FootstepDoor-v0 steps/s >= 2x BipedalWalker-v3 (1 process, near-nominal commands)"] == "PASS"
    res["env_steps"]["FootstepDoor-v0"]["near_nominal"]["single"]["rates"] = [1.9, 3.0, 3.8]
    status = {t["target"]: t["status"] for t in evaluate_targets(res, T)[0]}
    assert status["FootstepDoor-v0 steps/s >= 2x BipedalWalker-v3 (1 process, near-nominal commands)"] == "MISS"
    assert status["FootstepDoor-v0 steps/s >= 1x BipedalWalker-v3 (1 process, planner commands)"] == "PASS"
    assert status["LIPM check_steps, batch 1024"] == "MISS"
    assert status["period-aware median plan time, A"] == "PASS"
    assert status["period-aware p99 plan time, A"] == "PASS"
    assert status["period-aware vs pso-only, A"] == "PASS"  # 12x, 3/4 vs 3/4
    assert status["period-aware median plan time, B"] == "MISS"
    assert status["period-aware p99 plan time, B"] == "MISS"
    assert status["period-aware vs pso-only, B"] == "MISS"  # 6.7x and lower success
    assert status["period-aware planning on C"] == "MISS"
    assert status["period-aware vs pso-only, D"] == "N/A"
    # With each episode's times on both sides (the same seeds), the speed-up carries a bootstrap interval.
    for name, scale in (("period-aware", 1.0), ("pso-only", 12.0)):
        res["planners"]["A"][name].update(seeds=[1, 2, 3], plan_time_by_episode_s=[
            [scale * 0.005 * f for f in (0.8, 1.0, 1.3)], [scale * 0.005], [scale * 0.005 * f for f in (0.9, 1.1)]])
    targets, ratios = evaluate_targets(res, T)
    measured = {t["target"]: t["measured"] for t in targets}
    assert "95% CI 12.0–12.0" in measured["period-aware vs pso-only, A"]
    assert ratios["pso-only/period-aware median plan time, A, 95% CI"] == pytest.approx([12.0, 12.0])
    # Without BipedalWalker (not installed) the ratio is N/A, never a failure.
    res["env_steps"]["BipedalWalker-v3"] = {"random": {"single": {"skipped": "box2d missing"}}}
    targets, ratios = evaluate_targets(res, T)
    assert ratios["FootstepDoor_random/BipedalWalker"] is None
    assert {t["status"] for t in targets if "BipedalWalker" in t["target"]} == {"N/A"}


def test_median_ratio_interval_resamples_episodes_in_pairs():
    import numpy as np

    rng = np.random.default_rng(1)
    fast = [rng.uniform(1.0, 2.0, n) for n in (30, 25, 40, 35, 28)]
    slow = [10.0 * ep[: max(len(ep) // 2, 1)] for ep in fast]  # exactly 10x every footstep kept
    assert timing.median_ratio_interval([10.0 * ep for ep in fast], fast, rng) == pytest.approx((10.0, 10.0))
    lo, hi = timing.median_ratio_interval(slow, fast, np.random.default_rng(2), n_boot=500)
    point = np.median(np.concatenate(slow)) / np.median(np.concatenate(fast))
    assert lo < point < hi and 8.0 < lo and hi < 12.5  # the footsteps kept differ, so the ratio spreads
    assert timing.median_ratio_interval(slow, fast, np.random.default_rng(2), n_boot=500) == (lo, hi)
    with pytest.raises(ValueError, match="same number"):
        timing.median_ratio_interval(slow, fast[:3], rng)


def test_stats_and_formatting():
    s = timing.summary([5.0, 1.0, 3.0, 2.0, 4.0])
    assert (s["median"], s["min"], s["max"], s["n"]) == (3.0, 1.0, 5.0, 5)
    assert s["q1"] == 2.0 and s["q3"] == 4.0
    assert math.isnan(timing.summary([])["median"])
    t = timing.tail_summary(list(range(1, 101)))
    assert t["median"] <= t["p95"] <= t["p99"] <= t["max"] == 100 and t["n"] == 100
    assert fmt.fmt_num(1_234_567) == "1.23M" and fmt.fmt_num(8467) == "8.47k"
    assert fmt.fmt_num(float("nan")) == "n/a"
    assert fmt.fmt_bytes(2048) == "2.0 KiB" and fmt.fmt_bytes(None) == "n/a"
    j = fmt.finite_json({"a": float("nan"), "b": [float("inf"), 1.5], 3: (1, 2)})
    assert j == {"a": None, "b": [None, 1.5], "3": [1, 2]}
    assert fmt.markdown_table(["x", "y"], [[1, 2]]) == "| x | y |\n|---|---|\n| 1 | 2 |"


def test_speedlib_lives_beside_the_scripts_and_shadows_no_package_module():
    """The speed tooling is not in the installed package (``tests/test_install.py`` checks the install), and none
    of its modules takes the name of a ``footstep_gym`` module (``lipm``, ``tiers``, ``stats``, ``planners``, ...)."""
    import speedlib

    import footstep_gym

    lib = Path(speedlib.__file__).resolve().parent
    assert lib == ROOT / "baselines" / "speedlib"
    package = Path(footstep_gym.__file__).resolve().parent
    ours = {p.stem for p in lib.glob("*.py")} - {"__init__"}
    theirs = {p.stem for p in package.rglob("*.py")} | {p.name for p in package.rglob("*") if p.is_dir()}
    assert {"env_rates", "lipm_rates", "planner_times", "tier_rates", "timing", "soak"} <= ours
    assert not ours & theirs, f"speedlib modules named as footstep_gym modules: {sorted(ours & theirs)}"


def test_call_fresh_returns_the_value_or_says_why():
    """The memory probes, the PPO child and the soak's env processes run through ``fresh.call_fresh``."""
    from speedlib.fresh import ChildFailed, call_fresh

    assert call_fresh(timing.summary, [1.0, 2.0, 3.0])["median"] == 2.0
    with pytest.raises(ChildFailed, match="ValueError: need the same number") as exc:
        call_fresh(timing.median_ratio_interval, [[1.0]], [], None, quiet=True)
    assert exc.value.status == 1


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs /proc")
def test_rss_peak_sees_a_transient_allocation():
    import numpy as np

    r = memory_use.RssPeak()
    base = r.sample()
    a = np.ones(64 << 20 >> 3)  # 64 MiB, touched (above any mmap threshold: fresh pages)
    del a
    r.sample()
    if r.hwm_reset:  # the kernel's peak, reset at construction, saw the buffer
        assert r.peak - base >= 48 << 20
    assert r.peak >= base
    r.close()


def test_help_mentions_quick_default_and_full():
    """The command line: quick is the default, --full the long mode, the two exclusive."""
    def run(*args):
        return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=120)

    out = run("--help")
    assert out.returncode == 0
    for option in ("--quick", "--full", "--out", "--seed", "--sections", "--compare-with"):
        assert option in out.stdout
    assert "the default" in out.stdout and "--smoke" not in out.stdout
    both = run("--quick", "--full")
    assert both.returncode == 2 and "not allowed with argument" in both.stderr
    assert "unknown section(s) ['moon']" in run("--sections", "env,moon").stderr


# ------------------------------------------------------------------ planners timed through the evaluation runner
def test_the_runner_hands_every_footstep_to_its_hook():
    """``run_episode(..., on_step=hook)``: one ActTiming per footstep, its act time the one ``plan_ms`` records;
    a true return cuts the episode there; the hook changes nothing of the episode."""
    from footstep_gym.evaluation.runner import Cell, Task, run_episode

    cell = Cell("FootstepDoor-v0", "door", "period-aware")
    seen = []
    full = run_episode(Task(0, cell, 3), warm=False, on_step=seen.append)
    assert [t.footstep for t in seen] == list(range(1, full.steps + 1))
    assert [1e3 * t.act_s for t in seen] == full.plan_ms
    assert all(t.sense_s > 0 and t.step_s > 0 for t in seen)
    assert (seen[-1].terminated or seen[-1].truncated) and not any(t.terminated or t.truncated for t in seen[:-1])
    assert {"time_period_search_ms", "pso_ran"} <= set(seen[0].last_info)
    assert [t.info["steps"] for t in seen] == list(range(1, full.steps + 1))
    again = run_episode(Task(0, cell, 3), warm=False)
    assert (again.outcome, again.steps, again.time, again.periods) == (full.outcome, full.steps, full.time,
                                                                       full.periods)
    cut = []
    short = run_episode(Task(0, cell, 3), warm=False, on_step=lambda t: cut.append(t) or t.footstep >= 2)
    assert len(cut) == 2 and short.steps == 2 and short.outcome == "timeout" and len(short.plan_ms) == 2


def test_planner_run_times_through_the_runner_and_records_its_commands():
    import gymnasium as gym
    import numpy as np

    from speedlib.planner_times import PlannerRun
    from footstep_gym.evaluation import runner

    # The speed run warms each planner up as the evaluation warms up a cell, with as many acts (quick and full).
    assert MODES["quick"].planner_warmup_steps == MODES["full"].planner_warmup_steps == runner.WARMUP_ACTS
    run = PlannerRun("fixed-period", "FootstepCrossing-v0", max_steps=None)
    run.warm_up(10_000, acts=2)
    assert not run.warm_up(10_000, acts=2)  # once per process and cell
    n = run.episode(1)
    r = run.result()
    assert r["footsteps"] == n == r["plan_time_s"]["n"] == len(r["plan_time_by_episode_s"][0])
    assert r["sensing_time_s"]["n"] == r["env_step_time_s"]["n"] == n
    assert r["episodes"] == 1 and r["per_episode"][0]["capped"] is False and r["seeds"] == [1]
    assert "period_search" in r["stage_time_s"]
    capped = PlannerRun("fixed-period", "FootstepCrossing-v0", max_steps=3)
    assert capped.episode(1) == 3 and capped.episodes[0]["capped"] is True
    # The recorded commands replay the episode (the env section times the env on them).
    seed, actions, termination = run.recorded[0]
    assert np.asarray(actions).shape == (n, 5)
    env = gym.make("FootstepCrossing-v0")
    env.reset(seed=seed)
    for a in actions:
        *_, info = env.step(a)
    assert info.get("termination") == termination == r["per_episode"][0]["termination"]
