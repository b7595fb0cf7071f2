"""footstep_gym.evaluation and baselines/eval_planner.py: statistics, recording, figures and tables, the CLI.

The CLI runs in a subprocess exactly as a user runs it. The in-process tests drive the
episode runner with a stand-in policy (walk straight at the nominal period), so they
check the evaluation machinery independently of the planners' quality.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from footstep_gym.evaluation import figures as eval_report
from footstep_gym.evaluation import profiles
from footstep_gym.evaluation.runner import Cell, Task, planner_notes, run_episode
from footstep_gym.evaluation.records import CellRecord, cell_record
from footstep_gym.evaluation.splits import split_seeds
from footstep_gym.evaluation.stats import OUTCOMES, TIMING_FIELDS, EpisodeResult, wilson_interval
from script_helpers import load_script

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "baselines" / "eval_planner.py"
FIRST_SEED = split_seeds("validation", 1)[0]  # configs/eval.yaml: the validation split's first seed (the default)

FASTEST_POLICY = "fixed-period"  # no period search; the quickest of the three per footstep
REQUIRED_KEYS = {
    "env": str, "policy": str, "params": dict, "episodes": int, "success_rate": float, "success_ci95": list,
    "collision_rate": float, "fall_rate": float, "timeout_rate": float, "mean_steps": (float, type(None)),
    "mean_path_length": (float, type(None)), "mean_time": (float, type(None)), "mean_steps_all": float,
    "mean_path_length_all": float, "mean_time_all": float, "plan_ms_median": float, "plan_ms_p95": float,
    "plan_ms_p99": float, "seeds": list,
}
RATES = ("success_rate", "collision_rate", "fall_rate", "timeout_rate")


def run_cli(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=REPO, capture_output=True, text=True,
                          timeout=timeout)


# ---------------------------------------------------------------- stand-in policy
class StraightAhead:
    """Walks straight at the longest stride and the nominal period; reports a fake pre-PSO command."""

    def __init__(self, robot, seed=None):
        self.command = robot.nominal_command.copy()
        self.command[0] = 0.07
        self.last_info = {}

    def reset(self, seed=None):
        self.last_info = {}

    def act(self, observation, snapshot):
        pre = self.command.copy()
        pre[0] = 0.08
        self.last_info = {"command_pre_pso": pre, "pso_ran": True}
        return self.command.copy()


def stand_in(cell, robot, seed):
    return StraightAhead(robot, seed)


@pytest.fixture(scope="module")
def stand_in_traces():
    """One recorded stand-in episode per env (door at 8 deg/s)."""
    cells = [Cell("FootstepDoor-v0", "door", "straight", (("door_speed", 8.0),)),
             Cell("FootstepCrossing-v0", "crossing", "straight"), Cell("FootstepCrowd-v0", "crowd", "straight")]
    return [run_episode(Task(i, c, 3, record=True), factory=stand_in) for i, c in enumerate(cells)]


# ---------------------------------------------------------------- statistics
def wilson_by_roots(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson's interval as the roots of (p_hat - p)^2 = z^2 p (1 - p) / n (independent of the closed form)."""
    ph = k / n
    a, b, c = 1 + z * z / n, -(2 * ph + z * z / n), ph * ph
    roots = np.sort(np.roots([a, b, c]).real)
    return float(roots[0]), float(roots[1])


@pytest.mark.parametrize("k,n", [(0, 1), (1, 1), (0, 3), (2, 3), (10, 20), (19, 20), (20, 20), (7, 50)])
def test_wilson_interval_matches_the_quadratic_and_contains_the_rate(k, n):
    lo, hi = wilson_interval(k, n)
    rlo, rhi = wilson_by_roots(k, n)
    assert lo == pytest.approx(max(rlo, 0.0), abs=1e-9) and hi == pytest.approx(min(rhi, 1.0), abs=1e-9)
    assert 0.0 <= lo <= k / n <= hi <= 1.0


def test_wilson_interval_known_value_and_bad_input():
    assert wilson_interval(10, 20) == pytest.approx((0.2993, 0.7007), abs=1e-4)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(3, 2)


def _episode(seed, outcome, steps, t, path):
    return EpisodeResult(cell_index=0, seed=seed, outcome=outcome, steps=steps, time=t, path_length=path,
                         com_path_length=path + 0.1, plan_ms=[1.0, 2.0, 3.0], periods=[0.8, 0.4],
                         pso_ran=[False, True])


def test_cell_record_rates_and_means_over_successes():
    eps = [_episode(2, "goal", 20, 10.0, 2.0), _episode(0, "collision", 5, 3.0, 0.5),
           _episode(1, "goal", 30, 14.0, 3.0), _episode(3, "timeout", 200, 60.0, 1.0)]
    r = cell_record("FootstepDoor-v0", "door", "p", {"door_speed": 14.0}, eps)
    assert r.seeds == [0, 1, 2, 3] and r.outcomes == ["collision", "goal", "goal", "timeout"]
    assert (r.success_rate, r.collision_rate, r.fall_rate, r.timeout_rate) == (0.5, 0.25, 0.0, 0.25)
    assert r.mean_steps == 25 and r.mean_time == 12.0 and r.mean_path_length == 2.5
    assert r.mean_steps_all == pytest.approx(63.75) and r.mean_path_length_all == pytest.approx(1.625)
    assert r.success_ci95 == list(wilson_interval(2, 4))
    assert r.pso_step_rate == 0.5 and r.mean_period == pytest.approx(0.6)
    assert r.plan_ms_median == 2.0 and r.plan_ms_max == 3.0
    none = cell_record("FootstepDoor-v0", "door", "p", {}, [_episode(0, "fall", 3, 1.0, 0.1)])
    assert none.mean_steps is None and none.mean_steps_all == 3
    with pytest.raises(ValueError, match="outcome"):
        cell_record("FootstepDoor-v0", "door", "p", {}, [_episode(0, "exploded", 3, 1.0, 0.1)])


# ---------------------------------------------------------------- recording (stand-in policy)
def test_recorded_trace_is_consistent_with_the_result(stand_in_traces):
    for res in stand_in_traces:
        tr = res.trace
        assert res.outcome in OUTCOMES and res.steps == len(tr.commands) == len(res.plan_ms) > 0
        assert len(tr.times) == len(tr.com) == len(tr.centre) == len(tr.poses) == res.steps + 1
        assert tr.poses.shape[1] == len(tr.shapes)
        assert np.all(np.diff(tr.times) >= 0) and tr.times[-1] == pytest.approx(res.time)
        assert res.path_length == pytest.approx(np.linalg.norm(np.diff(tr.centre, axis=0), axis=1).sum())
        np.testing.assert_allclose(tr.commands[:, 0], 0.07)
        np.testing.assert_allclose(tr.pre_pso[:, 0], 0.08)
        assert res.periods == pytest.approx([0.8] * res.steps)
        # One footprint per completed step, plus the two initial feet.
        completed = res.steps - (res.outcome in ("collision", "fall"))
        assert len(tr.footprints) == 2 + completed


def test_same_seed_same_episode():
    cell = Cell("FootstepCrowd-v0", "crowd", "straight")
    a, b = (run_episode(Task(0, cell, 5, record=True), factory=stand_in) for _ in range(2))
    assert (a.outcome, a.steps, a.time, a.path_length) == (b.outcome, b.steps, b.time, b.path_length)
    np.testing.assert_array_equal(a.trace.poses, b.trace.poses)


def test_planner_notes_reads_last_info():
    class P:
        last_info = {"command_pre_pso": [0.01, 0.08, 0.0, 0.6, 0.2], "pso_ran": False}

    pre, ran = planner_notes(P().last_info)
    assert pre.shape == (5,) and ran is False
    assert planner_notes(None) == (None, None) and planner_notes({}) == (None, None)


def test_command_table_format(stand_in_traces):
    text = eval_report.command_table(stand_in_traces[0].trace)
    lines = text.splitlines()
    header = next(line for line in lines if line.startswith("| Steps"))
    assert header == "| Steps | S (cm) | L (cm) | θ (rad) | T_DS (s) | T_SS (s) |"
    rows = [line for line in lines if line.startswith("| ") and not line.startswith("| Steps")]
    assert len(rows) == stand_in_traces[0].steps
    # S was 8 cm before the (fake) PSO and 7 cm after: parentheses, bold row; T_SS unchanged.
    assert rows[0].startswith("| **1** | (8.00) **7.00** | ") and rows[0].endswith(" | 0.00 | 0.20 | 0.60 |")


def test_figure_draws_every_env(stand_in_traces, tmp_path):
    for res in stand_in_traces:
        path = eval_report.episode_figure([res.trace, res.trace], tmp_path / f"{res.trace.scenario}.png", "test")
        img = matplotlib.image.imread(path)
        assert img.shape[0] > 300 and img.shape[1] > 600 and img[..., :3].std() > 0.05


# ---------------------------------------------------------------- the CLI
def check_record(r: dict) -> None:
    for key, types in REQUIRED_KEYS.items():
        assert key in r, f"missing {key}"
        assert isinstance(r[key], types if isinstance(types, tuple) else (types,)) or (
            types is float and isinstance(r[key], int)), f"{key}={r[key]!r}"
    assert r["episodes"] == len(r["seeds"]) * len(r.get("runs") or [None]) >= 1  # an agent pools its runs
    for k in RATES:
        assert 0.0 <= r[k] <= 1.0
    assert sum(r[k] for k in RATES) == pytest.approx(1.0)
    lo, hi = r["success_ci95"]
    assert 0.0 <= lo <= r["success_rate"] <= hi <= 1.0
    assert 0 < r["plan_ms_median"] <= r["plan_ms_p95"] <= r["plan_ms_p99"]
    assert r["mean_steps_all"] >= 1 and r["mean_path_length_all"] >= 0 and r["mean_time_all"] >= 0
    if r["success_rate"] > 0:
        assert r["mean_steps"] >= 1 and r["mean_path_length"] > 0 and r["mean_time"] > 0
    else:
        assert r["mean_steps"] is None


def test_cli_one_episode_per_env(tmp_path):
    out = tmp_path / "eval"
    proc = run_cli("--episodes", "1", "--env", "door", "--env", "FootstepCrossing-v0", "--env", "crowd",
                   "--policy", FASTEST_POLICY, "--out", str(out), "--workers", "1")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("| env ") and FASTEST_POLICY in proc.stdout

    records = json.loads((out / "results.json").read_text())
    assert [(r["env"], r["params"]) for r in records] == [
        ("FootstepDoor-v0", {"door_speed": 17.0}), ("FootstepCrossing-v0", {}), ("FootstepCrowd-v0", {})]
    for r in records:
        check_record(r)
        assert r["policy"] == FASTEST_POLICY and r["seeds"] == [FIRST_SEED]

    with (out / "results.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(records)
    for row, r in zip(rows, records):
        assert (row["env"], row["policy"], float(row["success_rate"])) == (r["env"], r["policy"], r["success_rate"])
        assert float(row["success_ci95_lo"]) == pytest.approx(r["success_ci95"][0])
        assert row["param_door_speed"] == ("17.0" if r["params"] else "")

    for name in ("door_17", "crossing", "crowd"):
        png = out / "figures" / f"{name}.png"
        assert png.exists() and png.stat().st_size > 20_000, name
    tables = sorted(p.name for p in (out / "tables").glob("*.md"))
    assert tables == [f"crowd_{FASTEST_POLICY}_seed{FIRST_SEED}.md",
                      f"door_17_{FASTEST_POLICY}_seed{FIRST_SEED}.md"]
    assert "| Steps | S (cm) |" in (out / "tables" / tables[1]).read_text()
    summary = (out / "summary.md").read_text()
    assert "results.json" in summary and "figures/door_17.png" in summary
    assert json.loads((out / "run.json").read_text())["seeds"] == [FIRST_SEED]


def test_ablation_end_to_end(tmp_path):
    """``--ablation``: period-aware, each addition off in turn and the paper's planner, on every scene given;
    the summary's table of what each addition buys has one row per policy and one column per setting."""
    from footstep_gym.planners import ablation_variants

    out = tmp_path / "ablation"
    proc = run_cli("--ablation", "--episodes", "1", "--env", "crossing", "--env", "crowd", "--crowd-speed", "0.2",
                   "--no-figures", "--out", str(out), "--workers", "2", timeout=600)
    assert proc.returncode == 0, proc.stderr
    records = json.loads((out / "results.json").read_text())
    variants = ablation_variants()
    assert [r["policy"] for r in records] == list(variants) * 2
    assert {r["scenario"] for r in records} == {"crossing", "crowd"}
    for r in records:
        check_record(r)
    summary = (out / "summary.md").read_text()
    table = summary[summary.index("## What each addition buys"):]
    rows = [line for line in table.splitlines() if line.startswith("| period-aware") or line.startswith("| paper-")]
    assert [row.split("|")[1].strip() for row in rows] == list(variants)
    assert all(row.count(" ms") == 2 for row in rows)  # a cell per setting


def _without_timing(records: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in records]


def test_workers_do_not_change_results(tmp_path):
    common = ["--episodes", "2", "--seed", "7", "--env", "door", "--env", "crowd", "--door-speed", "14",
              "--policy", "period-aware", "--no-figures"]
    outs = []
    for workers in ("1", "2"):
        out = tmp_path / f"w{workers}"
        proc = run_cli(*common, "--out", str(out), "--workers", workers)
        assert proc.returncode == 0, proc.stderr
        outs.append(json.loads((out / "results.json").read_text()))
    assert outs[0][0]["seeds"] == [FIRST_SEED + 7, FIRST_SEED + 8]
    assert _without_timing(outs[0]) == _without_timing(outs[1])


@pytest.mark.parametrize("args,message", [
    (["--env", "moon"], "unknown env 'moon'"),
    (["--policy", "teleport"], "unknown policy 'teleport'"),
    (["--episodes", "0"], "--episodes: must be >= 1"),
    (["--door-speed", "-3"], "--door-speed"),
    (["--env", "crowd", "--door-speed", "8"], "--door-speed applies to the door env only"),
])
def test_bad_cli_values_exit_nonzero_with_a_message(args, message, tmp_path):
    proc = run_cli(*args, "--out", str(tmp_path / "x"), timeout=60)
    assert proc.returncode != 0
    assert message in proc.stderr
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_quick_default_runs(tmp_path):
    proc = run_cli("--out", str(tmp_path), timeout=900)
    assert proc.returncode == 0, proc.stderr
    records = json.loads((tmp_path / "results.json").read_text())
    assert {r["scenario"] for r in records} == {"door", "crossing", "crowd"}
    for r in records:
        check_record(r)


# ---------------------------------------------------------------- splits, statistics over training runs
def test_seed_splits_are_disjoint_and_bounded():
    from footstep_gym.evaluation.splits import SPLITS, split_seeds

    ranges = sorted(SPLITS.values())
    assert all(a1 <= b0 for (_, a1), (b0, _) in zip(ranges, ranges[1:]))
    assert {"train", "validation", "test"} <= set(SPLITS)
    first, end = SPLITS["test"]
    assert split_seeds("test", 3, release=True) == [first, first + 1, first + 2]
    assert split_seeds("test", 2, offset=5, release=True) == [first + 5, first + 6]
    with pytest.raises(ValueError, match="runs only as eval_planner.py --benchmark --release"):
        split_seeds("test", 1)  # the board's split: a release run's only
    with pytest.raises(ValueError, match="goes past its end"):
        split_seeds("validation", 2, offset=SPLITS["validation"][1] - SPLITS["validation"][0] - 1)
    with pytest.raises(ValueError, match="unknown split"):
        split_seeds("holdout", 1)


def _run_record(run: str, outcomes: list[str]) -> CellRecord:
    eps = [_episode(i, o, 10, 5.0, 1.0) for i, o in enumerate(outcomes)]
    return cell_record("FootstepDoor-v0", "door", "ppo", {"door_speed": 8.0}, eps, run=run)


def test_over_runs_pools_episodes_and_gives_an_iqm_over_training_seeds():
    from footstep_gym.evaluation.records import over_runs
    from footstep_gym.evaluation.stats import iqm_over_tasks

    runs = [_run_record("FootstepDoor-v0_1", ["goal"] * 4),
            _run_record("FootstepDoor-v0_2", ["goal", "goal", "collision", "fall"]),
            _run_record("FootstepDoor-v0_3", ["collision"] * 4)]
    planner = cell_record("FootstepDoor-v0", "door", "period-aware", {"door_speed": 8.0}, [_episode(0, "goal", 9, 4, 1)])
    out = over_runs(runs + [planner])
    assert len(out) == 2 and out[1] is planner
    pooled = out[0]
    assert (pooled.episodes, pooled.successes, pooled.success_rate) == (12, 6, 0.5)
    assert pooled.collision_rate == pytest.approx(5 / 12) and pooled.fall_rate == pytest.approx(1 / 12)
    assert pooled.success_ci95 == list(wilson_interval(6, 12))
    assert pooled.run_success_rates == [1.0, 0.5, 0.0] and pooled.runs[0] == "FootstepDoor-v0_1"
    # IQM of three runs trims nothing (0.25 * 3 < 1): the mean; the bootstrap interval spans the runs.
    assert pooled.success_iqm == pytest.approx(0.5)
    lo, hi = pooled.success_iqm_ci95
    assert 0.0 <= lo < 0.5 < hi <= 1.0
    # With eight runs the IQM drops the best two and the worst two.
    iqm, lo, hi = iqm_over_tasks(np.array([[0.0, 0.1, 0.5, 0.5, 0.6, 0.6, 0.9, 1.0]]).T)
    assert iqm == pytest.approx(np.mean([0.5, 0.5, 0.6, 0.6])) and lo <= iqm <= hi


# ---------------------------------------------------------------- more of the CLI
def test_crowd_speed_cells_and_a_clean_output_folder(tmp_path):
    out = tmp_path / "eval"
    (out / "figures").mkdir(parents=True)
    (out / "figures" / "stale.png").write_bytes(b"old")
    (out / "run.json").write_text("{}")
    proc = run_cli("--env", "crowd", "--crowd-speed", "0.2", "--crowd-speed", "0.12", "--policy", FASTEST_POLICY,
                   "--episodes", "1", "--workers", "1", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    records = json.loads((out / "results.json").read_text())
    assert [r["params"] for r in records] == [{"crowd_speed": 0.2}, {"crowd_speed": 0.12}]
    assert not (out / "figures" / "stale.png").exists()  # an earlier run's figures are not left behind
    assert (out / "figures" / "crowd_0.2.png").is_file()
    assert sorted(p.name for p in (out / "tables").iterdir())[0] == f"crowd_0.12_fixed-period_seed{FIRST_SEED}.md"
    run = json.loads((out / "run.json").read_text())  # a list per sweep axis, named as ever
    assert run["crowd_speeds"] == [0.2, 0.12] and run["door_speeds"] == [17.0]  # the quick profile's door
    assert list(run)[list(run).index("seeds") + 1:][:2] == ["door_speeds", "crowd_speeds"]
    for r in records:
        assert r["min_zmp_margin_median"] is not None
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    proc = run_cli("--env", "crowd", "--policy", FASTEST_POLICY, "--episodes", "1", "--out", str(tmp_path / "mine"))
    assert proc.returncode != 0 and "not empty" in proc.stderr
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep"


def test_ray_backend_gives_the_local_results(tmp_path):
    pytest.importorskip("ray")
    from footstep_gym.evaluation.runner import run_tasks

    cells = [Cell("FootstepCrossing-v0", "crossing", FASTEST_POLICY), Cell("FootstepCrowd-v0", "crowd", FASTEST_POLICY)]
    tasks = [Task(i, c, s) for i, c in enumerate(cells) for s in (FIRST_SEED, FIRST_SEED + 1)]
    local = run_tasks(tasks, workers=1, progress=False)
    remote = run_tasks(tasks, workers=2, backend="ray", progress=False)
    strip = lambda rs: [(r.cell_index, r.seed, r.outcome, r.steps, r.time, r.path_length, r.min_clearance)  # noqa: E731
                        for r in rs]
    assert strip(local) == strip(remote)
    with pytest.raises(ValueError, match="unknown backend"):
        run_tasks(tasks, backend="spark")


def test_help_lists_every_policy():
    proc = run_cli("--help", timeout=60)
    assert proc.returncode == 0
    for name in ("period-aware", "fixed-period", "pso-only", "ppo", "ppo-all", "sac", "--crowd-speed", "--video",
                 "--agent", "--split"):
        assert name in proc.stdout, name


# ---------------------------------------------------------------- nothing a user made is lost
def _earlier_run(out: Path) -> dict[str, bytes]:
    """A folder holding an earlier evaluation (and a user's note beside it); its files' bytes by path."""
    (out / "figures").mkdir(parents=True)
    (out / "run.json").write_text('{"profile": "quick"}\n')
    (out / "results.json").write_text("[]\n")
    (out / "figures" / "door_17.png").write_bytes(b"\x89PNG earlier")
    (out / "notes.txt").write_text("mine")
    return _snapshot(out)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_bad_setting_exits_2_with_one_line_before_touching_out(tmp_path):
    """A door speed above the env's bound used to empty --out, then die in a worker's traceback."""
    out = tmp_path / "eval"
    before = _earlier_run(out)
    proc = run_cli("--env", "door", "--door-speed", "400", "--policy", FASTEST_POLICY, "--episodes", "1",
                   "--out", str(out), timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and "door_speed=400" in errors[0] and "max_door_speed" in errors[0], proc.stderr
    assert _snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eval"]  # no temporary folder left beside it


def test_an_agent_folder_without_a_model_is_refused_up_front(tmp_path):
    (tmp_path / "not_an_agent").mkdir()
    proc = run_cli("--env", "crossing", "--agent", str(tmp_path / "not_an_agent"), "--out", str(tmp_path / "x"),
                   timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "expected one <EnvId>.zip" in proc.stderr.splitlines()[-1]
    assert not (tmp_path / "x").exists()


def test_a_run_that_fails_midway_leaves_out_as_it_was(tmp_path, monkeypatch, capsys):
    """The second episode's policy fails: the earlier run's files are all still there, nothing half-written."""
    from footstep_gym import registry

    script = load_script("eval_planner")
    real = registry.PolicyEntry.make

    def failing(entry, robot=None, seed=None, **kwargs):  # the entry the cell carries builds each episode's policy
        if seed == FIRST_SEED + 1:
            raise RuntimeError("simulated failure")
        return real(entry, robot, seed, **kwargs)

    monkeypatch.setattr(registry.PolicyEntry, "make", failing)
    out = tmp_path / "eval"
    before = _earlier_run(out)
    code = script.main(["--env", "crossing", "--policy", FASTEST_POLICY, "--episodes", "2", "--workers", "1",
                        "--out", str(out)])
    assert code == 1
    assert "simulated failure" in capsys.readouterr().err.splitlines()[-1]
    assert _snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eval"]


def test_a_worker_failing_on_a_broken_agent_leaves_out_as_it_was(tmp_path):
    """Through the CLI: an agent whose files look right but whose model does not load fails in the worker."""
    broken = tmp_path / "broken" / "FootstepCrossing-v0_1"
    (broken / "FootstepCrossing-v0").mkdir(parents=True)
    (broken / "FootstepCrossing-v0.zip").write_bytes(b"not a zip file")
    (broken / "FootstepCrossing-v0" / "args.yml").write_text("algo: ppo\n")
    out = tmp_path / "eval"
    before = _earlier_run(out)
    proc = run_cli("--env", "crossing", "--agent", str(broken), "--episodes", "1", "--workers", "2",
                   "--out", str(out), timeout=300)
    assert proc.returncode == 1
    assert "left as it was" in proc.stderr.splitlines()[-1]
    assert _snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken", "eval"]


def test_a_finished_run_replaces_the_earlier_one_and_keeps_the_users_files(tmp_path):
    out = tmp_path / "eval"
    _earlier_run(out)
    proc = run_cli("--env", "crossing", "--policy", FASTEST_POLICY, "--episodes", "1", "--workers", "1",
                   "--no-figures", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert (out / "notes.txt").read_text() == "mine"
    assert not (out / "figures").exists()  # the earlier run's figures; this run drew none
    assert json.loads((out / "run.json").read_text())["envs"] == ["crossing"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eval"]


# ---------------------------------------------------------------- what a user sees
def test_each_process_warms_a_cell_up_once_before_timing_it(monkeypatch):
    """The first acts of a fresh process load the compiled kernels: they run untimed, on a throwaway policy."""
    from footstep_gym.evaluation import runner

    monkeypatch.setattr(runner, "_warmed", set())
    made: list[list[str]] = []  # per policy instance, its calls

    class Logged(StraightAhead):
        def __init__(self, robot, seed=None):
            super().__init__(robot, seed)
            made.append([])

        def act(self, observation, snapshot):
            made[-1].append("act")
            return super().act(observation, snapshot)

    def factory(cell, robot, seed):
        return Logged(robot, seed)

    cell = Cell("FootstepCrossing-v0", "crossing", "logged")
    first = run_episode(Task(0, cell, 1), factory=factory)
    assert len(made) == 2  # the warm-up's policy, then the timed one
    assert len(made[0]) == min(runner.WARMUP_ACTS, first.steps) > 0
    assert len(first.plan_ms) == len(made[1]) == first.steps  # only the second policy's acts are timed
    second = run_episode(Task(0, cell, 2), factory=factory)
    assert len(made) == 3 and len(second.plan_ms) == len(made[2])  # this process is warm for the cell now
    unwarmed = run_episode(Task(0, cell, 1), factory=factory, warm=False)  # the warm-up changes no result
    assert (unwarmed.outcome, unwarmed.steps, unwarmed.path_length) == (first.outcome, first.steps,
                                                                           first.path_length)


WARM_PROBE = """
import json, numba
import footstep_gym.kernels.numba_kernels as K, footstep_gym.kernels.sweep as S
from footstep_gym.evaluation.runner import Cell, Task, default_factory, run_episode
kernels = [f for m in (K, S) for f in vars(m).values() if isinstance(f, numba.core.registry.CPUDispatcher)]
loaded = lambda: sum(len(k.overloads) for k in kernels)
class Counted:  # counts the kernels each act loads
    def __init__(self, policy):
        self.policy, self.loads = policy, []
    @property
    def last_info(self):
        return self.policy.last_info
    def reset(self, seed=None):
        self.policy.reset(seed=seed)
    def act(self, obs, snapshot):
        before = loaded()
        action = self.policy.act(obs, snapshot)
        self.loads.append(loaded() - before)
        return action
instances = []
def factory(cell, robot, seed):
    instances.append(Counted(default_factory(cell, robot, seed)))
    return instances[-1]
r = run_episode(Task(0, Cell("FootstepDoor-v0", "door", "period-aware", (("door_speed", 17.0),)), 20000),
                factory=factory)
print(json.dumps({"loads": [i.loads for i in instances], "timed_acts": len(r.plan_ms)}))
"""


def test_kernels_load_in_the_warm_up_not_in_a_timed_act():
    """In a fresh process, every numba kernel the planner uses is loaded (or compiled) before the first
    timed act: no timed act loads one (checked on the kernels themselves, not on timings)."""
    proc = subprocess.run([sys.executable, "-c", WARM_PROBE], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    probe = json.loads(proc.stdout.splitlines()[-1])
    timed = probe["loads"][-1]  # the runner builds the timed episode's policy last
    assert len(timed) == probe["timed_acts"]
    assert sum(timed) == 0, f"timed acts loaded kernels: {timed}"
    assert len(probe["loads"]) == 2 and sum(probe["loads"][0]) > 0  # the warm-up's policy loaded them


def test_missing_shipped_agents_are_one_line_not_warnings(tmp_path, capsys, recwarn):
    script = load_script("eval_planner")
    settings = script.parse_settings(["--env", "door", "--env", "crowd", "--policy", "ppo", "--policy", "sac",
                                      "--policy", FASTEST_POLICY, "--agents-dir", str(tmp_path)])
    cells = profiles.make_cells(settings)
    assert [c.policy for c in cells] == [FASTEST_POLICY, FASTEST_POLICY]
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "ppo on FootstepDoor-v0, FootstepCrowd-v0" in err[0] and "sac on" in err[0]
    assert not [w for w in recwarn if "agent" in str(w.message)]


def test_the_iqm_bootstrap_raises_no_future_warning():
    import warnings

    from footstep_gym.evaluation.stats import iqm_over_tasks

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert iqm_over_tasks([[0.2], [0.5], [0.9]])[0] == pytest.approx(0.5 + 0.1 / 3, abs=0.1)


def test_file_names_are_safe_and_the_same_everywhere(tmp_path):
    from footstep_gym.evaluation import report
    from footstep_gym.evaluation.runner import safe_name

    assert safe_name("door_17", "agent:FootstepDoor-v0_1", "seed20000") == "door_17_agent-FootstepDoor-v0_1_seed20000"
    assert safe_name("crowd_0.2", "period-aware") == "crowd_0.2_period-aware"
    cells = [Cell("FootstepDoor-v0", "door", "agent:FootstepDoor-v0_1", (("door_speed", 8.0),), run="x")]
    results = [run_episode(Task(0, cells[0], 3, record=True), factory=stand_in)]
    written = report.write_pictures(tmp_path, cells, results, "period-aware")
    names = sorted(str(p.relative_to(tmp_path)) for p in written)
    assert names == ["figures/door_8.png", "tables/door_8_agent-FootstepDoor-v0_1_seed3.md"]


def test_videos_go_to_a_new_folder_without_warnings_and_with_safe_names(tmp_path):
    """Gymnasium warned "Overwriting existing videos" from the second video of a fresh folder on."""
    pytest.importorskip("moviepy")
    pytest.importorskip("pygame")
    import warnings

    from footstep_gym.evaluation import runner

    cells = [Cell("FootstepDoor-v0", "door", policy, (("door_speed", 8.0),)) for policy in ("straight", "agent:x")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        paths = [runner.record_video(c, 3, tmp_path / "videos", factory=stand_in) for c in cells]
    assert not [str(w.message) for w in caught if "video" in str(w.message).lower()]
    assert [p.name for p in paths] == ["door_8_straight.mp4", "door_8_agent-x.mp4"]
    assert sorted(p.name for p in (tmp_path / "videos").iterdir()) == sorted(p.name for p in paths)


def test_a_policy_name_is_resolved_once_and_its_entry_travels(monkeypatch):
    """The benchmark resolves the name; its cells carry the entry through the checks, the episodes and (by name,
    back to the same entry) the pickle to a worker: the registry is not asked again."""
    import pickle

    from footstep_gym import registry
    from footstep_gym.evaluation import benchmark
    from footstep_gym.evaluation.runner import check_cells, run_tasks

    entry = registry.resolve("null-walk-10cm-0.4s")
    assert pickle.loads(pickle.dumps(entry)) is entry
    cells, _ = benchmark.runner_cells(benchmark.benchmark_cells(["crossing"], ["paper"]), entry)
    assert [c.entry for c in cells] == [entry] and cells[0].policy == entry.name

    def asked_again(*args, **kwargs):
        raise AssertionError(f"the registry was asked again: {args}")

    monkeypatch.setattr(registry, "resolve", asked_again)
    monkeypatch.setattr(registry, "make_policy", asked_again)
    assert check_cells(cells) is None
    (result,) = run_tasks(benchmark.tasks(cells, 1), workers=1, progress=False)
    assert result.steps > 0 and result.outcome in OUTCOMES
    with pytest.raises(ValueError, match="entry 'null-walk-10cm-0.4s' is not policy 'other'"):
        Cell(cells[0].env_id, "crossing", "other", entry=entry)
