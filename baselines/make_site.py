"""Build the board's static web site from the committed results (footstep_gym/evaluation/site.py).

    python baselines/make_site.py --out site                                  # the site, from committed files only
    python baselines/make_site.py --out site --screenshot docs/site_board.png # and a 900 px screenshot of the board
    python baselines/make_site.py --videos                                    # re-render the committed episode videos

The build reads baselines/results/ (the leaderboard, each row's benchmark.json, the learning curves, the
videos under baselines/results/site/), the shipped agents' manifests, configs/benchmark.yaml and
docs/benchmark.md; it renders nothing and fetches nothing. Open DIR/index.html, or serve DIR with
`python -m http.server -d DIR -b 127.0.0.1`. --videos plays one validation episode per cell and method
(fixed seed) and rewrites baselines/results/site/ (a few MB), which the next build copies in.
--screenshot needs Chromium and its driver (Debian: chromium, chromium-driver) and selenium.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from footstep_gym.evaluation.board import SHOWN_BOARD_DIR

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, help="the site's folder (new, empty, or a site built before)")
    ap.add_argument("--board", type=Path, default=None,
                    help=f"the folder of leaderboard.json (default {SHOWN_BOARD_DIR}: the board the docs show)")
    ap.add_argument("--screenshot", type=Path, default=None, help="also write a PNG of the board page, 900 px wide")
    ap.add_argument("--videos", action="store_true",
                    help="re-render the episode videos into baselines/results/site/ (minutes), then build if --out")
    ap.add_argument("--cells", nargs="*", default=None, help="with --videos: only these TIER/SCENE/CELL")
    args = ap.parse_args(argv)
    if args.out is None and not args.videos:
        ap.error("give --out DIR (the site) or --videos (re-render the committed videos)")
    if args.screenshot is not None and args.out is None:
        ap.error("--screenshot needs --out (the site it photographs)")
    if args.screenshot is not None and args.screenshot.suffix.lower() != ".png":
        ap.error(f"--screenshot {args.screenshot}: must be a .png file")

    from footstep_gym.evaluation import site

    try:
        if args.out is not None:
            site.check_out(args.out)
        if args.videos:
            from footstep_gym.evaluation import site_videos

            t0 = time.perf_counter()
            made = site_videos.render_videos(ROOT, cells=args.cells)
            print(f"wrote {len(made)} videos to {site.VIDEOS_DIR}/ in {time.perf_counter() - t0:.0f} s "
                  f"({sum(p.stat().st_size for p in made) / 1e6:.2f} MB)")
        if args.out is not None:
            t0 = time.perf_counter()
            pages = site.build_site(ROOT, args.out, args.board)
            print(f"wrote {len(pages)} pages to {args.out}/ in {time.perf_counter() - t0:.1f} s "
                  f"(open {args.out / 'index.html'})")
            if args.screenshot is not None:
                from footstep_gym.evaluation import site_browser

                site_browser.screenshot(args.out, args.screenshot)
                print(f"wrote {args.screenshot}")
    except (ValueError, FileNotFoundError) as exc:
        print(f"make_site.py: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
