"""Write the leaderboard across policies from their benchmark.json files: one table, rliable's figures.

Usage::

    python baselines/make_leaderboard.py                              # baselines/results/benchmark/*/benchmark.json
    python baselines/make_leaderboard.py runs/bench --out runs/bench  # every runs/bench/*/benchmark.json
    python baselines/make_leaderboard.py runs/bench/ppo runs/bench/oracle/benchmark.json --out /tmp/board

Each path is a ``benchmark.json`` (``eval_planner.py --benchmark``), a folder holding one, or a folder whose
sub-folders hold one each. The files must be of one protocol (the same ``protocol.env_configs_sha256`` and
``episodes_per_cell``; ``--allow-mixed`` lifts this) and name each policy once. ``--out`` gets
``leaderboard.md``, ``leaderboard.json``, ``iqm_per_tier.png``, ``iqm_optimality_gap_<tier>.png`` per tier and
``performance_profiles.png``, written into a temporary folder beside it and then moved in (its other files are
kept). The machinery is ``footstep_gym.evaluation.leaderboard``; docs/benchmark.md §4 says what the figures show.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import NoReturn

from footstep_gym.evaluation import leaderboard as lb
from footstep_gym.evaluation.board import BOARD_DIR

REPO = Path(__file__).resolve().parent.parent
DEFAULT = REPO / BOARD_DIR
#: The full-body column's summary (``python baselines/fullbody.py summary``), shown when it exists.
FULLBODY = REPO / "baselines" / "results" / "fullbody" / "fullbody_paper_op3.json"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     epilog="docs/benchmark.md §4 describes the outputs.")
    parser.add_argument("paths", nargs="*", type=Path, metavar="PATH",
                        help=f"benchmark.json files or folders (default: every {BOARD_DIR}/*/benchmark.json)")
    parser.add_argument("--out", type=Path, default=None,
                        help=f"output folder (default: {BOARD_DIR}/); its other files are kept")
    parser.add_argument("--allow-mixed", action="store_true",
                        help="accept files of different protocols (env configs or episodes per cell)")
    parser.add_argument("--reps", type=int, default=lb.REPS,
                        help=f"bootstrap resamples of every interval (default {lb.REPS})")
    parser.add_argument("--seed", type=int, default=lb.SEED, help=f"bootstrap seed (default {lb.SEED})")
    parser.add_argument("--fullbody", type=Path, default=None,
                        help="a full-body summary shown as a column (default, with no PATH: "
                             f"{FULLBODY.relative_to(REPO)} when it exists); 'none': no column")
    return parser


def refuse(problem: str) -> NoReturn:
    """One usage-error line on stderr, exit status 2; nothing written."""
    build_parser().error(problem)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if not args.paths and not DEFAULT.is_dir():
        refuse(f"no PATH given and {DEFAULT.relative_to(REPO)}/ (the default) does not exist; name the benchmark.json "
               "files or their folders (e.g. runs/bench)")
    paths = args.paths or [DEFAULT]
    out = args.out if args.out is not None else DEFAULT
    if args.reps < 1:
        refuse(f"--reps must be at least 1, got {args.reps}")
    problem = lb.check_out(out)
    if problem:
        refuse(problem)
    try:
        fullbody = (None if str(args.fullbody) == "none" else args.fullbody if args.fullbody is not None
                    else FULLBODY if not args.paths and FULLBODY.is_file() else None)
        board = lb.leaderboard(paths, allow_mixed=args.allow_mixed, reps=args.reps, seed=args.seed, fullbody=fullbody)
    except lb.LeaderboardError as exc:
        refuse(str(exc))
    files = lb.write_leaderboard(board, out)
    print(lb.main_summary(board, files, out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
