"""Scores that hide no cell and safe success (docs/benchmark.md §2, §4), against closed forms: a hand-computed
scene-balanced mean, bootstraps on degenerate cases and on the binomial's normal approximation, the normalised
score's anchors, rliable's probability of improvement on one-run matrices, and safe success per episode."""

from __future__ import annotations

import math

import numpy as np
import pytest

from footstep_gym.evaluation import scores
from footstep_gym.evaluation.records import cell_record
from footstep_gym.evaluation.stats import EpisodeResult


def test_the_balanced_mean_weighs_scenes_then_cells():
    cells = ["door/a", "door/b", "crowd/c"]
    assert scores.balanced_mean([1.0, 0.0, 0.4], cells) == pytest.approx((0.5 + 0.4) / 2, abs=1e-15)
    seven = [f"door/{k}" for k in range(2)] + [f"crowd/{k}" for k in range(5)]
    w = scores.balanced_weights(seven)
    assert w.tolist() == [0.25, 0.25, 0.1, 0.1, 0.1, 0.1, 0.1] and math.isclose(w.sum(), 1.0)
    with pytest.raises(ValueError, match="one value per cell"):
        scores.balanced_mean([1.0], cells)


def test_the_hierarchical_bootstrap_of_degenerate_cases_is_exact():
    cells = ["door/a", "crowd/b"]
    assert scores.hierarchical_bootstrap([[10, 10]], [[10, 10]], cells, reps=200) == (1.0, 1.0, 1.0)
    assert scores.hierarchical_bootstrap([[0, 0], [0, 0]], [[10, 10], [10, 10]], cells, reps=200) == (0.0, 0.0, 0.0)
    # Two runs, one at 0 and one at 1, every episode alike: only the runs' draw varies, the mean of two drawn runs
    # is 0, 1/2 or 1 with probabilities 1/4, 1/2, 1/4: the interval is [0, 1] around 1/2.
    assert scores.hierarchical_bootstrap([[0], [10]], [[10], [10]], ["door/a"], reps=400) == (0.5, 0.0, 1.0)


def test_a_one_run_interval_is_the_episodes_binomial_noise():
    # One run, one cell, 200 of 400: the interval is about p +- 1.96 sqrt(p (1 - p) / n) = 0.5 +- 0.049.
    score, lo, hi = scores.hierarchical_bootstrap([[200]], [[400]], ["door/a"], reps=4000, seed=1)
    half = 1.959964 * math.sqrt(0.25 / 400)
    assert score == 0.5 and lo == pytest.approx(0.5 - half, abs=0.006) and hi == pytest.approx(0.5 + half, abs=0.006)


def test_the_bootstrap_is_seeded_and_leaves_numpys_generator_alone():
    np.random.seed(3)
    expected = np.random.random()
    np.random.seed(3)
    a = scores.hierarchical_bootstrap([[3, 7], [5, 9]], [[10, 10], [10, 10]], ["door/a", "crowd/b"], reps=300)
    assert np.random.random() == expected
    assert a == scores.hierarchical_bootstrap([[3, 7], [5, 9]], [[10, 10], [10, 10]], ["door/a", "crowd/b"], reps=300)
    with pytest.raises(ValueError, match="successes <= episodes"):
        scores.hierarchical_bootstrap([[11]], [[10]], ["door/a"])


def test_the_normalised_score_and_the_probability_of_improvement():
    assert scores.normalised(0.5, 0.2, 0.8) == pytest.approx(0.5)
    assert scores.normalised(0.2, 0.2, 0.8) == 0.0 and scores.normalised(0.8, 0.2, 0.8) == 1.0
    assert math.isnan(scores.normalised(0.5, 0.7, 0.7))
    # One run each: per cell 1 (better), 1/2 (tie), 0 (worse); averaged over the cells.
    assert scores.probability_of_improvement([[1.0, 0.3, 0.2]], [[0.0, 0.3, 0.9]]) == pytest.approx(0.5)
    assert scores.probability_of_improvement([[1.0, 0.3]], [[0.0, 0.3]]) == pytest.approx(0.75)
    # Two runs against one: on the cell, X beats Y in one pair of two.
    assert scores.probability_of_improvement([[0.9], [0.1]], [[0.5]]) == pytest.approx(0.5)


def _episode(seed: int, outcome: str, clearance: float | None, margin: float | None) -> EpisodeResult:
    return EpisodeResult(cell_index=0, seed=seed, outcome=outcome, steps=10, time=5.0, path_length=2.0,
                         com_path_length=2.0, plan_ms=[1.0], periods=[0.5], pso_ran=[None], min_clearance=clearance,
                         min_zmp_margin=margin)


def test_safe_success_needs_the_goal_clearance_and_zmp_margin():
    t = scores.safety_thresholds()
    assert (t.min_clearance, t.min_zmp_margin) == (0.02, 0.005)  # configs/eval.yaml
    assert scores.safe_success("goal", 0.02, 0.005) and scores.safe_success("goal", None, 0.01)
    assert not scores.safe_success("goal", 0.019, 0.01) and not scores.safe_success("goal", 0.05, 0.004)
    assert not scores.safe_success("collision", 0.05, 0.01) and not scores.safe_success("goal", 0.05, None)
    episodes = [_episode(1, "goal", 0.05, 0.01), _episode(2, "goal", 0.01, 0.01), _episode(3, "goal", None, 0.006),
                _episode(4, "timeout", 0.5, 0.02)]
    r = cell_record("FootstepDoor-v0", "door", "p", {}, episodes)
    assert (r.successes, r.safe_successes, r.safe_success_rate) == (3, 2, 0.5)


def _records(policy: str, tier: str, rates: dict[str, list[int]], upper: bool = False) -> list:
    """Benchmark records of ``policy`` on ``tier``: ``rates[scene/cell]`` lists each training run's successes of 10."""
    out = []
    for label, wins in rates.items():
        scene, cell = label.split("/")
        for k, w in enumerate(wins):
            eps = [_episode(s, "goal" if s < w else "collision", 0.05, 0.01) for s in range(10)]
            out.append(cell_record("FootstepDoor-v0", scene, policy, {}, eps, run=f"r{k}" if len(wins) > 1 else None,
                                   scene=scene, tier=tier, cell=cell, upper_bound=upper))
    return out


def test_the_board_scores_normalise_between_the_anchors_and_rank_without_paper():
    cells = {"paper": ["door/p"], "train": ["door/a", "crowd/b", "crowd/c"]}
    reactive = _records("wait-until-clear", "train", {"door/a": [2], "crowd/b": [0], "crowd/c": [4]}) + \
        _records("wait-until-clear", "paper", {"door/p": [10]})
    privileged = _records("oracle", "train", {"door/a": [10], "crowd/b": [8], "crowd/c": [10]}, upper=True) + \
        _records("oracle", "paper", {"door/p": [10]}, upper=True)
    method = _records("mine", "train", {"door/a": [6, 8], "crowd/b": [4, 6], "crowd/c": [7, 7]}) + \
        _records("mine", "paper", {"door/p": [0, 0]})
    board = scores.board_scores([("wait-until-clear", False, reactive), ("oracle", True, privileged),
                                 ("mine", False, method)], cells, reps=50)
    mine = next(r for r in board["tiers"] if r["policy"] == "mine" and r["tier"] == "train")
    # Balanced means: mine (0.7 + (0.5 + 0.7) / 2) / 2 = 0.65; reactive (0.2 + 0.2) / 2 = 0.2; privileged
    # (1.0 + 0.9) / 2 = 0.95: normalised (0.65 - 0.2) / (0.95 - 0.2) = 0.6.
    assert mine["success"] == pytest.approx(0.65) and mine["normalised"] == pytest.approx(0.6)
    a = next(r for r in board["cells"] if r["policy"] == "mine" and r["cell"] == "door/a")
    assert a["success"] == pytest.approx(0.7) and a["normalised"] == pytest.approx((0.7 - 0.2) / 0.8)
    # paper is not ranked (mine scores 0 there, the reactive 1); the privileged row is not ranked at all.
    assert [r["policy"] for r in board["ranking"]] == ["mine", "wait-until-clear"] and board["ranked_tiers"] == ["train"]
    assert board["ranking"][0]["score"] == pytest.approx(0.65) and board["ranking"][0]["safe_score"] == pytest.approx(0.65)
    # P(mine > reactive) over the ranked cells, two runs against one: cells a, b, c all better in both runs.
    assert board["ranking"][0]["p_improvement"] == pytest.approx(1.0) and board["ranking"][1]["p_improvement"] is None


def test_in_distribution_rows_are_scored_on_their_tier_and_are_never_anchors_nor_ranked():
    cells = {"train": ["door/a", "crowd/b", "crowd/c"]}
    reactive = _records("wait-until-clear", "train", {"door/a": [2], "crowd/b": [0], "crowd/c": [4]})
    privileged = _records("oracle", "train", {"door/a": [10], "crowd/b": [8], "crowd/c": [10]}, upper=True)
    trained = _records("mine-train", "train", {"door/a": [10, 10], "crowd/b": [10, 10], "crowd/c": [9, 10]})
    board = scores.board_scores([("wait-until-clear", False, reactive), ("oracle", True, privileged)], cells,
                                reps=50, in_distribution=[("mine-train", "train", trained)])
    row = next(r for r in board["tiers"] if r["policy"] == "mine-train")
    # Balanced: (1.0 + (1.0 + 0.95) / 2) / 2 = 0.9875. The anchors stay the generalisation rows' (reactive 0.2,
    # privileged (1.0 + 0.9) / 2 = 0.95), so a row trained on the tier may score above 1.
    assert row["trained_on_tier"] == "train" and row["success"] == pytest.approx(0.9875)
    assert row["normalised"] == pytest.approx((0.9875 - 0.2) / 0.75)
    oracle = next(r for r in board["tiers"] if r["policy"] == "oracle")
    assert oracle["trained_on_tier"] is None and oracle["normalised"] == pytest.approx(1.0)
    assert [r["policy"] for r in board["ranking"]] == ["wait-until-clear"]
    # A row that does not cover its tier is not scored.
    short = scores.board_scores([("oracle", True, privileged)], cells, reps=50,
                                in_distribution=[("half", "train", trained[:2])])
    assert not any(r["policy"] == "half" for r in short["tiers"])
