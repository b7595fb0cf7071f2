"""The README and docs/ hold what the code and the committed results say.

* ``docs/results.md`` (generated whole) and the generated blocks of ``README.md``, ``docs/benchmark.md`` and
  ``docs/speed.md`` (cog's) equal what ``baselines/make_results_doc.py`` writes from the committed result files and
  ``configs/eval.yaml``, and the script follows a change of those files;
* every relative link (and image) of the README and of ``docs/*.md`` resolves to a file, and every ``#anchor`` to
  a heading of its page;
* every Python snippet of the README and docs/env.md runs as written (in a temporary folder: nothing is written
  into the checkout);
* the README is a guide of at most 350 lines, and its two commands are the ones ``.ci/run`` and a newcomer use.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from footstep_gym.evaluation import results_doc
from footstep_gym.evaluation.splits import PROTOCOL_VERSION, SPLITS

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "baselines" / "make_results_doc.py"
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
QUICK_START = ('python3 -m venv .venv && .venv/bin/pip install -c constraints.txt torch==2.13.0 -e ".[dev]" && '
               '.venv/bin/python baselines/eval_planner.py')
TEST_COMMAND = ".venv/bin/python -m pytest -q -n 2"


# ---------------------------------------------------------------- generated pages
def test_generated_pages_match_the_committed_results():
    stale = results_doc.stale_docs(REPO)
    assert not stale, (f"{', '.join(map(str, stale))} differ(s) from the committed result files: run "
                       f"python baselines/make_results_doc.py (and commit the pages with the results)")


def test_the_script_checks_and_rewrites_a_stale_page(tmp_path):
    """A copy of the repository's result files, one of them changed: --check fails, the script rewrites the pages
    from the changed file; a changed evaluation changes docs/results.md, a changed leaderboard row the README's table
    too."""
    repo = tmp_path / "repo"
    shutil.copytree(REPO / "baselines" / "results", repo / "baselines" / "results",
                    ignore=shutil.ignore_patterns("episodes.csv", "tables", "runs"))
    for manifest in (REPO / "baselines" / "agents").glob("*/*/manifest.json"):
        dest = repo / manifest.relative_to(REPO)
        dest.parent.mkdir(parents=True)
        shutil.copy(manifest, dest)
    (repo / "docs").mkdir()
    for rel in (results_doc.RESULTS_DOC, *results_doc.COG_PAGES):
        shutil.copy(REPO / rel, repo / rel)
    run = lambda *args: subprocess.run([sys.executable, str(SCRIPT), "--repo", str(repo), *args],  # noqa: E731
                                       capture_output=True, text=True, cwd=REPO, timeout=120)
    assert run("--check").returncode == 0

    results = repo / "baselines" / "results" / "agents" / "results.json"
    records = json.loads(results.read_text(encoding="utf-8"))
    cell = next(r for r in records if r["policy"] == "fixed-period" and r["params"] == {"door_speed": 8.0})
    cell["success_ci95"] = [0.123, 0.987]
    results.write_text(json.dumps(records), encoding="utf-8")
    checked = run("--check")
    assert checked.returncode == 1
    assert "docs/results.md" in checked.stderr and "README.md" not in checked.stderr
    assert run().returncode == 0
    assert run("--check").returncode == 0
    assert "[0.12, 0.99]" in (repo / results_doc.RESULTS_DOC).read_text(encoding="utf-8")

    board_path = repo / results_doc.LEADERBOARD.with_suffix(".json")
    board = json.loads(board_path.read_text(encoding="utf-8"))
    # the README shows the shown board's (protocol 3's) scene-balanced scores
    row = next(a for a in board["scores"]["tiers"] if a["policy"] == "lookahead" and a["tier"] == "structure")
    row["success"], row["success_ci95"] = 0.345, [0.234, 0.456]
    board_path.write_text(json.dumps(board), encoding="utf-8")
    checked = run("--check")
    assert checked.returncode == 1 and "README.md" in checked.stderr
    assert run().returncode == 0 and run("--check").returncode == 0
    assert "0.34 [0.23, 0.46]" in (repo / results_doc.README).read_text(encoding="utf-8")
    for rel in (results_doc.BENCHMARK_DOC, results_doc.SPEED_DOC):
        assert (repo / rel).read_text(encoding="utf-8") == (REPO / rel).read_text(encoding="utf-8")


def test_a_new_evaluation_folder_gets_its_own_section(tmp_path):
    results = tmp_path / "baselines" / "results"
    shutil.copytree(REPO / "baselines" / "results" / "robustness", results / "my_sweep",
                    ignore=shutil.ignore_patterns("episodes.csv", "tables", "figures"))
    text = results_doc.results_markdown(tmp_path)
    assert "## Evaluation `my_sweep`" in text and "baselines/results/my_sweep/summary.md" in text


def test_cog_fills_the_blocks_and_names_a_bad_one(tmp_path):
    """The pages' blocks are cog's: the text between a block's code and its end is replaced, the rest kept; an
    unknown block name is refused by name; a block without its end is cog's error."""
    page = REPO / results_doc.README
    text = ("a\n<!-- [[[cog import footstep_gym.evaluation.results_doc as r; r.cog_block(cog, \"splits\") ]]] -->\n"
            "old\n<!-- [[[end]]] -->\nb\n")
    done = results_doc.cog_page(page, text)
    assert done.startswith("a\n<!-- [[[cog") and done.endswith("\n<!-- [[[end]]] -->\nb\n") and "old" not in done
    assert results_doc.splits_block(REPO) in done
    with pytest.raises(ValueError, match="unknown generated block 'split'; known: leaderboard_headline, splits"):
        results_doc.cog_page(page, text.replace('"splits"', '"split"'))
    with pytest.raises(ValueError, match=r"Missing '\[\[\[end\]\]\]'"):
        results_doc.cog_page(page, text.replace("<!-- [[[end]]] -->\n", ""))
    assert results_doc.repo_of(REPO / results_doc.SPEED_DOC) == REPO


def test_the_pages_give_the_splits_of_the_config():
    """The seed splits on the pages are configs/eval.yaml's (the block), and no page names another test range as
    the test split."""
    first, end = SPLITS["test"]
    assert results_doc.splits_text().endswith(f"test {first}–{end - 1} (`configs/eval.yaml`, protocol "
                                              f"{PROTOCOL_VERSION})")
    for rel in (results_doc.README, results_doc.BENCHMARK_DOC, results_doc.RESULTS_DOC):
        assert results_doc.splits_text() in (REPO / rel).read_text(encoding="utf-8"), rel
    stated = re.compile(r"test (?:split )?\(?(\d{5})[-–](\d{5})")
    for page in PAGES:
        for lo, hi in stated.findall(page.read_text(encoding="utf-8")):
            assert (int(lo), int(hi)) == (first, end - 1), f"{page.name} gives the test split as {lo}-{hi}"


def test_cog_itself_checks_the_pages():
    """``cog --check`` (the standard tool, without our script) finds the committed pages up to date."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-m", "cogapp", "--check", *(str(REPO / p) for p in results_doc.COG_PAGES)],
                          capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr


# ---------------------------------------------------------------- links
_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
_FENCE = re.compile(r"```.*?```", re.S)


def _anchors(page: Path) -> set[str]:
    """GitHub's anchors of the page's headings (a repeated heading gets -1, -2, ...)."""
    seen: dict[str, int] = {}
    out = set()
    for line in _FENCE.sub("", page.read_text(encoding="utf-8")).splitlines():
        match = re.match(r"#{1,6} (.+)", line)
        if match:
            base = results_doc.anchor(match.group(1).strip())
            n = seen.get(base, 0)
            seen[base] = n + 1
            out.add(base if n == 0 else f"{base}-{n}")
    return out


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(REPO)) for p in PAGES])
def test_relative_links_resolve(page):
    text = _FENCE.sub("", page.read_text(encoding="utf-8"))
    bad = []
    for target in _LINK.findall(text):
        if re.match(r"[a-z]+:", target):  # http(s):, mailto:
            continue
        path, _, fragment = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            bad.append(f"{target}: no such file")
        elif fragment and dest.suffix == ".md" and fragment not in _anchors(dest):
            bad.append(f"{target}: no heading with that anchor in {dest.name}")
    assert not bad, f"{page.relative_to(REPO)}: " + "; ".join(bad)


# ---------------------------------------------------------------- snippets and commands
#: The pages whose Python snippets run as written.
SNIPPET_PAGES = (REPO / "README.md", REPO / "docs" / "env.md")


def _snippets(page: Path = REPO / "README.md") -> list[str]:
    return re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), re.S)


def _snippet_params():
    for page in SNIPPET_PAGES:
        for i, code in enumerate(_snippets(page)):
            slow = any(word in code for word in ("agent_runs", "RecordVideo", "make_vec"))  # torch, a video, JAX
            yield pytest.param(code, id=f"{page.relative_to(REPO)}:snippet{i}",
                               marks=[pytest.mark.slow] if slow else [])


@pytest.mark.parametrize("code", list(_snippet_params()))
def test_readme_python_snippet_runs(code, tmp_path):
    """As a reader would run it, in a fresh interpreter, but in a temporary folder: what a snippet writes (runs/)
    lands there, not in the checkout. The shipped agents are named by ``$FOOTSTEP_GYM_AGENTS_DIR``, as a reader
    outside the checkout's root names them."""
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy",
           "PYTHONPATH": os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])]),
           "FOOTSTEP_GYM_AGENTS_DIR": str(REPO / "baselines" / "agents")}
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, f"the snippet failed:\n{code}\n--- stderr:\n{done.stderr[-3000:]}"
    if "RecordVideo" in code:
        assert list((tmp_path / "runs" / "videos").glob("*.mp4"))  # it wrote where it says, in the cwd


def test_readme_is_a_guide_with_snippets_and_the_two_commands():
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 350, "the README is a guide of at most 350 lines: results go to docs/"
    assert len(_snippets()) >= 3
    blocks = re.findall(r"```bash\n(.*?)```", readme, re.S)
    assert QUICK_START in [b.strip() for b in blocks]
    assert TEST_COMMAND in [b.strip() for b in blocks]
    assert TEST_COMMAND in (REPO / ".ci" / "run").read_text(encoding="utf-8")


def test_readme_has_a_table_of_contents_of_its_sections():
    readme = REPO / "README.md"
    text = readme.read_text(encoding="utf-8")
    sections = [results_doc.anchor(h) for h in re.findall(r"^## (.+)$", _FENCE.sub("", text), re.M)]
    contents = text.split("## ", 1)[0]
    missing = [s for s in sections if f"(#{s})" not in contents]
    assert not missing, f"README sections missing from its contents: {missing}"
