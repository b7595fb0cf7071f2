"""Run the protocol-3 board: every method of configs/board.yaml once on the test split, in order.

Usage::

    python baselines/run_board.py                      # the plan: each row made / failed / due under this fingerprint
    python baselines/run_board.py --run --workers 2    # run every due row (eval_planner.py --benchmark --release)
    python baselines/run_board.py --run --only lookahead --only dwa
    python baselines/run_board.py --run --retry dwa    # a row whose logged run failed: run (and log) it again

A row is ``made`` when its folder (``--out-root``/<method>) holds a test-split row whose release is a line of the
access log under this checkout's fingerprint; it is never run again, so the board can be made over several sittings
and the test split is touched once per method. A ``failed`` row (logged, no row) runs only with ``--retry``; the log
keeps both lines. Every release run is refused from a tree with uncommitted changes (outputs under
baselines/results/ aside). Then ``python baselines/make_leaderboard.py`` makes the board. The machinery is
``footstep_gym.evaluation.board``; docs/benchmark.md §6 is the protocol.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

from footstep_gym.errors import ConfigError
from footstep_gym.evaluation import board
from footstep_gym.evaluation import protocol as row_protocol

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / board.BOARD_DIR


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     epilog="docs/benchmark.md §6 is the protocol.")
    parser.add_argument("--run", action="store_true", help="run the due rows (without it: print the plan only)")
    parser.add_argument("--only", action="append", default=[], metavar="METHOD",
                        help="only this row (repeatable; a method of the board)")
    parser.add_argument("--retry", action="append", default=[], metavar="METHOD",
                        help="run this failed row again (logged again; repeatable)")
    parser.add_argument("--workers", type=int, default=1, help="worker processes per row (default 1)")
    parser.add_argument("--out-root", type=Path, default=DEFAULT_OUT,
                        help="the board's folder, a row per method in <out-root>/<method> "
                             f"(default {DEFAULT_OUT.relative_to(REPO)})")
    parser.add_argument("--rows", type=Path, default=None,
                        help=f"the board's rows (default configs/{board.BOARD_CONFIG})")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error(f"--workers must be >= 1, got {args.workers}")
    try:
        methods = board.load_rows(args.rows)
        log = row_protocol.read_access_log(row_protocol.access_log_path())
    except (ConfigError, ValueError) as exc:
        parser.error(str(exc))
    named = [*args.only, *args.retry]
    unknown = [m for m in named if m not in methods]
    if unknown:
        parser.error(f"{', '.join(unknown)}: not a row of the board ({args.rows or 'configs/' + board.BOARD_CONFIG})")
    fingerprint = row_protocol.fingerprint()
    states = board.plan(methods, args.out_root, log, fingerprint)
    missing = board.missing_runs(methods)
    print(f"fingerprint {fingerprint[:12]}, {len(methods)} rows in {args.out_root}")
    for s in states:
        lines = ", ".join(a.date for a in s.accesses)
        lacking = missing.get(s.method)
        print(f"  {s.state:6s}  {s.method}" + (f"  (logged {lines})" if lines else "")
              + (f"  (no shipped run for {', '.join(lacking)}: cannot be a row)" if lacking else ""))
    if not args.run:
        return 0
    blocked = [m for m in missing if m in (set(named) or set(methods))]
    if blocked:
        which = "; ".join(f"{m} on {', '.join(missing[m])}" for m in blocked)
        parser.error(f"no shipped training run for {which}: a row covers every scene; train and ship them, or take "
                     "the method off the board's rows")
    foreign = board.foreign_rows(args.out_root, fingerprint)
    if foreign:
        parser.error(f"{args.out_root} holds {len(foreign)} rows of another protocol or fingerprint (e.g. "
                     f"{foreign[0].name}); a board is of one: move them out first (protocol 2's to "
                     "baselines/results/benchmark-protocol2) or give another --out-root")
    by_name = {s.method: s for s in states}
    not_failed = [m for m in args.retry if by_name[m].state != "failed"]
    if not_failed:
        parser.error(f"--retry {', '.join(not_failed)}: not a failed row (only a logged run without a row is retried)")
    problem = row_protocol.dirty_refusal(row_protocol.tree_state())
    if problem:
        parser.error(problem)
    chosen = set(named) or set(methods)
    todo = [s for s in states if s.method in chosen
            and (s.state == "due" or (s.state == "failed" and s.method in args.retry))]
    skipped = [s.method for s in states if s.method in chosen and s.state == "failed" and s.method not in args.retry]
    if skipped:
        print(f"not run (failed before; --retry to run again): {', '.join(skipped)}")
    for k, s in enumerate(todo, 1):
        print(f"[{k}/{len(todo)}] {s.method}", flush=True)
        start = time.monotonic()
        cmd = [sys.executable, str(REPO / "baselines" / "eval_planner.py"),
               *board.release_argv(s.method, s.folder, args.workers)]
        code = subprocess.call(cmd, cwd=REPO)
        print(f"[{k}/{len(todo)}] {s.method}: exit {code}, {time.monotonic() - start:.0f} s", flush=True)
        if code != 0:
            print(f"stopped at {s.method} (exit {code}); the rows before it are made", file=sys.stderr)
            return code
    return 0


if __name__ == "__main__":
    sys.exit(main())
