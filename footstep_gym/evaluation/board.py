"""The protocol-3 board's release runs: which methods make the board and which of their rows are made.

* :func:`load_rows`: the board's methods, in run order (``configs/board.yaml``, validated: registered names, none
  twice);
* :func:`plan`: each method's :class:`RowState` under the present fingerprint, read from the access log and the
  board's folder: ``made`` (its folder holds a test-split row whose ``run.release`` is a line of the log under the
  fingerprint), ``failed`` (the log holds a line of the method under the fingerprint that no row carries: the run
  failed or was stopped after it was logged; running it again logs it again) or ``due`` (no line);
* :func:`foreign_rows`: rows in the board's folder of another protocol version or fingerprint, which a board of one
  fingerprint cannot hold (:func:`footstep_gym.evaluation.leaderboard.check_rows` refuses the mix);
* :func:`missing_runs`: the learned rows that cannot be made, the scenes a registered agent has no shipped training
  run for (a release row covers every scene);
* :func:`release_argv`: the ``eval_planner.py --benchmark --release`` command of one row.

A row is run once per fingerprint: a ``made`` row is never run again, so the test split is touched once per method
however many sessions the board takes. ``baselines/run_board.py`` is the command line.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Sequence

from footstep_gym.errors import ConfigError
from footstep_gym.evaluation import protocol as row_protocol
from footstep_gym.evaluation.splits import PROTOCOL_VERSION  # the version the board's rows are of

#: The board's rows (relative to configs/).
BOARD_CONFIG = "board.yaml"
#: Where the board's rows and leaderboard are written (``baselines/run_board.py``, ``baselines/make_leaderboard.py``),
#: relative to the repository.
BOARD_DIR = Path("baselines") / "results" / "benchmark"
#: The board the README, docs/results.md and the site show, relative to the repository: the last board made
#: (protocol 3's; protocol 2's is kept in ``baselines/results/benchmark-protocol2``).
SHOWN_BOARD_DIR = BOARD_DIR

State = Literal["made", "failed", "due"]


@dataclass(frozen=True)
class RowState:
    """One method of the board: ``state`` (``made``, ``failed`` or ``due``), its folder, and the access log's lines
    of it under the fingerprint (oldest first)."""

    method: str
    state: State
    folder: Path
    accesses: tuple[row_protocol.Access, ...] = ()


def load_rows(path: str | Path | None = None) -> tuple[str, ...]:
    """The board's methods in run order, from ``path`` (default ``configs/board.yaml``).

    Raises:
        ConfigError: (one line) ``rows`` missing or not a list of names, a name given twice, or a name that is not
            a registered policy or variant (:func:`footstep_gym.registry.resolve`).
    """
    from footstep_gym.config import read_yaml
    from footstep_gym.registry import resolve

    where = str(path) if path is not None else f"configs/{BOARD_CONFIG}"
    data = read_yaml(str(path) if path is not None else BOARD_CONFIG)
    rows = data.get("rows")
    if not isinstance(rows, list) or not rows or not all(isinstance(r, str) and r for r in rows):
        raise ConfigError(f"{where}: rows must be a non-empty list of method names, got {rows!r}")
    twice = sorted({r for r in rows if rows.count(r) > 1})
    if twice:
        raise ConfigError(f"{where}: rows names {', '.join(twice)} more than once")
    unknown = []
    for name in rows:
        try:
            resolve(name)
        except ValueError:
            unknown.append(name)
    if unknown:
        raise ConfigError(f"{where}: rows names {', '.join(unknown)}: not a registered policy or variant "
                          "(footstep_gym.registry.policy_names())")
    return tuple(rows)


def _row(folder: Path) -> dict[str, Any] | None:
    """The ``benchmark.json`` in ``folder`` as a dict, or None when there is none or it is not JSON."""
    try:
        doc = json.loads((folder / "benchmark.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return doc if isinstance(doc, dict) else None


def plan(methods: Sequence[str], out_root: Path, log: Sequence[row_protocol.Access],
         fingerprint: str) -> list[RowState]:
    """The :class:`RowState` of each of ``methods``, whose rows live in ``out_root/<method>/``, given the access
    log's lines ``log`` and the board's ``fingerprint``."""
    states = []
    for method in methods:
        folder = out_root / method
        mine = tuple(a for a in log if a.method == method and a.fingerprint == fingerprint)
        doc = _row(folder)
        release = ((doc or {}).get("run") or {}).get("release")
        made = (doc is not None and doc.get("protocol_version") == PROTOCOL_VERSION
                and (doc.get("protocol") or {}).get("fingerprint") == fingerprint
                and row_protocol.logged(release, mine))
        state: State = "made" if made else ("failed" if mine else "due")
        states.append(RowState(method, state, folder, mine))
    return states


def foreign_rows(out_root: Path, fingerprint: str) -> list[Path]:
    """The folders under ``out_root`` holding a ``benchmark.json`` of another protocol version or fingerprint."""
    if not out_root.is_dir():
        return []
    foreign = []
    for folder in sorted(p for p in out_root.iterdir() if p.is_dir()):
        doc = _row(folder)
        if doc is None:
            continue
        if (doc.get("protocol_version") != PROTOCOL_VERSION
                or (doc.get("protocol") or {}).get("fingerprint") != fingerprint):
            foreign.append(folder)
    return foreign


def missing_runs(methods: Sequence[str], agents_dir: str | Path | None = None) -> dict[str, list[str]]:
    """Per method of ``methods`` that is a registered agent, the benchmark's scenes it has no shipped training run for
    in ``agents_dir`` (default: the shipped agents folder); methods with every scene are left out. A release row
    covers every cell, so ``eval_planner.py --release`` refuses such a method (a partial run is no row)."""
    from footstep_gym.evaluation.benchmark import benchmark_cells
    from footstep_gym.rl.registry import AGENTS, agent_runs

    scenes = list(dict.fromkeys(c.scene for c in benchmark_cells()))
    missing = {}
    for method in methods:
        if method in AGENTS:
            lacking = [s for s in scenes if not agent_runs(method, s, agents_dir)]
            if lacking:
                missing[method] = lacking
    return missing


def release_argv(method: str, folder: Path, workers: int = 1) -> list[str]:
    """The arguments of ``baselines/eval_planner.py`` that make ``method``'s board row in ``folder``."""
    if workers < 1:
        raise ValueError(f"release_argv: workers must be >= 1, got {workers!r}")
    return ["--benchmark", "--release", "--policy", method, "--out", str(folder), "--workers", str(workers)]


__all__ = ["BOARD_CONFIG", "BOARD_DIR", "SHOWN_BOARD_DIR", "RowState", "foreign_rows", "load_rows", "missing_runs",
           "plan", "release_argv"]
