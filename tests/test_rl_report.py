"""The learning-curve plots of a short run (one validation point) show that point: a line of one point draws
nothing, so every curve of a few points carries a marker on each. Checked on the figures as they are saved."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

matplotlib = pytest.importorskip("matplotlib")
from footstep_gym.rl import report, training  # noqa: E402


def short_run(folder: Path, seed: int, success: float) -> Path:
    run = folder / "ppo" / f"FootstepDoor-v0_{seed}"
    run.mkdir(parents=True)
    (run / training.VALIDATION_CURVE).write_text(
        f"timesteps,wall_time_s,success_rate,episodes\n1000,5.0,{success:.4f},20\n", encoding="utf-8")
    (run / "manifest.json").write_text(json.dumps({"env_id": "FootstepDoor-v0", "algorithm": "ppo", "seed": seed,
                                                   "timesteps": 1000, "wall_time_s": 5.0, "env_steps_per_s": 200.0,
                                                   "final_eval_success": success}), encoding="utf-8")
    return run


@pytest.fixture
def saved(monkeypatch):
    """The figures saved while the test runs."""
    from matplotlib.figure import Figure

    figures = []
    original = Figure.savefig

    def savefig(self, *args, **kwargs):
        figures.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return figures


def curves(figure) -> list:
    """The data lines of a figure (not the reference lines across the axes)."""
    return [line for ax in figure.axes for line in ax.get_lines() if len(line.get_xdata()) and
            not line.get_label().startswith("_")]


@pytest.mark.parametrize("runs", [1, 2])
def test_a_one_point_curve_is_drawn_with_a_marker(tmp_path, saved, runs):
    agents = tmp_path / "agents"
    made = [short_run(agents, seed, 0.5 + 0.2 * seed) for seed in range(1, runs + 1)]
    report.scene_curves(agents, tmp_path / "curves")
    training.learning_curves(made, tmp_path / "ppo.png", "one point")
    assert len(saved) == 2
    for figure in saved:
        lines = curves(figure)
        assert lines and all(len(line.get_xdata()) == 1 for line in lines)
        assert all(line.get_marker() not in (None, "", "None", " ") for line in lines), \
            [line.get_label() for line in lines]
