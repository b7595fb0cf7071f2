"""``baselines/demo.py``: the README's pictures are what the README's command draws, and the demo without ``--out``
writes under ``runs/`` of the working folder, never over them.

The pictures are compared as decoded pixels: a pixel differs when one of its channels differs by more than
:data:`LEVELS` of 255, and at most :data:`SHARE` of the pixels may (anti-aliased edges may move by a pixel where
another CPU or library version rounds a coordinate the other way; a stale picture differs in thousands of pixels).
"""

from __future__ import annotations

import argparse
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

import footstep_gym
from script_helpers import load_script

pygame = pytest.importorskip("pygame")

REPO = Path(__file__).resolve().parents[1]
LEVELS = 16
SHARE = 0.002


def readme_command() -> argparse.Namespace:
    """The arguments of the README's demo command (the one under its pictures)."""
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    match = re.search(r"`[^`]*baselines/demo\.py([^`]*)`", readme)
    assert match, "the README shows no baselines/demo.py command"
    return load_script("demo").build_parser().parse_args(shlex.split(match.group(1)))


def decoded(path: Path) -> np.ndarray:
    return pygame.surfarray.array3d(pygame.image.load(str(path))).transpose(1, 0, 2)


def test_the_readme_pictures_are_what_its_command_draws():
    demo = load_script("demo")
    args = readme_command()
    assert args.out == Path("baselines/results/frames")
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    for scene, env_id in footstep_gym.ENV_IDS.items():
        committed = REPO / args.out / demo.picture_name(scene)
        assert f"]({args.out}/{committed.name})" in readme, scene  # the README shows it
        drawn = demo.frame(env_id, args.seed, args.steps)
        shown = decoded(committed)
        assert shown.shape == drawn.shape, scene
        differ = (np.abs(shown.astype(int) - drawn.astype(int)) > LEVELS).any(axis=-1).mean()
        assert differ <= SHARE, (f"{committed.relative_to(REPO)} differs from what the README's command draws in "
                                 f"{100 * differ:.2f} % of its pixels: rerun the command")


def test_without_out_the_demo_writes_under_runs_and_leaves_the_readme_pictures(tmp_path, monkeypatch, capsys):
    frames = REPO / "baselines" / "results" / "frames"
    before = {p.name: p.read_bytes() for p in frames.glob("*.png")}
    monkeypatch.chdir(tmp_path)
    assert load_script("demo").main(["--steps", "1"]) == 0
    assert sorted(p.name for p in (tmp_path / "runs" / "frames").iterdir()) == sorted(
        f"{scene}.png" for scene in footstep_gym.ENV_IDS)
    assert {p.name: p.read_bytes() for p in frames.glob("*.png")} == before
    with pytest.raises(SystemExit):
        load_script("demo").main(["--steps", "0"])
    assert "--steps must be at least 1" in capsys.readouterr().err
