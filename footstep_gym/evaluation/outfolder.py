"""The output folder of a run: checked before anything runs, written only once the run has finished.

A run writes into a new temporary folder beside ``--out`` (:func:`new_run_folder`) and moves into
place only once it has finished (:func:`commit_out`): a run that fails or is interrupted leaves
``--out`` as it was (:func:`run_into`). ``--out`` must be a folder of its own (:func:`check_out`):
an earlier run's files there (:data:`OWN_FILES`, :data:`OWN_DIRS`) are replaced, anything else a
user put there is kept, and a folder holding anything else but no earlier run is refused.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import traceback
from pathlib import Path
from typing import Callable

from footstep_gym.errors import FootstepGymError

OWN_FILES = ("results.json", "results.csv", "episodes.csv", "summary.md", "run.json", "benchmark.json", "benchmark.md")
OWN_DIRS = ("figures", "tables", "videos", "runs")


def check_out(out: Path) -> str | None:
    """Why ``out`` cannot take this run's files (one line), or None: it must be a folder that
    is empty or holds an earlier evaluation (its ``run.json``). Nothing is written."""
    if out.exists() and not out.is_dir():
        return f"--out {out} is a file, not a folder"
    if out.is_dir() and any(out.iterdir()) and not (out / "run.json").is_file():
        return f"--out {out} is not empty and holds no earlier evaluation (run.json); choose another folder"
    return None


def new_run_folder(out: Path) -> Path:
    """An empty folder beside ``out`` (same file system) for this run's files until it has finished."""
    out = out.absolute()
    out.parent.mkdir(parents=True, exist_ok=True)
    folder = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".partial", dir=out.parent))
    umask = os.umask(0)
    os.umask(umask)
    folder.chmod(0o777 & ~umask)  # as a folder made by mkdir (mkdtemp makes it private)
    return folder


def commit_out(run: Path, out: Path) -> None:
    """Put a finished run's folder in place as ``out``.

    An earlier run's files in ``out`` (``OWN_FILES``, ``OWN_DIRS``) are replaced by the new
    ones and anything else a user put there is kept. ``out`` is moved aside and ``run``
    renamed into its place (both beside ``out``: renames, no copies); where ``out`` is a
    symbolic link or cannot be moved (a mount point), its contents are replaced in place.
    """
    out = out.absolute()
    if not out.exists() and not out.is_symlink():
        os.replace(run, out)
        return

    def in_place() -> None:
        for name in OWN_FILES:
            (out / name).unlink(missing_ok=True)
        for name in OWN_DIRS:
            shutil.rmtree(out / name, ignore_errors=True)
        for entry in run.iterdir():
            os.replace(entry, out / entry.name)
        run.rmdir()

    if out.is_symlink() or os.path.ismount(out):
        in_place()
        return
    aside = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".old", dir=out.parent))
    try:
        os.replace(out, aside / "out")
    except OSError:
        aside.rmdir()
        in_place()
        return
    try:
        os.replace(run, out)
    except OSError:
        os.replace(aside / "out", out)  # put the earlier run back
        aside.rmdir()
        raise
    for entry in (aside / "out").iterdir():
        if entry.name not in OWN_FILES + OWN_DIRS:  # a user's file beside the earlier run: kept
            os.replace(entry, out / entry.name)
    shutil.rmtree(aside)


def run_into(out: Path, what: str, index: str, work: Callable[[Path], tuple[str, list[Path], str]]) -> int:
    """Run ``work(folder)`` into a new temporary folder beside ``out`` and put it in place only when it finished:
    a failure (exit status 1) or an interrupt (130) removes the folder and leaves ``out`` as it was. ``work``
    returns the table to print, the files written and a line on how long it took."""
    folder = new_run_folder(out)
    try:
        table, files, took = work(folder)
    except KeyboardInterrupt:
        shutil.rmtree(folder, ignore_errors=True)
        print(f"\ninterrupted; {out} left as it was", file=sys.stderr)
        return 130
    except Exception as exc:
        shutil.rmtree(folder, ignore_errors=True)
        if not isinstance(exc, FootstepGymError):  # ours say in one line what failed (a submitted policy's, say)
            traceback.print_exc()
        print(f"error: {what} failed; {out} left as it was. {exc}", file=sys.stderr)
        return 1
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    commit_out(folder, out)
    print(table)
    print(f"{took}; wrote {len(files)} files to {out}/ ({index})")
    return 0
