"""What makes two benchmark rows comparable: the protocol fingerprint, committed code, the test split's access log.

* :func:`fingerprint`: one SHA-256 over what decides an episode: the env configs (their YAML as loaded,
  :func:`footstep_gym.evaluation.benchmark.env_config_files`) and the source of the simulator's modules
  (:data:`SIMULATOR_SOURCES`, every registered scenario's own module among them). Each source file enters by its
  path relative to the package's parent and its bytes with line ends made ``\\n``, so a checkout on any machine
  (any folder, any ``core.autocrlf``) gives the same fingerprint, and a changed line of physics another;
* :func:`tree_state`: the commit of the repository and its files that differ from it (``git status``; outputs
  under :data:`OUTPUT_DIRS` do not count), :func:`dirty_refusal` the one line that refuses a release run from
  such a tree;
* :func:`repo_path` and :func:`repo_command`: paths as the row records them, relative to the repository;
* the access log (:data:`ACCESS_LOG`, a CSV committed beside the rows): :func:`append_access` writes one line
  per release run (date, commit, method, cells, fingerprint) before it runs an episode;
  :func:`logged` says whether a row's release is in it.
"""

from __future__ import annotations

import csv
import datetime as _dt
import hashlib
import inspect
import io
import json
import shlex
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import footstep_gym
from footstep_gym.evaluation.splits import TEST as TEST_SPLIT  # the board's split, run only by a release

#: The package's folder and the repository's (its parent, in a checkout).
PACKAGE = Path(footstep_gym.__file__).resolve().parent
#: The simulator's sources, relative to the package folder: a file, or a folder (its ``*.py``, recursively).
#: The env and its config, the world (collisions), the scenarios and the scene layer, sensing, the LIPM, the
#: footstep placement, the tiers (cells), the observation and the action, the robot, the geometry and the
#: compiled kernels behind them; and the JAX env and scenes, where rows are trained. One fingerprint covers both
#: engines, so a row trained in JAX and one evaluated in numpy are checked against the same simulator.
SIMULATOR_SOURCES = ("env.py", "env_config.py", "world.py", "scenarios", "scenes", "sensing.py", "lipm.py",
                     "footstep.py", "tiers.py", "observation.py", "action.py", "robot.py", "geometry.py", "kernels",
                     "jax/env.py", "jax/scenes.py", "jax/sensing.py", "jax/shapes.py", "jax/walker.py")
#: Repository folders of outputs: their changes do not make a tree dirty (a release writes its row there).
OUTPUT_DIRS = ("baselines/results/",)
#: The access log of the test split, relative to the repository.
ACCESS_LOG = "baselines/results/access_log.csv"
ACCESS_FIELDS = ("date", "commit", "method", "cells", "episodes_per_cell", "fingerprint")


def simulator_files() -> list[Path]:
    """The files of :data:`SIMULATOR_SOURCES` (folders expanded to their ``*.py``, sorted), then the module of every
    registered scenario that lives outside them (a plugin's), without repeats."""
    files: list[Path] = []
    for name in SIMULATOR_SOURCES:
        path = PACKAGE / name
        if path.is_dir():
            files += sorted(path.rglob("*.py"))
        elif path.is_file():
            files.append(path)
    from footstep_gym.scenarios import SCENARIOS

    for cls in SCENARIOS.values():
        source = inspect.getsourcefile(cls)
        if source:
            files.append(Path(source).resolve())
    return list(dict.fromkeys(files))


def _source_key(path: Path) -> str:
    """A source file's name in the fingerprint: relative to the package's parent (``footstep_gym/env.py``), or its
    file name for a plugin's module outside it."""
    try:
        return path.relative_to(PACKAGE.parent).as_posix()
    except ValueError:
        return path.name


def fingerprint() -> str:
    """The protocol fingerprint: a SHA-256 (hex) over the env configs' content and the simulator's source
    (:func:`simulator_files`), each entry its name, a NUL, its content, a NUL, in a fixed order."""
    from footstep_gym.config import read_yaml
    from footstep_gym.evaluation.benchmark import env_config_files

    digest = hashlib.sha256()
    for name in env_config_files():
        content = json.dumps(read_yaml(name), separators=(",", ":"))
        digest.update(b"config:" + name.encode() + b"\0" + content.encode() + b"\0")
    for path in simulator_files():
        text = path.read_bytes().replace(b"\r\n", b"\n")
        digest.update(b"source:" + _source_key(path).encode() + b"\0" + text + b"\0")
    return digest.hexdigest()


# ---------------------------------------------------------------- the repository
def repo_root(start: Path = PACKAGE) -> Path | None:
    """The git work tree holding ``start`` (None outside one, or without git)."""
    try:
        out = subprocess.run(["git", "rev-parse", "--show-toplevel"], cwd=start, capture_output=True, text=True,
                             timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return Path(out.stdout.strip()).resolve() if out.returncode == 0 and out.stdout.strip() else None


@dataclass(frozen=True)
class TreeState:
    """A checkout: its ``commit`` (None outside git) and ``dirty``, the paths that differ from it (modified,
    added, deleted or untracked files, outputs under :data:`OUTPUT_DIRS` left out)."""

    commit: str | None
    dirty: tuple[str, ...]


def tree_state(root: Path | None = None) -> TreeState:
    """The :class:`TreeState` of the repository at ``root`` (default: the package's)."""
    root = root if root is not None else repo_root()
    if root is None:
        return TreeState(None, ())
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10)
        status = subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=root,
                                capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return TreeState(None, ())
    if head.returncode != 0 or status.returncode != 0:
        return TreeState(None, ())
    paths = [line[3:].split(" -> ")[-1].strip('"') for line in status.stdout.splitlines() if len(line) > 3]
    return TreeState(head.stdout.strip(), tuple(p for p in paths if not p.startswith(OUTPUT_DIRS)))


def dirty_refusal(state: TreeState) -> str | None:
    """The one line that refuses a release run from ``state``, or None when it is committed code."""
    if state.commit is None:
        return "--release runs from a git checkout of footstep_gym (no commit found): a board row is committed code"
    if state.dirty:
        n = len(state.dirty)
        return (f"--release needs committed code: {n} file{'s' if n != 1 else ''} differ{'s' if n == 1 else ''} "
                f"from commit {state.commit[:12]} (git status); commit or drop them")
    return None


def repo_path(path: str | Path, root: Path | None = None) -> str:
    """``path`` as a row records it: relative to the repository (``root``, default the package's) when inside it,
    else ``<outside>/NAME`` (the machine's own folders are no part of a row)."""
    root = root if root is not None else repo_root()
    p = Path(path)
    resolved = p.resolve() if p.is_absolute() or p.exists() else (Path.cwd() / p).resolve()
    if root is not None:
        try:
            return resolved.relative_to(root).as_posix() or "."
        except ValueError:
            pass
    return f"<outside>/{resolved.name}"


def _looks_like_path(token: str) -> bool:
    return "/" in token or token.endswith((".zip", ".pkl", ".json", ".py"))


def repo_command(argv: Sequence[str], root: Path | None = None, script: str = "baselines/eval_planner.py") -> str:
    """The command of a run with ``argv`` whose paths (``PATH``, ``SCENE=PATH``, ``--opt=PATH``) are
    :func:`repo_path`'s; a ``module:attr`` or an option stays as given."""
    root = root if root is not None else repo_root()
    out = []
    for token in argv:
        head, sep, value = token.rpartition("=") if "=" in token else ("", "", token)
        if not value.startswith("-") and _looks_like_path(value):
            value = repo_path(value, root)
        out.append(head + sep + value)
    return "python " + " ".join(shlex.quote(a) for a in [script, *out])


# ---------------------------------------------------------------- the access log
def access_log_path(root: Path | None = None) -> Path:
    """The access log of the repository at ``root`` (default the package's; the working directory outside git)."""
    root = root if root is not None else repo_root()
    return (root if root is not None else Path.cwd()) / ACCESS_LOG


@dataclass(frozen=True)
class Access:
    """One release run of the test split: when (UTC, ISO 8601 to the second), from which commit, which method, how
    many cells, episodes per cell and under which :func:`fingerprint`."""

    date: str
    commit: str
    method: str
    cells: int
    episodes_per_cell: int
    fingerprint: str

    def to_dict(self) -> dict[str, Any]:
        return {"date": self.date, "commit": self.commit, "method": self.method, "cells": self.cells,
                "episodes_per_cell": self.episodes_per_cell, "fingerprint": self.fingerprint}


def new_access(commit: str, method: str, cells: int, episodes_per_cell: int, fp: str,
               now: _dt.datetime | None = None) -> Access:
    """The :class:`Access` of a release run starting ``now`` (default: the present, UTC)."""
    now = now or _dt.datetime.now(_dt.timezone.utc)
    return Access(now.strftime("%Y-%m-%dT%H:%M:%SZ"), commit, method, cells, episodes_per_cell, fp)


def read_access_log(path: Path) -> list[Access]:
    """The accesses of the log at ``path`` (none when it does not exist); ``ValueError`` (one line) for a file
    that is not such a log."""
    if not path.is_file():
        return []
    rows = list(csv.DictReader(io.StringIO(path.read_text(encoding="utf-8"))))
    try:
        return [Access(r["date"], r["commit"], r["method"], int(r["cells"]), int(r["episodes_per_cell"]),
                       r["fingerprint"]) for r in rows]
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{path}: not an access log (columns {', '.join(ACCESS_FIELDS)})") from None


def append_access(path: Path, access: Access) -> None:
    """Append ``access`` to the log at ``path`` (its header first when the file is new)."""
    new = not path.is_file() or path.stat().st_size == 0
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", encoding="utf-8", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=ACCESS_FIELDS, lineterminator="\n")
        if new:
            writer.writeheader()
        writer.writerow(access.to_dict())


def logged(release: Mapping[str, Any] | None, log: Sequence[Access]) -> bool:
    """Whether a row's ``release`` (its ``run.release``, an :class:`Access` as a dict) is a line of ``log``."""
    if not isinstance(release, Mapping):
        return False
    try:
        mine = Access(**{k: release[k] for k in ACCESS_FIELDS})
    except (KeyError, TypeError):
        return False
    return mine in log


__all__ = ["ACCESS_FIELDS", "ACCESS_LOG", "Access", "OUTPUT_DIRS", "SIMULATOR_SOURCES", "TEST_SPLIT", "TreeState",
           "access_log_path", "append_access", "dirty_refusal", "fingerprint", "logged", "new_access",
           "read_access_log", "repo_command", "repo_path", "repo_root", "simulator_files", "tree_state"]
