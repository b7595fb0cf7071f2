"""Write docs/results.md (the generated blocks of docs/speed.md and README.md, and each committed evaluation's
summary.md) from the committed results.

Usage::

    python baselines/make_results_doc.py           # rewrite the pages that differ from the result files
    python baselines/make_results_doc.py --check   # only list them; exit status 1 if any

The pages are written from ``baselines/results/*/{run,results}.json``, ``baselines/results/speed/speed.md``,
``baselines/results/speed_tiers/speed.md``, ``baselines/results/soak/soak.md`` and
``baselines/agents/*/*/manifest.json`` (``footstep_gym.evaluation.results_doc``). Run it after committing a new evaluation into
``baselines/results/``; ``tests/test_docs.py`` fails while a page is stale. The blocks of README.md and docs/speed.md
are cog's: ``cog -r README.md`` (pip package cogapp) regenerates one page the same way.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from footstep_gym.evaluation.results_doc import render_docs, stale_docs

REPO = Path(__file__).resolve().parent.parent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a page is stale")
    parser.add_argument("--repo", type=Path, default=REPO, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    try:
        stale = stale_docs(args.repo)
    except ValueError as exc:  # a bad block in a page (its name, a missing end)
        parser.error(str(exc))
    if args.check:
        for rel in stale:
            print(f"stale: {rel} (run python baselines/make_results_doc.py)", file=sys.stderr)
        return 1 if stale else 0
    pages = render_docs(args.repo)
    for rel in stale:
        (args.repo / rel).write_text(pages[rel], encoding="utf-8")
        print(f"wrote {rel}")
    if not stale:
        print("every page is up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())
