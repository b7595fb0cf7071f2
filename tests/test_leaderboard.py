"""The leaderboard across policies: ``baselines/make_leaderboard.py`` on benchmark.json files.

The aggregates (IQM and optimality gap with stratified-bootstrap intervals over training runs) are checked against
a hand-worked score matrix, the per-scene table against tiny fake benchmark.json files built with the records'
real fields (``records.cell_record`` with the benchmark's own), the script end to end on them (tables, JSON and
non-empty PNGs; a user's file in ``--out`` kept), and bad input is refused with exit status 2 and nothing written.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from script_helpers import load_script

from footstep_gym.evaluation import leaderboard as lb
from footstep_gym.evaluation.board import SHOWN_BOARD_DIR
from footstep_gym.evaluation.records import cell_record
from footstep_gym.evaluation import protocol
from footstep_gym.evaluation.splits import PROTOCOL_VERSION
from footstep_gym.evaluation.stats import EpisodeResult, iqm_over_tasks, wilson_interval

REPS = 20  # few bootstrap resamples: the tests check the plumbing, not the intervals' precision
ENV_IDS = {"door": "FootstepDoor-v0", "crossing": "FootstepCrossing-v0"}
#: The fake protocol: two tiers, two scenes, five cells, ten episodes per cell.
CELLS = [("door", "paper", "default"), ("crossing", "paper", "default"),
         ("door", "hard", "two_doors"), ("door", "hard", "noisy"), ("crossing", "hard", "traffic")]
EPISODES = 10
SHA = "ab" * 32
PNG = b"\x89PNG\r\n\x1a\n"


def record(policy: str, scene: str, tier: str, cell: str, run: str | None, wins: int,
           upper_bound: bool = False) -> dict:
    """A benchmark record as ``benchmark.cell_records`` writes it: ``wins`` of :data:`EPISODES` reach the goal."""
    episodes = [EpisodeResult(cell_index=0, seed=20000 + i, outcome="goal" if i < wins else "collision", steps=20,
                              time=10.0, path_length=2.5, com_path_length=2.6, plan_ms=[1.0, 2.0],
                              periods=[0.45, 0.5], pso_ran=[None, None], min_clearance=0.05, min_zmp_margin=0.01)
                for i in range(EPISODES)]
    return cell_record(ENV_IDS[scene], scene, policy, {"tier": tier, "tier_cell": cell}, episodes, run=run,
                       scene=scene, tier=tier, cell=cell, env_kwargs={}, upper_bound=upper_bound).to_dict()


def squash(table: str) -> list[str]:
    """A markdown table's lines without the padding around its cells."""
    return [re.sub(r" *\| *", " | ", line).strip() for line in table.splitlines()]


def document(policy: str, wins: dict[tuple[str, str], list[int]], upper_bound: bool = False, sha: str = SHA,
             episodes: int = EPISODES, version: int = 2) -> dict:
    """A benchmark.json of ``policy``: ``wins[(scene, cell)]`` lists the successes of each training run (one
    entry: a planner). The cells it has no entry for are left out (a partial run). Protocol 2's by default (no
    fingerprint, no access log: :func:`release_document` makes a protocol-3 row)."""
    cells = [c for c in CELLS if (c[0], c[2]) in wins]
    agent = any(len(w) > 1 for w in wins.values())
    records = [record(policy, s, t, c, f"{ENV_IDS[s]}_{k + 1}" if agent else None, w, upper_bound)
               for s, t, c in cells for k, w in enumerate(wins[(s, c)])]
    label = f"{policy} (upper bound)" if upper_bound else policy
    return {
        "benchmark": "footstep_gym", "protocol_version": version, "footstep_gym": "0.1.0", "policy": policy,
        "label": label, "upper_bound": upper_bound, "description": "a fake", "complete": len(cells) == len(CELLS),
        "protocol": {"split": "test", "episodes_per_cell": episodes, "seeds": list(range(30000, 30000 + episodes)),
                     "tiers": list(dict.fromkeys(t for _, t, _ in cells)),
                     "scenes": list(dict.fromkeys(s for s, _, _ in cells)),
                     "cells": [{"scene": s, "tier": t, "cell": c, "env_id": ENV_IDS[s], "env_kwargs": {}}
                               for s, t, c in cells],
                     "warmup_acts": 10, "timing_fields": [], "env_configs_sha256": sha},
        "aggregates": [], "records": records, "summary": [], "run": {"command": "fake"},
    }


#: An agent with two runs, a planner, a partial agent (door only), an upper bound.
AGENT = {("door", "default"): [10, 10], ("crossing", "default"): [8, 6], ("door", "two_doors"): [3, 5],
         ("door", "noisy"): [10, 10], ("crossing", "traffic"): [0, 2]}
PLANNER = {("door", "default"): [9], ("crossing", "default"): [10], ("door", "two_doors"): [1],
           ("door", "noisy"): [4], ("crossing", "traffic"): [7]}
PARTIAL = {("door", "default"): [5, 7], ("door", "two_doors"): [2, 2]}
ORACLE = {key: [10] for key in AGENT}


def fakes() -> list[dict]:
    return [document("planner", PLANNER), document("partial", PARTIAL), document("oracle", ORACLE, upper_bound=True),
            document("agent", AGENT)]


def write_fakes(root: Path, docs: list[dict] | None = None) -> Path:
    for doc in docs if docs is not None else fakes():
        (root / doc["policy"]).mkdir(parents=True)
        (root / doc["policy"] / "benchmark.json").write_text(json.dumps(doc), encoding="utf-8")
    return root


# ---------------------------------------------------------------- aggregates
def test_iqm_and_optimality_gap_of_a_hand_worked_matrix():
    scores = np.array([[0.0, 0.5, 0.9, 1.0],
                       [0.2, 0.6, 0.8, 1.0]])
    # Sorted: 0.0 0.2 | 0.5 0.6 0.8 0.9 | 1.0 1.0 -> IQM = mean of the middle half = 2.8 / 4.
    # Gap: mean of max(0, 1 - s) = (1 + .5 + .1 + 0 + .8 + .4 + .2 + 0) / 8 = 3.0 / 8.
    point, interval = lb.interval_estimates(scores, lb.iqm_and_gap, reps=200, seed=3)
    assert point == pytest.approx([0.7, 0.375])
    assert point[0] == pytest.approx(iqm_over_tasks(scores, reps=10)[0])
    assert interval.shape == (2, 2)
    assert np.all(interval[0] <= point + 1e-12) and np.all(point <= interval[1] + 1e-12)
    assert interval[0, 0] < interval[1, 0]  # two runs that differ: a real interval
    # Seeded: the same interval again, whatever the global generator did in between; and it is put back.
    np.random.seed(123)
    before = np.random.get_state()[1].copy()
    again = lb.interval_estimates(scores, lb.iqm_and_gap, reps=200, seed=3)[1]
    assert np.array_equal(np.random.get_state()[1], before)
    assert np.array_equal(again, interval)
    # The IQM's interval does not depend on what else is estimated with it (the same resamples).
    iqm_only = lb.interval_estimates(scores, lambda x: lb.iqm_and_gap(x)[:1], reps=200, seed=3)[1]
    assert np.array_equal(iqm_only[:, 0], interval[:, 0])


def test_a_one_run_policy_has_its_point_as_interval():
    scores = np.array([[0.0, 0.5, 0.9, 1.0]])
    point, interval = lb.interval_estimates(scores, lb.iqm_and_gap, reps=REPS)
    # IQM over 4 entries: the middle two, (0.5 + 0.9) / 2; gap (1 + .5 + .1 + 0) / 4.
    assert point == pytest.approx([0.7, 0.4])
    assert np.array_equal(interval, np.stack([point, point]))
    curve, band = lb.profile_estimates(scores, reps=REPS)
    assert np.array_equal(band[0], curve) and np.array_equal(band[1], curve)
    assert curve[0] == pytest.approx(0.75) and curve[-1] == 0.0  # > 0: three of four; > 1: none


def test_the_board_pairs_runs_and_marks_partial_and_upper_bound():
    board = lb.build(fakes(), reps=REPS)
    assert [p["policy"] for p in board["policies"]] == ["agent", "planner", "partial", "oracle"]
    assert board["tiers"] == ["paper", "hard"] and board["scenes"] == ["door", "crossing"]
    agg = {(a["policy"], a["tier"]): a for a in board["aggregates"]}
    hard = agg[("agent", "hard")]
    assert hard["scores"] == [[0.3, 1.0, 0.0], [0.5, 1.0, 0.2]]  # run k of each cell in row k
    assert hard["iqm"] == pytest.approx((0.2 + 0.3 + 0.5 + 1.0) / 4)  # middle half of 0 .2 .3 .5 1 1
    assert hard["optimality_gap"] == pytest.approx((0.7 + 0 + 1 + 0.5 + 0 + 0.8) / 6)
    assert hard["runs"] == 2 and hard["covers_tier"]
    planner = agg[("planner", "hard")]
    assert planner["runs"] == 1 and planner["iqm_ci95"] == [planner["iqm"]] * 2
    assert planner["optimality_gap_ci95"] == [planner["optimality_gap"]] * 2
    partial = agg[("partial", "hard")]
    assert not partial["covers_tier"] and partial["missing_cells"] == ["door/noisy", "crossing/traffic"]
    shown, left_out = lb.in_figure(board, "hard")
    assert [p["policy"] for p in shown] == ["agent", "planner", "oracle"]
    assert [p["policy"] for p in left_out] == ["partial"]
    head = squash(lb.headline_markdown(board))
    assert head[0] == "| policy | runs | paper (2 cells) | hard (3 cells) |"
    assert head[2].startswith("| agent | 2 | ") and head[3].startswith("| planner | 1 | ")
    assert head[4].startswith("| partial (partial) | 2 | ") and head[4].endswith(" † |")
    assert head[5].startswith("| *oracle (upper bound)* | 1 | 1.00 [1.00, 1.00] | 1.00 [1.00, 1.00] |")
    assert f"{hard['iqm']:.2f} [{hard['iqm_ci95'][0]:.2f}, {hard['iqm_ci95'][1]:.2f}]" in head[2]


def test_the_in_distribution_track_is_its_own_table():
    """A file of a method trained on one tier is no row of the headline (nor of the figures): it has its own table,
    beside the generalisation track's learned rows and upper bounds on the same tier."""
    agent = {**document("agent", AGENT), "run": {"command": "fake", "agent_runs": ["FootstepDoor-v0_1"]}}
    hard_only = {key: wins for key, wins in AGENT.items() if key[1] != "default"}
    trained_here = {**document("agent-hard", {k: [min(10, w + 5) for w in ws] for k, ws in hard_only.items()}),
                    "track": "in-distribution", "trained_on_tier": "hard", "complete": True,
                    "run": {"command": "fake", "agent_runs": ["FootstepDoor-v0_1"]}}
    board = lb.build([document("planner", PLANNER), document("oracle", ORACLE, upper_bound=True), agent,
                      trained_here], reps=REPS)
    assert [p["policy"] for p in board["policies"]] == ["agent", "planner", "oracle"]
    (entry,) = board["in_distribution"]
    assert entry["policy"] == "agent-hard" and entry["complete"] and entry["trained_on_tier"] == "hard"
    assert [a["tier"] for a in board["aggregates"] if a["policy"] == "agent-hard"] == ["hard"]
    assert "agent-hard" not in lb.headline_markdown(board)
    assert [p["policy"] for p in lb.in_figure(board, "hard")[0]] == ["agent", "planner", "oracle"]
    table = squash(lb.in_distribution_markdown(board))
    assert table[0] == "| policy | trained on | runs | hard (3 cells) |"
    mine = next(a for a in board["aggregates"] if a["policy"] == "agent-hard")
    assert table[2] == f"| agent-hard | hard | 2 | {mine['iqm']:.2f} [{mine['iqm_ci95'][0]:.2f}, " \
                       f"{mine['iqm_ci95'][1]:.2f}] |"
    assert table[3].startswith("| agent | train | 2 | ") and table[4].startswith("| *oracle (upper bound)* | no ")
    assert len(table) == 5  # the planner (it does not learn) is left to the headline table
    text = lb.markdown(board)
    assert "## In-distribution track" in text and "tested on that tier's test seeds only" in text
    no_track = lb.build(fakes(), reps=REPS)
    assert lb.in_distribution_markdown(no_track) == "" and "## In-distribution track" not in lb.markdown(no_track)
    # Protocol 3: the scene-balanced success [hierarchical CI] there too. The agent trained on `hard`: door
    # (two_doors 0.9, noisy 1.0) 0.95, crossing (traffic 0.6) 0.6: (0.95 + 0.6) / 2 = 0.775, no cell trimmed.
    three = lb.build([{**d, "protocol_version": PROTOCOL_VERSION} for d in (
        document("planner", PLANNER), document("oracle", ORACLE, upper_bound=True), agent, trained_here)], reps=REPS)
    scored = {(r["policy"], r["tier"]): r for r in three["scores"]["tiers"]}
    mine = scored[("agent-hard", "hard")]
    assert mine["success"] == pytest.approx(0.775) and mine["trained_on_tier"] == "hard"
    table = squash(lb.in_distribution_markdown(three))
    lo, hi = mine["success_ci95"]
    assert table[2] == f"| agent-hard | hard | 2 | {mine['success']:.2f} [{lo:.2f}, {hi:.2f}] |" and lo < 0.775 < hi
    agent_hard = scored[("agent", "hard")]
    assert table[3] == f"| agent | train | 2 | {agent_hard['success']:.2f} [{agent_hard['success_ci95'][0]:.2f}, " \
                       f"{agent_hard['success_ci95'][1]:.2f}] |"
    assert "scene-balanced success" in lb.markdown(three).split("## In-distribution track", 1)[1]


def test_the_per_scene_table_from_fake_files():
    board = lb.build(fakes(), reps=REPS)
    rows = {(r["policy"], r["tier"], r["scene"]): r for r in board["per_scene"]}
    door = rows[("agent", "hard", "door")]
    # two_doors pooled over the runs (3 + 5) / 20, noisy 20 / 20: the mean over the two cells; Wilson of all 40.
    assert door["success_mean"] == pytest.approx((0.4 + 1.0) / 2)
    assert door["success_ci95"] == pytest.approx(list(wilson_interval(28, 40)))
    assert door["episodes"] == 40 and door["cells"] == ["two_doors", "noisy"] and door["runs"] == 2
    assert rows[("planner", "paper", "crossing")]["success_mean"] == 1.0
    assert ("partial", "hard", "crossing") not in rows
    table = squash(lb.scene_markdown(board))
    assert table[0] == "| tier | scene | cells | agent | planner | partial | oracle (upper bound) |"
    lo, hi = wilson_interval(28, 40)
    assert table[4] == (f"| hard | door | 2 | 0.70 [{lo:.2f}, {hi:.2f}] | 0.25 [{wilson_interval(5, 20)[0]:.2f}, "
                        f"{wilson_interval(5, 20)[1]:.2f}] | 0.20 [{wilson_interval(4, 20)[0]:.2f}, "
                        f"{wilson_interval(4, 20)[1]:.2f}] (1/2 cells) | 1.00 [{wilson_interval(20, 20)[0]:.2f}, "
                        "1.00] |")
    assert table[5].split(" | ")[-2] == "–"  # the partial run has no crossing
    text = lb.markdown(board)
    assert "partial: partial run (scene door only)" in text
    assert "left out: partial from paper (1 of 2 cells); partial from hard (1 of 3 cells)." in text


# ---------------------------------------------------------------- the script
def test_the_script_end_to_end(tmp_path, capsys):
    script = load_script("make_leaderboard")
    bench = write_fakes(tmp_path / "bench")
    out = tmp_path / "board"
    out.mkdir()
    (out / "notes.txt").write_text("mine", encoding="utf-8")
    assert script.main([str(bench), "--out", str(out), "--reps", str(REPS)]) == 0
    printed = capsys.readouterr().out
    assert squash(printed)[0] == "| policy | runs | paper (2 cells) | hard (3 cells) |"
    names = {"leaderboard.md", "leaderboard.json", "iqm_per_tier.png", "iqm_optimality_gap_paper.png",
             "iqm_optimality_gap_hard.png", "performance_profiles.png"}
    assert {p.name for p in out.iterdir()} == names | {"notes.txt"}
    assert (out / "notes.txt").read_text(encoding="utf-8") == "mine"
    for name in names:
        if name.endswith(".png"):
            data = (out / name).read_bytes()
            assert data.startswith(PNG) and len(data) > 1000, name
    board = json.loads((out / "leaderboard.json").read_text(encoding="utf-8"))
    assert board["bootstrap"]["reps"] == REPS and board["protocol"]["env_configs_sha256"] == SHA
    fields = {"policy", "tier", "iqm", "iqm_ci95", "optimality_gap", "optimality_gap_ci95", "runs", "cells"}
    assert all(fields <= set(a) for a in board["aggregates"]) and len(board["aggregates"]) == 8
    assert lb.headline_markdown(board) in (out / "leaderboard.md").read_text(encoding="utf-8")
    # A rerun replaces the leaderboard's files (the same JSON), keeps the user's, leaves no temporary folder.
    assert script.main([str(bench / "agent"), str(bench / "planner" / "benchmark.json"), "--out", str(out),
                        "--reps", str(REPS)]) == 0
    again = json.loads((out / "leaderboard.json").read_text(encoding="utf-8"))
    assert [p["policy"] for p in again["policies"]] == ["agent", "planner"]
    assert {p.name for p in out.iterdir()} == names | {"notes.txt"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bench", "board"]


def _png_width(data: bytes) -> int:
    assert data.startswith(PNG)
    return int.from_bytes(data[16:20], "big")  # the IHDR chunk's width


def test_the_committed_figures_are_readable_at_readme_width():
    """Every committed leaderboard figure is at most 900 px wide (a README's column), and no two policies that are
    not null baselines share a colour and a line style."""
    results = Path(__file__).resolve().parents[1] / "baselines" / "results"
    folder = Path(__file__).resolve().parents[1] / SHOWN_BOARD_DIR
    pngs = sorted(results.glob("benchmark*/*.png"))  # every board kept: the one shown and the archived ones
    board = json.loads((folder / "leaderboard.json").read_text(encoding="utf-8"))
    expected = {lb.FIGURE_IQM, lb.FIGURE_PROFILES} | ({lb.FIGURE_SCORES} if board["protocol_version"] >= 3 else set())
    assert {p.name for p in folder.glob("*.png")} >= expected
    wide = [f"{p.name}: {_png_width(p.read_bytes())} px" for p in pngs if _png_width(p.read_bytes()) > 900]
    assert not wide, f"wider than 900 px: {wide}"
    styles = lb.policy_styles(board)
    assert set(styles) == {p["label"] for p in board["policies"]}
    drawn = [(tuple(st["color"]) if not isinstance(st["color"], str) else st["color"], st["linestyle"])
             for st in styles.values() if st["group"] != "null"]
    assert len(drawn) == len(set(drawn)) and len(drawn) > 10


def test_help_exits_0(capsys):
    with pytest.raises(SystemExit) as exc:
        load_script("make_leaderboard").main(["--help"])
    assert exc.value.code == 0 and "--allow-mixed" in capsys.readouterr().out


def _bad(tmp_path: Path, case: str) -> list[str]:
    bench = tmp_path / "bench"
    if case == "missing":
        return [str(tmp_path / "nowhere")]
    if case == "empty folder":
        bench.mkdir()
        (bench / "ppo").mkdir()
        return [str(bench)]
    if case == "other format":
        bench.mkdir()
        (bench / "benchmark.json").write_text(json.dumps({"results": []}), encoding="utf-8")
        return [str(bench)]
    if case == "not json":
        bench.mkdir()
        (bench / "benchmark.json").write_text("{", encoding="utf-8")
        return [str(bench / "benchmark.json")]
    if case == "protocol version":
        write_fakes(bench, [document("agent", AGENT, version=PROTOCOL_VERSION + 1)])
        return [str(bench)]
    if case == "configs":
        write_fakes(bench, [document("agent", AGENT), document("planner", PLANNER, sha="cd" * 32)])
        return [str(bench)]
    if case == "episodes":
        write_fakes(bench, [document("agent", AGENT), document("planner", PLANNER, episodes=500)])
        return [str(bench)]
    if case == "twice":
        write_fakes(bench, [document("agent", AGENT)])  # the same policy in two files (one file twice: read once)
        (tmp_path / "copy.json").write_text(json.dumps(document("agent", AGENT)), encoding="utf-8")
        return [str(bench), str(bench / "agent" / "benchmark.json"), str(tmp_path / "copy.json")]
    if case == "out is a file":
        write_fakes(bench)
        (tmp_path / "board").write_text("", encoding="utf-8")
        return [str(bench)]
    raise AssertionError(case)


@pytest.mark.parametrize("case, message", [
    ("missing", "no such file or folder"), ("empty folder", "no benchmark.json"),
    ("other format", "not a footstep_gym benchmark.json"), ("not json", "not a readable JSON file"),
    ("protocol version", f"protocol_version {PROTOCOL_VERSION + 1}"), ("configs", "differ in protocol.env_configs_sha256"),
    ("episodes", "differ in protocol.episodes_per_cell"), ("twice", "is in both"),
    ("out is a file", "is a file, not a folder"),
])
def test_bad_input_is_refused_with_exit_2_and_nothing_written(tmp_path, capsys, case, message):
    args = _bad(tmp_path, case)
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    with pytest.raises(SystemExit) as exc:
        load_script("make_leaderboard").main([*args, "--out", str(tmp_path / "board"), "--reps", str(REPS)])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "error: " in err[-1] and message in err[-1], err
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


def test_allow_mixed_accepts_other_configs(tmp_path):
    bench = write_fakes(tmp_path / "bench", [document("agent", AGENT), document("planner", PLANNER, sha="cd" * 32)])
    assert load_script("make_leaderboard").main([str(bench), "--allow-mixed", "--out", str(tmp_path / "board"),
                                                 "--reps", str(REPS)]) == 0
    board = json.loads((tmp_path / "board" / "leaderboard.json").read_text(encoding="utf-8"))
    assert board["protocol"]["env_configs_sha256"] == [SHA, "cd" * 32]
    # The row of the other protocol is marked and its difference said under the table.
    three = write_fakes(tmp_path / "three", [document("agent", AGENT), document("partial", PARTIAL),
                                             document("planner", PLANNER, sha="cd" * 32, episodes=20)])
    board = lb.leaderboard([three], allow_mixed=True, reps=REPS)
    rows = {line.split("|")[1].strip(): line for line in lb.headline_markdown(board).splitlines()[2:]}
    assert set(rows) == {"agent", "partial (partial)", "planner ‡"}
    notes = lb.headline_notes(board)
    assert notes[-1].startswith(f"‡ planner: another protocol than the other rows (env configs {'cd' * 6}, 20 "
                                "episodes per cell;")
    assert "configs abababababab (rows marked ‡: another protocol)" in lb.markdown(board)


def test_the_benchmarks_bootstrap_intervals_are_seeded_and_leave_numpys_generator_alone():
    """rliable draws its resamples from NumPy's global generator whatever random_state it is given: the interval
    must not depend on that generator's state, and the caller's stream must go on as if nothing had drawn."""
    from footstep_gym.evaluation import stats

    matrix = np.array([[0.2, 0.9, 0.5, 1.0], [0.6, 0.4, 0.7, 0.8], [0.1, 1.0, 0.3, 0.9]])
    np.random.seed(1)
    first = stats.iqm_over_tasks(matrix, reps=300)
    after_first = np.random.random()
    np.random.seed(2)
    second = stats.iqm_over_tasks(matrix, reps=300)
    assert first == second and first[1] < first[0] < first[2]
    np.random.seed(1)
    assert np.random.random() == after_first  # the global stream untouched by the bootstrap
    column = [[0.2], [0.6], [0.9]]
    assert stats.iqm_over_tasks(column, reps=300) == stats.iqm_over_tasks(column, reps=300)


def test_a_mix_of_episodes_per_cell_is_refused_in_one_short_line(tmp_path):
    """Many files of the board's number and one of another: one short line naming the odd file, its number and
    the board's (not a list of every file)."""
    board = [document(f"planner-{k}", PLANNER) for k in range(31)]
    write_fakes(tmp_path / "bench", [*board, document("mine", PLANNER, episodes=2)])
    with pytest.raises(lb.LeaderboardError) as exc:
        lb.leaderboard([tmp_path / "bench"], reps=REPS)
    text = str(exc.value)
    mine = tmp_path / "bench" / "mine" / "benchmark.json"
    assert "\n" not in text and len(text) < 200 + 2 * len(str(mine)), text
    assert f"{mine}: 2 episodes per cell; the board (" in text and f"and 30 more): {EPISODES};" in text, text
    assert "--allow-mixed" in text


# ---------------------------------------------------------------- protocol 3: fingerprint, split, access log
FP = "f0" * 32


def release_document(policy: str, wins: dict[tuple[str, str], list[int]], fingerprint: str = FP,
                     split: str = "test") -> tuple[dict, protocol.Access]:
    """A protocol-3 row of ``policy`` with its fingerprint and split, and the access-log line of its release."""
    doc = document(policy, wins, version=PROTOCOL_VERSION)
    doc["protocol"].update(fingerprint=fingerprint, split=split)
    access = protocol.Access("2026-11-28T01:00:00Z", "a" * 40, policy, 5, EPISODES, fingerprint)
    if split == "test":
        doc["run"]["release"] = access.to_dict()
    return doc, access


def test_a_protocol_3_board_needs_its_fingerprint_and_logged_releases(tmp_path):
    (agent, a_log), (planner, p_log) = release_document("agent", AGENT), release_document("planner", PLANNER)
    log = tmp_path / "access_log.csv"
    for access in (a_log, p_log):
        protocol.append_access(log, access)
    bench = write_fakes(tmp_path / "bench", [agent, planner])
    board = lb.leaderboard([bench], reps=REPS, fingerprint=FP, access_log=log)
    assert board["protocol_version"] == PROTOCOL_VERSION and board["protocol"]["fingerprint"] == FP
    assert f"Protocol {PROTOCOL_VERSION}, fingerprint `{FP}`." in lb.markdown(board)
    # Another fingerprint: one line, the row's and the board's.
    with pytest.raises(lb.LeaderboardError, match=rf"planner/benchmark.json: fingerprint {'f0' * 6} \(yours\) / "
                                                  rf"{'0e' * 6} \(the board's\)"):
        lb.leaderboard([bench / "planner"], reps=REPS, fingerprint="0e" * 32, access_log=log)
    # A test-split run that the log does not hold (or whose line differs) is refused.
    protocol.append_access(tmp_path / "other.csv", a_log)
    with pytest.raises(lb.LeaderboardError, match=r"planner/benchmark.json: its test-split run is not in the access "
                                                  r"log \(baselines/results/access_log.csv\)"):
        lb.leaderboard([bench], reps=REPS, fingerprint=FP, access_log=tmp_path / "other.csv")
    forged, _ = release_document("forged", PLANNER)
    forged["run"]["release"]["commit"] = "b" * 40
    with pytest.raises(lb.LeaderboardError, match="not in the access log"):
        lb.leaderboard([write_fakes(tmp_path / "forged", [forged])], reps=REPS, fingerprint=FP, access_log=log)
    # --allow-mixed lifts neither.
    with pytest.raises(lb.LeaderboardError, match="not in the access log"):
        lb.leaderboard([bench], allow_mixed=True, reps=REPS, fingerprint=FP, access_log=tmp_path / "none.csv")


def test_a_board_is_of_one_protocol_and_one_split(tmp_path):
    v3, _ = release_document("agent", AGENT, split="validation")
    mixed = write_fakes(tmp_path / "mixed", [v3, document("planner", PLANNER)])
    with pytest.raises(lb.LeaderboardError, match=r"the files are of protocols 3 and 2: .*agent/benchmark.json \(3\)"):
        lb.leaderboard([mixed], allow_mixed=True, reps=REPS, fingerprint=FP)
    test_row, access = release_document("planner", PLANNER)
    protocol.append_access(tmp_path / "log.csv", access)
    splits = write_fakes(tmp_path / "splits", [v3, test_row])
    with pytest.raises(lb.LeaderboardError, match="the files mix the validation and test splits"):
        lb.leaderboard([splits], reps=REPS, fingerprint=FP, access_log=tmp_path / "log.csv")
    # Validation rows make a development board, labelled so; no access log is read.
    board = lb.leaderboard([splits / "agent"], reps=REPS, fingerprint=FP, access_log=tmp_path / "none.csv")
    assert "**Development board**: validation seeds" in lb.markdown(board)


def test_the_committed_protocol_2_board_still_builds_labelled_protocol_2():
    board = lb.leaderboard([Path(__file__).resolve().parent.parent / "baselines" / "results" / "benchmark-protocol2"],
                         reps=REPS)
    assert board["protocol_version"] == 2 and len(board["policies"]) > 20
    assert lb.markdown(board).splitlines()[2].startswith("Protocol 2 (before the fingerprint")


# ---------------------------------------------------------------- the full-body column
def _replay_table(path: Path, env: str, policy: str, outcomes: list[tuple[str, bool]], note: str = "") -> None:
    """A replay table as ``baselines/fullbody.py replay`` writes it (a summary table, then a row per episode)."""
    head = ("| env | tier | cell | policy | seed | footsteps | env_end | env_fall | op3_fell | op3_fell_at | "
            "median_foot_error_mm | min_cop_margin_mm | sim_time_s | wall_time_s |")
    rows = [f"| {env} | paper |  | {policy} | {10000 + i} | 12 | {end} |  | {fell} | {3 if fell else ''} | 1.0 | "
            f"2.0 | 9.6 | 4.0 |" for i, (end, fell) in enumerate(outcomes)]
    path.write_text(f"# {policy} on {env}\n\n{note}| env | cell | policy | episodes |\n|---|---|---|---|\n| {env} |  | {policy} | "
                    f"{len(rows)} |\n\n" + "\n".join([head, "|" + "---|" * 14, *rows]) + "\n", encoding="utf-8")


def test_the_full_body_column_from_replay_tables(tmp_path, capsys):
    """baselines/fullbody.py's tables pooled per policy over the scenes (counted by hand), written as the summary the
    leaderboard reads; the script shows it as a column of the named policies (– for the others), refuses a bad one."""
    from footstep_gym.evaluation import fullbody_column as fc

    tables = tmp_path / "fullbody"
    tables.mkdir()
    _replay_table(tables / "FootstepDoor-v0_paper_all_planner_op3.md", "FootstepDoor-v0", "planner",
                  [("goal", False), ("goal", True), ("collision", False)])
    _replay_table(tables / "FootstepCrossing-v0_paper_all_planner_op3.md", "FootstepCrossing-v0", "planner",
                  [("goal", False)])
    _replay_table(tables / "FootstepDoor-v0_paper_all_agent_op3.md", "FootstepDoor-v0", "agent", [("collision", True)],
                  "Recorded with robot 'default'; walked: the 1 of 3 episodes whose every command lies in op3's box.\n\n")
    _replay_table(tables / "FootstepDoor-v0_paper_all_agent_op3-lipm.md", "FootstepDoor-v0", "agent", [("goal", False)])
    (tables / "FootstepCrowd-v0_paper_all_fast-agent_op3.md").write_text(
        "# fast-agent on FootstepCrowd-v0 (tier paper, cell drawn), robot op3, walked on the OP3\n\nRecorded with robot "
        "'default'; walked: the 0 of 2 episodes whose every command lies in 'op3''s box, T_SS at or above its swing "
        f"floor.\n\n{fc.NO_EPISODE}\n", encoding="utf-8")
    json_path, csv_path = fc.write_summary(tables)
    summary = fc.load_summary(json_path)
    assert summary["policies"]["planner"] == {"episodes": 4, "scenes": ["FootstepCrossing-v0", "FootstepDoor-v0"],
                                              "op3_no_fall": 0.75, "env_success": 0.75,
                                              "env_success_and_op3_no_fall": 0.5}
    assert summary["policies"]["agent"]["episodes"] == 1 and summary["policies"]["agent"]["op3_no_fall"] == 0.0
    assert summary["policies"]["agent"]["not_admitted"] == 2 and "not_admitted" not in summary["policies"]["planner"]
    assert summary["policies"]["fast-agent"] == {"episodes": 0, "scenes": ["FootstepCrowd-v0"], "not_admitted": 2,
                                                 "op3_no_fall": None, "env_success": None,
                                                 "env_success_and_op3_no_fall": None}
    assert fc.cell(summary, "fast-agent") == "– (0 + 2 not admitted)" and fc.cell(summary, "nobody") is None
    csv_lines = csv_path.read_text(encoding="utf-8").splitlines()
    assert csv_lines[0] == ",".join(fc.SUMMARY_KEYS) and "fast-agent,0,FootstepCrowd-v0,,,,2" in csv_lines
    script = load_script("make_leaderboard")
    bench = write_fakes(tmp_path / "bench")
    assert script.main([str(bench), "--out", str(tmp_path / "board"), "--reps", str(REPS),
                        "--fullbody", str(json_path)]) == 0
    table = squash(capsys.readouterr().out)
    assert table[0] == "| policy | runs | paper (2 cells) | hard (3 cells) | full body (OP3, paper) |"
    cells = {line.split(" | ")[0].strip("| *"): line.split(" | ")[-1].rstrip(" |") for line in table[2:6]}
    assert cells["planner"] == "0.75 (0.75, 4)" and cells["agent"] == "0.00 (0.00, 1 + 2 not admitted)"
    assert cells["partial (partial)"] == "–"
    board = json.loads((tmp_path / "board" / "leaderboard.json").read_text(encoding="utf-8"))
    assert board["fullbody"]["policies"]["planner"]["op3_no_fall"] == 0.75
    json_path.write_text('{"fullbody": "footstep_gym", "tier": "paper", "robot": "op3", "policies": '
                         '{"x": {"episodes": 0}}}', encoding="utf-8")
    with pytest.raises(SystemExit) as exc:
        script.main([str(bench), "--out", str(tmp_path / "board2"), "--fullbody", str(json_path)])
    assert exc.value.code == 2 and "no episodes" in capsys.readouterr().err
    assert not (tmp_path / "board2").exists()
    (tables / "FootstepCrowd-v0_paper_all_fast-agent_op3.md").write_text(
        "fast-agent, crowd\n\nRecorded with robot 'default'; walked: the 0 of 2 episodes.\n", encoding="utf-8")
    with pytest.raises(fc.FullBodyError, match="first line"):
        fc.summarise(tables)


# ---------------------------------------------------------------- the compute protocol's columns
def _shipped_run(agents: Path, agent: str, name: str, timesteps: int, curve: list[float], episodes: int = 20,
                 cpu: float | None = None) -> Path:
    run = agents / agent / name
    run.mkdir(parents=True)
    (run / "manifest.json").write_text(json.dumps({"env_id": name.rsplit("_", 1)[0], "timesteps": timesteps,
                                                   "wall_time_s": 60.0 * timesteps / 1e5, "cpu_time_s": cpu}))
    (run / "validation.csv").write_text("timesteps,wall_time_s,success_rate,episodes\n" + "".join(
        f"{i},{i},{s:.4f},{episodes}\n" for i, s in enumerate(curve)))
    return run


def test_learned_rows_show_their_budget_and_converged_runs_from_the_shipped_agents(tmp_path):
    agents = tmp_path / "agents"
    # run 1 flat (19, 20, 20 of 20), run 2 still rising (10, 14, 18 of 20): 1/2 converged
    runs = [_shipped_run(agents, "agent", "FootstepDoor-v0_1", 300_000, [0.1, 0.95, 1.0, 1.0], cpu=30.0),
            _shipped_run(agents, "agent", "FootstepDoor-v0_2", 600_000, [0.5, 0.7, 0.9], cpu=50.0)]
    elsewhere = [f"/another/machine/baselines/agents/agent/{r.name}" for r in runs]
    agent = {**document("agent", AGENT), "run": {"command": "fake", "agent_runs": elsewhere}}
    at_budget = {**document("agent-noise", {k: w for k, w in AGENT.items() if k[1] != "default"}),
                 "track": "in-distribution", "trained_on_tier": "hard", "complete": True,
                 "run": {"command": "fake", "agent_runs": [str(_shipped_run(agents, "agent-noise", "FootstepDoor-v0_1",
                                                                            20_000_000, [0.9, 0.9, 0.925, 0.9],
                                                                            episodes=40)), "/gone/agent-noise/X_2"]}}
    board = lb.build([document("planner", PLANNER), agent, at_budget], reps=REPS, agents_dir=agents)
    rows = {p["policy"]: p for p in board["policies"] + board["in_distribution"]}
    assert rows["planner"]["training"] is None
    t = rows["agent"]["training"]
    assert (t["runs"], t["env_steps_per_run"], t["declared_budget"], t["at_budget"]) == (2, [300_000, 600_000],
                                                                                       20_000_000, False)
    assert (t["converged"], t["with_curve"], t["cpu_time_s"], t["missing_runs"]) == (1, 2, 80.0, [])
    table = squash(lb.training_markdown(board))
    assert table[0] == ("| policy | trained on | runs | env steps per run | declared budget | at budget | converged | "
                        "median wall s per run | CPU s (all runs) |")
    assert table[2] == "| agent | train | 2 | 3e5-6e5 | 2e7 | no | 1/2 | 360 | 80 |"
    # the in-distribution row: a tier without a declared budget (configs/compute.yaml: none for "hard"), one run gone
    assert table[3] == "| agent-noise | hard | 1 | 2e7 | – | – | 1/1 | 12,000 | – |"
    text = lb.markdown(board)
    assert "## Training budget of the learned rows" in text and "4 of 40" not in text
    assert "0.100 at 40, 0.150 at 20" in text and "not shipped here (not counted): agent-noise (1)" in text
    no_learning = lb.build([document("planner", PLANNER)], reps=REPS, agents_dir=agents)
    assert lb.training_markdown(no_learning) == "" and "Training budget" not in lb.markdown(no_learning)

def test_the_committed_full_body_summary_is_its_tables():
    """baselines/results/fullbody/fullbody_<tier>_<robot>.json (paper and train, op3 and op3-lipm) is what the committed
    replay tables pool to (re-write it with ``python baselines/fullbody.py [--robot R] summary [--tier train]``)."""
    from footstep_gym.evaluation import fullbody_column as fc

    folder = Path(__file__).resolve().parent.parent / "baselines" / "results" / "fullbody"
    for tier in ("paper", "train"):
        for robot in ("op3", "op3-lipm"):
            committed = fc.load_summary(folder / f"{fc.summary_name(tier, robot)}.json")
            assert committed["policies"] == fc.summarise(folder, tier, robot) and committed["robot"] == robot


def test_the_scores_figure_draws_each_rows_success_interval_and_safe_success():
    """Protocol 3's figure: a panel per tier, a bar per row that covers the tier as long as its scene-balanced
    success, the whisker its hierarchical interval, the circle its safe success; rows in rank order, the privileged
    last and starred; a partial row has no bar on the tier it does not cover. No such figure before protocol 3."""
    docs = [{**d, "protocol_version": PROTOCOL_VERSION} for d in fakes()]
    board = lb.build(docs, reps=REPS)
    fig = lb.scores_figure(board)
    assert fig is not None
    axes = fig.axes
    assert [ax.get_title().split(" (")[0] for ax in axes] == board["tiers"]
    labels = [t.get_text() for t in axes[0].get_yticklabels()]
    ranked = [r["policy"] for r in board["scores"]["ranking"]]
    assert labels[:len(ranked)] == ranked and labels[-1] == "oracle (upper bound) *"
    by = {(r["policy"], r["tier"]): r for r in board["scores"]["tiers"]}
    names = {label: p["policy"] for p in board["policies"] for label in (p["label"], p["label"] + " *")}
    for ax, tier in zip(axes, board["tiers"]):
        drawn = {round(bar.get_y() + bar.get_height() / 2): bar.get_width() for bar in ax.patches}
        want = {y: by[(names[label], tier)]["success"] for y, label in enumerate(labels) if (names[label], tier) in by}
        assert drawn.keys() == want.keys() and all(abs(drawn[y] - want[y]) < 1e-12 for y in want), tier
        circles = {round(line.get_ydata()[0]): line.get_xdata()[0] for line in ax.get_lines()
                   if line.get_marker() == "o"}
        assert circles == {y: by[(names[labels[y]], tier)]["safe_success"] for y in want}
        whiskers = {round(line.get_ydata()[0]): list(line.get_xdata()) for line in ax.get_lines()
                    if line.get_marker() in ("None", "", None) and len(line.get_xdata()) == 2}
        assert whiskers == {y: list(by[(names[labels[y]], tier)]["success_ci95"]) for y in want}
    assert ("partial", "hard") not in by and lb.scores_figure(lb.build(fakes(), reps=REPS)) is None
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_the_readme_and_results_doc_show_a_protocol_3_board_by_its_scores(tmp_path, monkeypatch):
    """docs/results.md and the README read the shown board: on a protocol-3 board its scene-balanced table (the
    README's rows without P(> next), which is over the whole board's next row) and the best null baseline."""
    from footstep_gym.evaluation import results_doc

    nulls = {"null-stand": {key: [0] for key in PLANNER}, "null-random": {key: [1] for key in PLANNER},
             "null-mine": {key: [2] for key in PLANNER}}  # not a registered null baseline: a name is not the family
    docs = [{**d, "protocol_version": PROTOCOL_VERSION} for d in (
        document("planner", PLANNER), document("agent", AGENT), document("oracle", ORACLE, upper_bound=True),
        *(document(name, wins) for name, wins in nulls.items()))]
    board = lb.build(docs, reps=REPS)
    folder = tmp_path / SHOWN_BOARD_DIR
    folder.mkdir(parents=True)
    (folder / "leaderboard.json").write_text(json.dumps(board), encoding="utf-8")
    (folder / "leaderboard.md").write_text(lb.markdown(board), encoding="utf-8")
    monkeypatch.setattr(results_doc, "HEADLINE_POLICIES_P3", ("planner", "oracle"))
    assert results_doc.headline_policies(board) == ("planner", "oracle", "null-random")  # outscores null-stand
    table = squash(results_doc.leaderboard_headline(tmp_path))
    assert table[0].startswith("| policy | paper (not ranked) | hard | score | safe score |")
    assert "P(> next)" not in table[0] and len(table) == 5  # head, rule, planner, null-random, oracle
    assert [line.split("|")[1].strip() for line in table[2:]] == ["planner", "null-random", "*oracle (upper bound)*"]
    assert results_doc.leaderboard_block(tmp_path).startswith(lb.scores_markdown(board).split("\n")[0])
    # docs/results.md shows the scores figure first where the board has one, then protocol 2's IQM figure
    shown = SHOWN_BOARD_DIR.as_posix()
    iqm = f"![IQM success per tier](../{shown}/{lb.FIGURE_IQM})"
    assert lb.FIGURE_SCORES not in "\n".join(results_doc._board_figures(tmp_path, shown))
    lb.write_figures(board, folder)
    section = "\n".join(results_doc._board_figures(tmp_path, shown))
    scored = f"![Scene-balanced success per tier](../{shown}/{lb.FIGURE_SCORES})"
    assert scored in section and iqm in section and section.index(scored) < section.index(iqm)
    monkeypatch.setattr(results_doc, "HEADLINE_POLICIES_P3", ("planner", "no-such-row"))
    with pytest.raises(ValueError, match="no row for no-such-row"):
        results_doc.leaderboard_headline(tmp_path)
