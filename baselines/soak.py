"""Soak: millions of fuzzed steps per env, checking that nothing unexpected ever happens.

    python baselines/soak.py                      # 10^6 steps per env
    python baselines/soak.py --steps 100000       # 10^5 per env
    python baselines/soak.py --envs FootstepDoor-v0 --steps 20000 --out runs/soak-door
    python baselines/soak.py --remake-every 300   # a fresh env every 300 episodes

Each env runs in a process of its own (so its memory figures are its own), with a tqdm
progress bar on stderr, and keeps **one env instance** for its whole run (made with random
``randomize=`` settings drawn from the scenario's fuzz ranges, reset at every episode's end),
as a training run does; ``--remake-every N`` makes a fresh env every N episodes instead. The
fuzz (commands inside, at and outside the box, bad commands, steps after the end, random
resets), the checks after every step and the RSS verdict are described in the engine's
docstring, ``baselines/speedlib/soak.py`` (beside this file, not part of the installed package); this
file is its command line.

Writes ``<out>/soak.json`` and ``<out>/soak.md`` (steps/s, outcomes, exceptions by type,
RSS figures); exits with status 1 if any env failed a check, saying which and why on stderr.
While it runs, each env's figures so far are in ``<out>/partial/<env id>.json`` (updated 20
times per env), so a run stopped early still says how far it got and what it saw.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from speedlib import soak
from speedlib.fmt import finite_json
from speedlib.reports import soak_report


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=soak.DEFAULT_STEPS, help="step calls per env (default 10^6)")
    p.add_argument("--envs", default=",".join(soak.ENV_IDS), help="comma-separated env ids (default: all four)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("runs/soak"), help="folder for soak.json and soak.md")
    p.add_argument("--rss-tolerance-mib", type=float, default=soak.DEFAULT_RSS_TOLERANCE_MIB,
                   help="largest growth of the current RSS (and of the peak) over its value after the warm-up "
                        f"still called flat [MiB] (default {soak.DEFAULT_RSS_TOLERANCE_MIB:g}); more fails the env")
    p.add_argument("--remake-every", type=int, default=soak.DEFAULT_REMAKE_EVERY, metavar="EPISODES",
                   help="make a fresh env (new random randomize= settings) every this many episodes; 0 (default): "
                        "one env instance for the whole run, which is what shows a leak tied to the instance")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    # Self-test of the RSS verdict: the env keeps this many KiB more at every reset (the run must FAIL).
    p.add_argument("--_inject-leak-kib", dest="leak_kib", type=float, default=0.0, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.steps < 1:
        p.error(f"--steps must be >= 1, got {args.steps}")
    if not (args.rss_tolerance_mib >= 0 and math.isfinite(args.rss_tolerance_mib)):
        p.error(f"--rss-tolerance-mib must be a finite number >= 0, got {args.rss_tolerance_mib}")
    if args.remake_every < 0:
        p.error(f"--remake-every must be >= 0 (0: one env instance), got {args.remake_every}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    env_ids = [e.strip() for e in args.envs.split(",") if e.strip()]
    unknown = [e for e in env_ids if e not in soak.ENV_IDS]
    if unknown:
        raise SystemExit(f"unknown env id(s) {unknown}; choose from {list(soak.ENV_IDS)}")
    summary = soak.run(env_ids, args.steps, args.seed, args.out, rss_tolerance_mib=args.rss_tolerance_mib,
                       remake_every=args.remake_every, progress=not args.no_progress, leak_kib=args.leak_kib)
    text = soak_report(summary)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "soak.json").write_text(json.dumps(finite_json(summary), indent=2) + "\n", encoding="utf-8")
    (args.out / "soak.md").write_text(text, encoding="utf-8")
    soak.log(f"wrote {args.out / 'soak.json'} and {args.out / 'soak.md'}")
    if not summary["passed"]:
        failed = [r for r in summary["envs"] if not r["passed"]]
        soak.log(f"FAILED: {len(failed)} of {len(summary['envs'])} env(s): " + "; ".join(
            f"{r['env_id']}: {' / '.join(r['failures'])}" for r in failed))
    return 0 if summary["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
