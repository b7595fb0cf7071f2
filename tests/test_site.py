"""The board's static site (footstep_gym/evaluation/site.py, baselines/make_site.py), built from the committed files
and opened in headless Chromium (Debian's chromium and chromium-driver, driven by selenium)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import urljoin, urlparse

import pytest

from footstep_gym.evaluation import site, site_browser
from footstep_gym.evaluation.board import SHOWN_BOARD_DIR

ROOT = Path(__file__).resolve().parents[1]
BOARD = json.loads((ROOT / SHOWN_BOARD_DIR / "leaderboard.json").read_text())
VIDEOS = json.loads((ROOT / site.VIDEOS_DIR / "videos.json").read_text())


class _Refs(HTMLParser):
    """Every URL a page refers to: (tag, attribute, value)."""

    def __init__(self) -> None:
        super().__init__()
        self.refs: list[tuple[str, str, str]] = []
        self.board_rows = 0
        self._in_board = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        for key in ("src", "href"):
            if a.get(key):
                self.refs.append((tag, key, str(a[key])))
        if tag == "table":
            self._in_board = a.get("id") == "board"
        if tag == "tr" and self._in_board:
            self.board_rows += 1


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site") / "site"
    site.build_site(ROOT, out)
    return out


def test_site_has_every_committed_method_and_cell_and_only_local_assets(built: Path) -> None:
    index = _Refs()
    index.feed((built / "index.html").read_text())
    assert index.board_rows == len(BOARD["policies"]) + 1  # the header row
    names = [p["policy"] for p in BOARD["policies"] + BOARD["in_distribution"]]
    assert sorted(p.stem for p in (built / "methods").glob("*.html") if p.stem != "index") == sorted(names)
    cells = {f"{t}-{c.replace('/', '-')}" for t in BOARD["tiers"] for c in BOARD["tier_cells"][t]}
    assert {p.stem for p in (built / "cells").glob("*.html")} == cells
    pages = list(built.rglob("*.html"))
    for page in pages:
        refs = _Refs()
        refs.feed(page.read_text())
        for tag, key, url in refs.refs:
            parsed = urlparse(url)
            if parsed.scheme == "data":
                continue
            # nothing on another host is loaded (a link to one would only be followed by a click)
            assert tag == "a" or not parsed.scheme, f"{page.name}: <{tag} {key}={url}> fetches from outside the site"
            if parsed.scheme or not parsed.path:
                continue
            target = (page.parent / parsed.path).resolve()
            assert target.is_file(), f"{page.relative_to(built)}: {url} is not in the site"
    protocol = (built / "protocol.html").read_text()
    ids = set(re.findall(r'id="([^"]+)"', protocol))
    internal = re.findall(r'href="(?:protocol\.html)?#([^"]+)"', protocol)
    assert internal and not [a for a in internal if a not in ids]  # the document's own links find their headings
    assert "<table>" in protocol and "<h2" in (built / "submit.html").read_text()
    for css in built.rglob("*.css"):
        assert not re.search(r"url\(|@import", css.read_text()), css
    total_video = sum(v["bytes"] for v in VIDEOS["videos"].values())
    assert len(list((built / "assets/videos").glob("*.mp4"))) == len(VIDEOS["videos"]) > 0
    assert total_video < 5e6  # the committed videos stay a few MB


def test_site_refuses_a_folder_it_did_not_write(tmp_path: Path) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    proc = subprocess.run([sys.executable, str(ROOT / "baselines/make_site.py"), "--out", str(mine)],
                          capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "not a site make_site.py wrote" in proc.stderr
    assert (mine / "notes.txt").read_text() == "keep me" and len(list(mine.iterdir())) == 1


def _browser_or_skip() -> None:
    missing = []
    if site_browser.browser_paths() is None:
        missing.append("chromium and chromedriver (apt-get install chromium chromium-driver)")
    try:
        import selenium  # noqa: F401
    except ImportError:
        missing.append("selenium")
    if missing:
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI=true and the browser test cannot run: no {', '.join(missing)}")
        pytest.skip(f"no {', '.join(missing)}")


def _column(driver, table: str, index: int) -> list[str]:  # type: ignore[no-untyped-def]
    return driver.execute_script(
        "return Array.from(document.querySelectorAll(arguments[0] + ' tbody tr'))"
        ".map(r => r.cells[arguments[1]].getAttribute('data-v'))", table, index)


def test_site_in_headless_chromium(built: Path, tmp_path: Path) -> None:
    _browser_or_skip()
    from selenium.webdriver.common.by import By

    with site_browser.serve(built) as base, site_browser.chrome((1300, 900)) as driver:
        driver.get(base + "index.html")
        rows = driver.find_elements(By.CSS_SELECTOR, "table#board tbody tr")
        assert len(rows) == len(BOARD["policies"])
        # sorting: a tier column, ascending then descending, by its values
        heads = driver.find_elements(By.CSS_SELECTOR, "table#board thead th")
        col = [h.text.strip(" ⇅▲▼") for h in heads].index("train")
        before = _column(driver, "table#board", col)
        heads[col].click()
        up = [float(v) for v in _column(driver, "table#board", col)]
        assert up == sorted(up) and heads[col].get_attribute("aria-sort") == "ascending"
        heads[col].click()
        down = [float(v) for v in _column(driver, "table#board", col)]
        assert down == sorted(up, reverse=True) and sorted(before) == sorted(_column(driver, "table#board", col))
        # a method page from the board's link
        first = driver.find_element(By.CSS_SELECTOR, "table#board tbody tr td a")
        name = first.text
        first.click()
        assert "/methods/" in driver.current_url and driver.find_element(By.TAG_NAME, "h1").text == name
        # a cell page from the board's per-tier links
        driver.get(base + "index.html")
        link = driver.find_element(By.CSS_SELECTOR, "main p a[href^='cells/']")
        label = link.text
        link.click()
        assert "/cells/" in driver.current_url
        assert driver.find_element(By.TAG_NAME, "h1").text.replace(" ", "").endswith(label)
        # a video loads and plays
        key = sorted(VIDEOS["videos"])[0]
        tier, scene, cell = key.split("/")
        driver.get(urljoin(base, site.cell_page(tier, scene, cell)))
        played = driver.execute_async_script(
            "const done = arguments[arguments.length - 1]; const v = document.querySelector('video');"
            "v.muted = true; v.play().catch(e => done('play failed: ' + e));"
            "const t0 = Date.now(); (function poll() {"
            "  if (v.currentTime > 0.5) return done([v.currentTime, v.videoWidth, v.readyState]);"
            "  if (Date.now() - t0 > 15000) return done('no progress: ' + v.currentTime + ' error ' + (v.error && v.error.code));"
            "  setTimeout(poll, 100); })();")
        assert isinstance(played, list), played
        assert played[0] > 0.5 and played[1] == VIDEOS["videos"][key]["width"]
        for page in ("figures.html", "protocol.html", "submit.html", "cells.html", "scenes/index.html"):
            driver.get(base + page)
        resources = driver.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
        console = driver.get_log("browser")
        requests = [json.loads(m["message"])["message"] for m in driver.get_log("performance")]
    assert not [e for e in console if e["level"] in ("SEVERE", "WARNING")], console
    urls = [m["params"]["request"]["url"] for m in requests if m["method"] == "Network.requestWillBeSent"]
    assert len(urls) > 10 and any(u.endswith(".mp4") for u in urls)
    outside = [u for u in urls + resources if not (u.startswith(base) or u.startswith("data:"))]
    assert not outside, outside
    png = site_browser.screenshot(built, tmp_path / "board.png")
    from PIL import Image

    with Image.open(png) as im:
        assert im.size == site_browser.SCREENSHOT_SIZE


def test_a_board_with_scores_shows_them_without_code_changes(tmp_path: Path) -> None:
    """A later protocol's board (protocol 3: ``scores`` with scene-balanced tier figures and a ranking) is shown by
    building again: its figures replace the IQM, and its score and probability of improvement get columns."""
    board = json.loads(json.dumps(BOARD))
    first, second = board["policies"][0]["policy"], board["policies"][1]["policy"]
    board["protocol_version"] = 3
    board["protocol"]["fingerprint"] = "f" * 64
    board["scores"] = {"tiers": [{"policy": first, "tier": t, "success": 0.123, "success_ci95": [0.1, 0.2]}
                                 for t in board["tiers"]],
                       "ranking": [{"policy": first, "score": 0.456, "safe_score": 0.321, "p_improvement": 0.789},
                                   {"policy": second, "score": 0.4, "safe_score": 0.3, "p_improvement": None}],
                       "ranked_tiers": board["tiers"][1:],
                       "safety_thresholds": {"min_clearance": 0.02, "min_zmp_margin": 0.005}}
    folder = tmp_path / "board"
    folder.mkdir()
    (folder / "leaderboard.json").write_text(json.dumps(board))
    site.build_site(ROOT, tmp_path / "site", folder)
    index = (tmp_path / "site/index.html").read_text()
    assert "Each tier: scene-balanced success" in index and "Each tier: IQM" not in index
    assert "fingerprint <code>ffffffffffff</code>" in index
    row = re.search(rf'<tr class="">(<td data-v="{re.escape(first)}".*?)</tr>', index).group(1)
    cells = re.findall(r'<td[^>]*data-v="([^"]*)"', row)
    tiers = len(board["tiers"])
    assert cells[3:3 + tiers] == ["0.123000"] * tiers  # method, track, runs (kind sorts by its text), the tiers
    assert cells[3 + tiers:6 + tiers] == ["0.456000", "0.321000", "0.789000"]  # score, safe score, P(> next)
    assert "smallest clearance at least 20 mm and smallest ZMP margin at least 5 mm" in index
    # a row the scores leave out (the in-distribution track) keeps its IQM, and says so
    ind = board["in_distribution"][0]["policy"]
    method = (tmp_path / f"site/methods/{ind}.html").read_text()
    assert "IQM success" in method and "scene-balanced success" not in method


def test_a_board_with_a_full_body_summary_shows_its_column(tmp_path: Path) -> None:
    """A board with a full-body summary (baselines/make_leaderboard.py --fullbody) gets a column on that tier's
    table: the share that walks on the OP3 without a fall, – for a method not replayed; the other tiers' tables none."""
    board = json.loads(json.dumps(BOARD))
    first = board["policies"][0]["policy"]
    board["fullbody"] = {"tier": "paper", "robot": "op3", "source": "fullbody_paper_op3.json",
                         "policies": {first: {"episodes": 9, "scenes": [], "op3_no_fall": 0.333,
                                              "env_success": 1.0, "env_success_and_op3_no_fall": 0.333}}}
    folder = tmp_path / "board"
    folder.mkdir()
    (folder / "leaderboard.json").write_text(json.dumps(board))
    site.build_site(ROOT, tmp_path / "site", folder)
    index = (tmp_path / "site/index.html").read_text()
    paper = index[index.index('id="tier-table-paper"'):]
    paper = paper[:paper.index("</table>")]
    assert paper.count("full body (op3): no fall (episodes)") == 1
    row = re.search(rf'<tr class="[^"]*">(<td data-v="{re.escape(first)}".*?)</tr>', paper).group(1)
    assert re.findall(r'<td[^>]*data-v="([^"]*)"', row)[-1] == "0.333000" and "(9)" in row
    other = index[index.index('id="tier-table-train"'):]
    assert "full body" not in other[:other.index("</table>")]


def test_the_board_shows_each_learned_rows_budget_and_converged_runs(built: Path) -> None:
    """From the shipped agents' manifests and validation curves, checked here with the rule written out again: the
    last three points within ceil(0.5 sqrt(n)) of one another, in episodes."""
    import csv
    import math

    index = (built / "index.html").read_text()
    data = site.load_site_data(ROOT)
    agents = [m for m in data.methods if m.kind == "agent" and m.manifests]
    assert agents
    for m in agents:
        runs = sorted((ROOT / "baselines/agents" / m.name).glob("*/manifest.json"))
        steps = sorted({json.loads(p.read_text())["timesteps"] for p in runs})
        converged = with_curve = 0
        for p in runs:
            path = p.parent / "validation.csv"
            if not path.is_file():
                continue
            rows = list(csv.DictReader(path.open()))
            n = int(rows[-1]["episodes"])
            wins = [round(float(r["success_rate"]) * n) for r in rows[-3:]]
            with_curve += 1
            converged += len(rows) >= 3 and max(wins) - min(wins) <= math.ceil(0.5 * math.sqrt(n))
        assert m.training["env_steps_per_run"] == steps, m.name
        if with_curve == len(runs):  # every run has a validation curve: the count is the rule's on them
            assert (m.training["converged"], m.training["with_curve"]) == (converged, with_curve), m.name
        text, _ = site.budget(m)
        assert f"{m.training['converged']}/{m.training['with_curve']} converged" in text
        assert "(below 2e7)" in text or "(at budget)" in text
        assert html_escape(text) in index, m.name
        page = (built / m.page).read_text()
        assert "converged (compute protocol)" in page and "CPU time [s]" in page


def html_escape(text: str) -> str:
    import html

    return html.escape(text)
