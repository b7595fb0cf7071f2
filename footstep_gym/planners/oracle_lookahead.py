"""``oracle-lookahead``: the multi-step lookahead planner told the truth. An upper bound, never a baseline.

``lookahead`` (:mod:`.lookahead`) optimises K footsteps with their periods by the cross-entropy method, seeded by
the greedy ``period-aware``'s plan; ``oracle-lookahead`` (:class:`OracleLookaheadPlanner`) is the same search with
the truth in both places: its greedy seed is the ``oracle`` (:class:`~footstep_gym.planners.oracle.OraclePlanner`,
period-aware told the truth), and its rollouts check the body against every obstacle's true future
(:class:`ScheduleTruth`: the env's own model of each obstacle, :class:`~footstep_gym.planners.oracle.TruthModel`)
on the true, noise-free snapshot. It is the solvability reference of protocol 3 (docs/benchmark.md §5): where the
greedy oracle fails because greed fails (the stream's gap, a door from any phase), the lookahead can wait or
reposition. It reads the truth through the same labelled door as the oracle (``reads_truth``,
:meth:`OracleLookaheadPlanner.bind_truth`, called by the evaluation runner), refuses to act unbound, and is marked
"(upper bound)" in every table.

**Approximation (documented).** The oracle's truth places a scheduled shape (a crowd member, the stream's cars)
at the boundaries of a walk of one period; a rollout's steps each have their own period, so the rollouts read the
truth on a fine grid of :data:`TRUTH_STEP_S` instead: each shape at its scheduled place every 0.1 s and on the
chord between (the scripted crowd), or at its own velocity from there (steady traffic). The env takes the same
chords between footstep boundaries, so the two agree at every boundary that falls on the grid and differ by
the chord's sag between (millimetres at the crowd's speeds and curvature). Its budget (``configs/planner.yaml``'s
``lookahead`` section, overridden by the registry: :data:`BUDGET`) is larger than ``lookahead``'s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from footstep_gym.planners.lookahead import LookaheadPlanner
from footstep_gym.planners.oracle import ORCA_HORIZON_S, OraclePlanner, TruthBound, TruthModel, TruthPredictor
from footstep_gym.planners.params import PlannerConfig
from footstep_gym.planners.prediction import ObstaclePredictor
from footstep_gym.robot import Robot
from footstep_gym.sensing import Snapshot

#: [s] The grid on which the rollouts read the truth (the module's doc).
TRUTH_STEP_S = 0.1
#: The search's budget (``lookahead`` keys of configs/planner.yaml set by the registry): a longer horizon (6
#: footsteps, 4.8 s at the nominal period: a stream's gap comes round in about that), twice the samples and more
#: iterations than ``lookahead``'s 4 x 64 x 4.
BUDGET = {"horizon_steps": 6, "samples": 128, "iterations": 5}

#: The registry's one line on it.
DESCRIPTION = ("UPPER BOUND, not a baseline: lookahead (K footsteps by the cross-entropy method) told every "
               "obstacle's true future, seeded by the oracle; the solvability reference; runs only where the "
               "evaluation binds it to the env (bind_truth)")


class ScheduleTruth(TruthPredictor):
    """A :class:`~footstep_gym.planners.oracle.TruthPredictor` that answers the constant-velocity predictor's
    questions (``clearance(points, times)``, ``free(points, times, d)``) from the truth read on the
    :data:`TRUTH_STEP_S` grid, whatever the period of the step a point belongs to."""

    def clearance(self, points: np.ndarray, times: np.ndarray) -> np.ndarray:
        return self.clearance_at(points, times, TRUTH_STEP_S)

    def free(self, points: np.ndarray, times: np.ndarray, safe_distance: float) -> np.ndarray:
        return self.free_at(points, times, safe_distance, TRUTH_STEP_S)


class OracleLookaheadPlanner(TruthBound, LookaheadPlanner):
    """``lookahead`` told the truth (the module's doc): an upper bound, labelled so in every table. Bound to its env
    (:meth:`bind_truth`), it binds its greedy oracle too; unbound, :meth:`act` raises ``RuntimeError``."""

    name = "oracle-lookahead"
    greedy_class = OraclePlanner

    def __init__(self, robot: Robot, config: PlannerConfig, seed: int | None = None, name: str | None = None) -> None:
        if not config.lookahead.greedy_seed:
            raise ValueError("oracle-lookahead is seeded by the oracle: lookahead.greedy_seed must be true")
        super().__init__(robot, config, seed, name)
        self._env: Any = None

    def bind_truth(self, env: Any) -> None:
        """Let the planner read the truth of ``env``, and its greedy oracle with it (the same door: the runner
        binds the planner, the planner shares it with the part of itself that plans on it)."""
        self._env = self.greedy._env = getattr(env, "unwrapped", env)

    def _rollout_predictor(self, snapshot: Snapshot) -> ObstaclePredictor:
        """The truth the greedy oracle has just planned on (this call's, built from the same env at the same instant
        with the same horizons: the same model, not built twice; an ORCA crowd's forward run is the costly part), read
        on the :data:`TRUTH_STEP_S` grid."""
        horizon = self.config.prediction.horizon_s
        greedy = self.greedy.predictor
        truth = greedy.truth if isinstance(greedy, TruthPredictor) else None
        if (truth is None or truth.t0 != float(self._env.time) or truth.horizon != float(horizon)
                or truth.orca_horizon != ORCA_HORIZON_S):
            truth = TruthModel(self._env, snapshot.obstacles, horizon, ORCA_HORIZON_S)
        return ScheduleTruth(snapshot, truth, horizon)
