"""The evaluation's figure of one setting stays readable with every policy in it: a grid of panels of a fixed width
(about 420 px), the time colour bar under them inside the figure, one legend."""

from __future__ import annotations

import dataclasses

import matplotlib.pyplot as plt
import pytest

from footstep_gym.evaluation import figures
from footstep_gym.evaluation.runner import Cell, Task, run_episode


@pytest.fixture(scope="module")
def trace():
    return run_episode(Task(0, Cell("FootstepCrossing-v0", "crossing", "fixed-period"), 20000, record=True)).trace


@pytest.mark.parametrize("n, rows, cols", [(1, 1, 1), (2, 1, 2), (15, 4, 4)])
def test_many_policies_make_a_grid_of_readable_panels(trace, tmp_path, monkeypatch, n, rows, cols):
    assert figures.grid_shape(n, wide=False) == (rows, cols)
    saved = []
    original = plt.Figure.savefig
    monkeypatch.setattr(plt.Figure, "savefig", lambda self, *a, **k: (saved.append(self), original(self, *a, **k))[1])
    traces = [dataclasses.replace(trace, policy=f"policy-{k}") for k in range(n)]
    path = figures.episode_figure(traces, tmp_path / "crossing.png", "crossing, seed 20000")
    height, width = plt.imread(path).shape[:2]
    assert width <= cols * figures.PANEL_W * figures.DPI + 100
    assert height <= rows * 5.5 * figures.DPI + 200  # 15 policies: about 1,800 px, not 7,000
    (fig,) = saved
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 1
    box = bars[0].get_position()
    assert 0 <= box.x0 < box.x1 <= 1 and 0 <= box.y0 < box.y1 <= 1  # inside the figure
    panels = [ax for ax in fig.axes if ax.get_title(loc="left").startswith("policy-")]
    assert len(panels) == n and box.y1 <= min(ax.get_position().y0 for ax in panels)  # under the panels
    assert len(fig.legends) == 1
