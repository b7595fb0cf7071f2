"""The protocol-3 board's plan (footstep_gym.evaluation.board) and its command line (baselines/run_board.py):
rows from configs/board.yaml, each made once per fingerprint, refusals before anything runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from script_helpers import load_script

from footstep_gym.errors import ConfigError
from footstep_gym.evaluation import board
from footstep_gym.evaluation import protocol
from footstep_gym.evaluation.splits import PROTOCOL_VERSION
from footstep_gym.registry import resolve

FP = "f" * 64
OTHER = "0" * 64


def _access(method: str, fp: str = FP, date: str = "2026-11-28T08:00:00Z") -> protocol.Access:
    return protocol.Access(date, "abc123", method, 22, 100, fp)


def _row(folder: Path, fp: str = FP, release: protocol.Access | None = None, version: int = PROTOCOL_VERSION) -> None:
    folder.mkdir(parents=True)
    run = {"release": release.to_dict()} if release is not None else {}
    doc = {"protocol_version": version, "protocol": {"fingerprint": fp, "split": "test"}, "run": run}
    (folder / "benchmark.json").write_text(json.dumps(doc), encoding="utf-8")


def test_the_shipped_rows_are_registered_and_hold_both_privileged_and_the_new_baselines():
    rows = board.load_rows()
    assert len(rows) == len(set(rows))
    for name in rows:
        resolve(name)  # raises for an unknown name
    for name in ("oracle", "oracle-lookahead", "wait-until-clear", "straight-stop", "orca-robot", "dwa",
                 "ppo-jax-2e7", "ppo-jax-2e7-structure", "ppo-jax-2e7-noise", "ppo-jax-gru-noise"):
        assert name in rows
    assert "paper-period-aware" not in rows  # the reproduction's settings are reported, not ranked
    # every learned row has a shipped run on every scene (a release row covers every cell; a door study does not)
    assert board.missing_runs(rows) == {}


def test_missing_runs_names_the_scenes_a_learned_row_lacks(tmp_path):
    assert board.missing_runs(["sac-sb3", "td3-b2048", "lookahead", "ppo"]) == {
        "sac-sb3": ["crossing", "crowd"], "td3-b2048": ["crossing", "crowd"]}  # door-only studies; planners need none
    (tmp_path / "ppo" / "FootstepDoor-v0_1").mkdir(parents=True)
    (tmp_path / "ppo" / "FootstepDoor-v0_1" / "FootstepDoor-v0.zip").write_bytes(b"")
    assert board.missing_runs(["ppo", "dwa"], agents_dir=tmp_path) == {"ppo": ["crossing", "crowd"]}


@pytest.mark.parametrize("text, words", [
    ("rows: []\n", "non-empty list"),
    ("rows: lookahead\n", "non-empty list"),
    ("rows: [lookahead, dwa, lookahead]\n", "lookahead more than once"),
    ("rows: [lookahead, no-such-planner]\n", "no-such-planner: not a registered"),
])
def test_a_bad_row_list_is_one_line_naming_what_is_wrong(tmp_path, text, words):
    path = tmp_path / "board.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match=words):
        board.load_rows(path)


def test_plan_says_made_failed_or_due_from_the_log_and_the_folder(tmp_path):
    made, failed, stale = _access("lookahead"), _access("dwa"), _access("oracle", fp=OTHER)
    _row(tmp_path / "lookahead", release=made)
    _row(tmp_path / "oracle", fp=OTHER, release=stale)  # a row of another fingerprint is not this board's
    log = [made, failed, stale]
    states = {s.method: s for s in board.plan(["lookahead", "dwa", "lattice", "oracle"], tmp_path, log, FP)}
    assert states["lookahead"].state == "made" and states["lookahead"].accesses == (made,)
    assert states["dwa"].state == "failed" and states["dwa"].accesses == (failed,)
    assert states["lattice"].state == "due" and states["lattice"].accesses == ()
    assert states["oracle"].state == "due"
    # a row whose release is not the log's line (e.g. copied from elsewhere) is not made
    _row(tmp_path / "lattice", release=_access("lattice", date="2026-01-01T00:00:00Z"))
    assert board.plan(["lattice"], tmp_path, log, FP)[0].state == "due"


def test_foreign_rows_are_those_of_another_version_or_fingerprint(tmp_path):
    _row(tmp_path / "mine", release=_access("mine"))
    _row(tmp_path / "old", version=PROTOCOL_VERSION - 1)
    _row(tmp_path / "other", fp=OTHER)
    (tmp_path / "empty").mkdir()
    assert [p.name for p in board.foreign_rows(tmp_path, FP)] == ["old", "other"]
    assert board.foreign_rows(tmp_path / "absent", FP) == []


def test_release_argv_is_a_whole_release_row():
    argv = board.release_argv("dwa", Path("out/dwa"), workers=2)
    assert argv == ["--benchmark", "--release", "--policy", "dwa", "--out", "out/dwa", "--workers", "2"]
    with pytest.raises(ValueError, match="workers"):
        board.release_argv("dwa", Path("x"), workers=0)


def test_the_command_prints_the_plan_and_refuses_before_running(tmp_path, capsys, monkeypatch):
    log = tmp_path / "access_log.csv"  # the repository's log is not read: every row is due here
    monkeypatch.setattr(protocol, "access_log_path", lambda root=None: log)
    script = load_script("run_board")
    assert script.main(["--out-root", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "fingerprint" in out and "oracle-lookahead" in out
    with pytest.raises(SystemExit) as exc:
        script.main(["--run", "--only", "no-such-row", "--out-root", str(tmp_path)])
    assert exc.value.code == 2
    assert "no-such-row: not a row of the board" in capsys.readouterr().err
    _row(tmp_path / "ppo", version=PROTOCOL_VERSION - 1)  # protocol 2's rows in the board's folder
    with pytest.raises(SystemExit) as exc:
        script.main(["--run", "--only", "dwa", "--out-root", str(tmp_path)])
    assert exc.value.code == 2
    assert "another protocol or fingerprint" in capsys.readouterr().err
    assert not (tmp_path / "dwa").exists()
    (tmp_path / "ppo" / "benchmark.json").unlink()
    protocol.append_access(log, _access("lookahead", fp=protocol.fingerprint()))
    assert script.main(["--out-root", str(tmp_path)]) == 0
    assert "failed  lookahead  (logged 2026-11-28T08:00:00Z)" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        script.main(["--run", "--retry", "dwa", "--out-root", str(tmp_path)])
    assert exc.value.code == 2
    assert "not a failed row" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        script.main(["--workers", "0"])
    rows = tmp_path / "rows.yaml"  # a door-only agent: shown in the plan, refused before anything runs or is logged
    rows.write_text("rows: [sac-sb3, dwa]\n", encoding="utf-8")
    assert script.main(["--rows", str(rows), "--out-root", str(tmp_path)]) == 0
    assert "sac-sb3  (no shipped run for crossing, crowd: cannot be a row)" in capsys.readouterr().out
    before = log.read_text(encoding="utf-8")
    with pytest.raises(SystemExit) as exc:
        script.main(["--run", "--rows", str(rows), "--out-root", str(tmp_path)])
    assert exc.value.code == 2
    assert "no shipped training run for sac-sb3 on crossing, crowd" in capsys.readouterr().err
    assert log.read_text(encoding="utf-8") == before and not (tmp_path / "sac-sb3").exists()
