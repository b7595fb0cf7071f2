"""Calibrate the benchmark's cells on validation seeds: the best null baseline's and the privileged solvers' success.

Usage::

    python baselines/calibrate.py --episodes 30 --out runs/calibration            # nulls and oracle, every cell
    python baselines/calibrate.py --episodes 30 --no-oracle --out runs/calib-null  # the null baselines only (fast)
    python baselines/calibrate.py --oracle-episodes 20 --no-null --out runs/calib-oracle   # the oracle only
    python baselines/calibrate.py --tier structure --env crowd --out runs/calib-crowd --workers 2
    python baselines/calibrate.py --no-null --privileged oracle-lookahead --oracle-episodes 100 \
        --cell structure/door/any_phase --out runs/calib-any-phase      # one cell
    python baselines/calibrate.py --no-null --privileged oracle-lookahead --oracle-episodes 100 \
        --out runs/calib-certify                   # protocol 3: certify solvability on 100 validation seeds per cell
    python baselines/calibrate.py --merge runs/calib-a --merge runs/calib-b --out baselines/results/calibration
                                                   # several runs as one, with the certification table

A cell outside the ``paper`` tier stays in the benchmark only if the best null baseline succeeds in
at most 0.1 of its validation episodes and the best privileged solver (``--privileged``: ``oracle``,
``oracle-lookahead``) in at least 0.9, certified on at least 100 episodes (configs/benchmark.yaml's
header; docs/benchmark.md, "How the cells are chosen"). The script writes ``calibration.json`` (every
policy's successes per cell with the seeds and outcomes of its failures, and each policy's cost: wall seconds per
episode) and ``calibration.md``
(the table docs/benchmark.md quotes) into ``--out`` and prints the table; it exits with status 1 if a
cell breaks the rule.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from footstep_gym.evaluation import calibration as cal
from footstep_gym.evaluation.benchmark import benchmark_cells
from footstep_gym.scenarios import resolve_env_id, scene_of


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=30, help="validation seeds per cell and policy (30)")
    parser.add_argument("--offset", type=int, default=0, help="start this many seeds into the validation split")
    parser.add_argument("--oracle-episodes", type=int, default=None,
                        help="the privileged solvers' seeds per cell (default: --episodes; 100 certify a cell)")
    parser.add_argument("--privileged", action="append", choices=cal.PRIVILEGED,
                        help="the privileged solvers to run (repeat; default oracle)")
    parser.add_argument("--no-oracle", action="store_true", help="the null baselines only (no privileged solver)")
    parser.add_argument("--no-null", action="store_true", help="the privileged solvers only")
    parser.add_argument("--tier", action="append", help="only these tiers (repeat)")
    parser.add_argument("--env", action="append", help="only these scenes or env ids (repeat)")
    parser.add_argument("--cell", action="append",
                        help="only these cells, TIER/SCENE/CELL as the table names them (repeat)")
    parser.add_argument("--workers", type=int, default=1, help="worker processes (1)")
    parser.add_argument("--merge", type=Path, action="append",
                        help="run nothing: merge these runs' folders (repeat) into --out, with the certification table")
    parser.add_argument("--out", type=Path, required=True, help="folder for calibration.json and calibration.md")
    args = parser.parse_args(argv)
    if args.merge:
        return merge(args.merge, args.out, parser)
    try:
        scenes = [scene_of(resolve_env_id(e)) for e in args.env] if args.env else None
        cells = cal.select_cells(benchmark_cells(scenes, args.tier), args.cell)
        oracle_n = args.oracle_episodes or args.episodes
        for n in (args.episodes, oracle_n):
            cal.split_seeds(cal.SPLIT, n, args.offset)
    except ValueError as exc:
        parser.exit(2, f"calibrate.py: error: {exc}\n")
    if args.no_oracle and args.no_null:
        parser.exit(2, "calibrate.py: error: --no-oracle and --no-null leave nothing to run\n")
    if args.workers < 1:
        parser.exit(2, "calibrate.py: error: --workers must be >= 1\n")
    if args.out.exists() and not args.out.is_dir():
        parser.exit(2, f"calibrate.py: error: --out {args.out} is a file\n")
    t0 = time.perf_counter()
    cost = {}
    runs = [] if args.no_null else [(cal.null_policies(), args.episodes)]
    if not args.no_oracle:
        runs += [([p], oracle_n) for p in dict.fromkeys(args.privileged or ["oracle"])]
    scores = []
    for policies, n in runs:
        t1 = time.perf_counter()
        scores += cal.score(cells, policies, n, args.offset, args.workers)
        spent = time.perf_counter() - t1
        episodes = len(policies) * len(cells) * n
        cost[policies[0] if len(policies) == 1 else "null baselines"] = {
            "episodes": episodes, "wall_s": round(spent, 1), "s_per_episode": round(spent / episodes, 2)}
    wall = time.perf_counter() - t0
    table = cal.markdown_table(scores)
    args.out.mkdir(parents=True, exist_ok=True)
    doc = {"split": cal.SPLIT, "offset": args.offset, "wall_time_s": round(wall, 1), "workers": args.workers,
           "cost": cost,
           "command": " ".join(["python", "baselines/calibrate.py", *(argv if argv is not None else sys.argv[1:])]),
           "scores": [{"scene": s.cell.scene, "tier": s.cell.tier, "cell": s.cell.name, "policy": s.policy,
                       "successes": s.successes, "episodes": s.episodes,
                       "failed": [{"seed": seed, "outcome": outcome} for seed, outcome in s.failed]}
                      for s in scores],
           "broken": cal.broken(scores)}
    (args.out / "calibration.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    (args.out / "calibration.md").write_text(table + "\n", encoding="utf-8")
    print(table)
    print(f"\n{len(scores)} policy x cell scores in {wall:.0f} s -> {args.out}", file=sys.stderr)
    for name, c in cost.items():
        print(f"{name}: {c['episodes']} episodes, {c['wall_s']} s, {c['s_per_episode']} s per episode "
              f"({args.workers} worker(s))", file=sys.stderr)
    for line in doc["broken"]:
        print(f"rule broken: {line}", file=sys.stderr)
    return 1 if doc["broken"] else 0


def merge(folders: list[Path], out: Path, parser: argparse.ArgumentParser) -> int:
    """``--merge``: the runs of ``folders`` as one calibration (``calibration.json``: every run's settings and
    cost, every score with its cost; ``calibration.md``: the certification table), exit 1 if a cell breaks the
    rule."""
    try:
        docs = [json.loads((f / "calibration.json").read_text(encoding="utf-8")) for f in folders]
        scores, cost = cal.scores_from_runs(docs)
    except (OSError, ValueError, KeyError) as exc:
        parser.exit(2, f"calibrate.py: error: --merge: {exc}\n")
    table = cal.certification_table(scores, cost)
    doc = {"split": cal.SPLIT,
           "runs": [{"folder": f.as_posix(), **{k: d[k] for k in ("command", "offset", "workers", "wall_time_s",
                                                                 "cost")}} for f, d in zip(folders, docs)],
           "scores": [{"scene": s.cell.scene, "tier": s.cell.tier, "cell": s.cell.name, "policy": s.policy,
                       "successes": s.successes, "episodes": s.episodes,
                       "s_per_episode": cost[(cal.cell_name(s.cell), s.policy)],
                       "failed": [{"seed": seed, "outcome": outcome} for seed, outcome in s.failed]}
                      for s in scores],
           "broken": cal.broken(scores)}
    out.mkdir(parents=True, exist_ok=True)
    (out / "calibration.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    (out / "calibration.md").write_text(table + "\n", encoding="utf-8")
    print(table)
    for line in doc["broken"]:
        print(f"rule broken: {line}", file=sys.stderr)
    return 1 if doc["broken"] else 0


if __name__ == "__main__":
    sys.exit(main())
