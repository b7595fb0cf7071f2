"""Rows that can be compared (docs/benchmark.md §5): the protocol fingerprint, committed code for a release, paths
relative to the repository, the access log of the test split.

The fingerprint is recomputed in a fresh interpreter from a copy of the package and the configs in another folder
(the same), with a source file's line ends made CRLF (the same) and with one line of the LIPM changed (another). The
tree's state is read from a throwaway git repository.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from footstep_gym.evaluation import benchmark, protocol
from footstep_gym.evaluation.profiles import OptionError
from footstep_gym.evaluation.splits import SPLITS

REPO = Path(__file__).resolve().parent.parent


def _fingerprint_of(root: Path) -> str:
    """The fingerprint a checkout at ``root`` computes, in a fresh interpreter."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    env.pop("FOOTSTEP_GYM_CONFIG_DIR", None)
    out = subprocess.run([sys.executable, "-c", "from footstep_gym.evaluation import protocol; "
                          "print(protocol.fingerprint())"], cwd=root, env=env, capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip()


def test_the_fingerprint_is_of_the_content_not_of_the_checkout(tmp_path):
    here = protocol.fingerprint()
    assert len(here) == 64 and here == protocol.fingerprint()
    copy = tmp_path / "elsewhere"
    shutil.copytree(REPO / "footstep_gym", copy / "footstep_gym", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(REPO / "configs", copy / "configs")
    world = copy / "footstep_gym" / "world.py"
    world.write_bytes(world.read_bytes().replace(b"\n", b"\r\n"))  # a checkout with core.autocrlf
    assert _fingerprint_of(copy) == here
    lipm = copy / "footstep_gym" / "lipm.py"
    lipm.write_text(lipm.read_text(encoding="utf-8") + "\n# a changed line of the simulator\n", encoding="utf-8")
    assert _fingerprint_of(copy) != here


def test_the_fingerprint_covers_the_simulators_modules():
    names = {p.relative_to(protocol.PACKAGE).as_posix() for p in protocol.simulator_files()}
    for module in ("env.py", "world.py", "sensing.py", "lipm.py", "footstep.py", "tiers.py", "observation.py",
                   "action.py", "scenarios/door.py", "scenarios/crowd.py", "scenes/__init__.py", "jax/scenes.py"):
        assert module in names
    assert not any(n.startswith(("planners/", "rl/", "evaluation/")) for n in names)  # methods are not the protocol


def _git(root: Path, *args: str) -> None:
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=root, check=True,
                   capture_output=True)


def test_a_release_is_refused_from_uncommitted_code(tmp_path):
    root = tmp_path / "repo"
    (root / "footstep_gym").mkdir(parents=True)
    (root / "footstep_gym" / "env.py").write_text("x = 1\n")
    _git(root, "init", "-q")
    _git(root, "add", ".")
    _git(root, "commit", "-qm", "first")
    clean = protocol.tree_state(root)
    assert clean.commit and len(clean.commit) == 40 and clean.dirty == ()
    assert protocol.dirty_refusal(clean) is None
    (root / "baselines" / "results").mkdir(parents=True)
    (root / "baselines" / "results" / "access_log.csv").write_text("")  # outputs do not count
    # A row records the commit it ran from by the same rule: the rows already made (untracked) and the committed
    # access log a release appends to (modified) leave it clean; uncommitted code marks it +dirty.
    assert benchmark.source_commit(root) == clean.commit
    _git(root, "add", "baselines/results/access_log.csv")
    _git(root, "commit", "-qm", "the log")
    clean = protocol.tree_state(root)
    (root / "baselines" / "results" / "access_log.csv").write_text("a line\n")
    (root / "baselines" / "results" / "dwa").mkdir()
    (root / "baselines" / "results" / "dwa" / "benchmark.json").write_text("{}")
    assert protocol.tree_state(root).dirty == () and benchmark.source_commit(root) == clean.commit
    (root / "footstep_gym" / "env.py").write_text("x = 2\n")
    (root / "mine.py").write_text("")  # untracked code counts
    dirty = protocol.tree_state(root)
    assert sorted(dirty.dirty) == ["footstep_gym/env.py", "mine.py"]
    assert benchmark.source_commit(root) == clean.commit + "+dirty"
    assert protocol.dirty_refusal(dirty) == (f"--release needs committed code: 2 files differ from commit "
                                             f"{clean.commit[:12]} (git status); commit or drop them")
    assert "no commit found" in protocol.dirty_refusal(protocol.TreeState(None, ()))


def _settings(**kw):
    return benchmark.benchmark_settings(policies=["null-stand"], agents=None, name=None, episodes=None,
                                        envs=None, tiers=None, out=Path("x"), workers=1, backend="local",
                                        ray_address=None, agents_dir=None, **kw)


def test_release_settings_take_the_test_split_only_from_a_clean_tree(monkeypatch):
    monkeypatch.setattr(protocol, "tree_state", lambda root=None: protocol.TreeState("c" * 40, ("a.py", "b.py")))
    with pytest.raises(OptionError, match=r"^--release needs committed code: 2 files differ from commit cccccccccccc"):
        _settings(release=True)
    monkeypatch.setattr(protocol, "tree_state", lambda root=None: protocol.TreeState("c" * 40, ()))
    settings = _settings(release=True)  # nothing is run: the settings only
    first = SPLITS["test"][0]
    assert settings.release and settings.split == "test"
    assert benchmark.seeds(settings.episodes, settings.split, settings.release)[:2] == [first, first + 1]
    development = _settings()
    assert not development.release and development.split == "validation"
    assert benchmark.seeds(3) == [SPLITS["validation"][0] + k for k in range(3)]
    with pytest.raises(ValueError, match="runs only as eval_planner.py --benchmark --release"):
        benchmark.split_seeds("test", 3)


def test_the_access_log_holds_each_release_once(tmp_path):
    log = tmp_path / "results" / "access_log.csv"
    a = protocol.new_access("c" * 40, "lookahead", 22, 100, "f" * 64)
    b = protocol.new_access("d" * 40, "oracle", 22, 100, "f" * 64)
    protocol.append_access(log, a)
    protocol.append_access(log, b)
    assert log.read_text().splitlines()[0] == ",".join(protocol.ACCESS_FIELDS)
    assert protocol.read_access_log(log) == [a, b]
    assert protocol.logged(a.to_dict(), protocol.read_access_log(log))
    assert not protocol.logged({**a.to_dict(), "cells": 21}, [a, b]) and not protocol.logged(None, [a, b])
    (tmp_path / "bad.csv").write_text("x,y\n1,2\n")
    with pytest.raises(ValueError, match="not an access log"):
        protocol.read_access_log(tmp_path / "bad.csv")


def test_rows_record_paths_relative_to_the_repository(tmp_path):
    root = REPO
    assert protocol.repo_path(REPO / "baselines" / "agents" / "ppo", root) == "baselines/agents/ppo"
    assert protocol.repo_path(tmp_path / "board" / "ppo", root) == "<outside>/ppo"
    command = protocol.repo_command(["--benchmark", "--policy", "my_mod:Mine", "--agent",
                                     f"door={REPO}/runs/a.zip", "--out", str(tmp_path / "bench")], root)
    assert command == ("python baselines/eval_planner.py --benchmark --policy my_mod:Mine --agent door=runs/a.zip "
                       "--out '<outside>/bench'")
