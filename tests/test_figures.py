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


def test_the_grid_is_near_square_and_at_most_four_wide():
    assert figures.grid_shape(1, 0.8) == (1, 1) and figures.grid_shape(2, 0.8) == (1, 2)
    assert figures.grid_shape(15, 0.8) == (4, 4) and figures.grid_shape(16, 0.7) == (4, 4)
    assert figures.grid_shape(6, 1.5) == (2, 3) and figures.grid_shape(40, 0.5) == (10, 4)


@pytest.mark.parametrize("n", [1, 2, 15])
def test_many_policies_make_a_grid_of_readable_panels(trace, tmp_path, monkeypatch, n):
    saved = []
    original = plt.Figure.savefig
    monkeypatch.setattr(plt.Figure, "savefig", lambda self, *a, **k: (saved.append(self), original(self, *a, **k))[1])
    traces = [dataclasses.replace(trace, policy=f"policy-{k}") for k in range(n)]
    path = figures.episode_figure(traces, tmp_path / "crossing.png", "crossing, seed 20000")
    height, width = plt.imread(path).shape[:2]
    assert width <= min(n, figures.MAX_COLUMNS) * figures.PANEL_W * figures.DPI + 100
    assert height <= 2000  # 15 policies: about 1,800 px, not 7,000
    (fig,) = saved
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(bars) == 1
    box = bars[0].get_position()
    assert 0 <= box.x0 < box.x1 <= 1 and 0 <= box.y0 < box.y1 <= 1  # inside the figure
    panels = [ax for ax in fig.axes if ax.get_title(loc="left").startswith("policy-")]
    assert len(panels) == n and box.y1 <= min(ax.get_position().y0 for ax in panels)  # under the panels
    assert len(fig.legends) == 1
