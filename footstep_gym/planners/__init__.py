"""Reference planners (Lee et al.): period search, modified RRT, PSO, and the policies built on them.

The maths here never imports pygame or torch. One module per stage, each with a unit
that returns a small record: :class:`PeriodSearch` -> :class:`PeriodChoice` (stage 1,
:mod:`.period_search` over the walks of :mod:`.rollouts`), :class:`PathSearch` ->
:class:`PathChoice` (stage 2, :mod:`.rrt`), :class:`CommandRepair` ->
:class:`RepairChoice` (stage 3, :mod:`.pso`). :mod:`.staged` holds the planners and :mod:`.oracle`
the upper bound (``oracle``: period-aware told the true future, never a baseline). :mod:`.registry`,
below them, is their registry :data:`POLICIES` (``period-aware``, ``fixed-period``, ``pso-only``,
``paper-period-aware``, ``paper-fixed-period``, ``oracle``) and names their variants: ``<planner>-no-<switch>``
(one of our additions off), ``<planner>-with-<switch>`` (one on, for the paper's planners) and
``paper-period-aware-t0-<s>`` (T0 fixed); the paper's planners follow :data:`PAPER_READINGS` where
the paper differs from our defaults (docs/model.md §5.3). :mod:`.ablation` lists the ablation's
variants. A planner is made by name with :func:`footstep_gym.make_policy`, the one factory of
planners, agents and policies of one's own (:mod:`footstep_gym.registry`; the interface is
:class:`footstep_gym.policy.Policy`).
"""

from footstep_gym.planners.ablation import ablation_variants
from footstep_gym.planners.params import (
    AdditionsParams,
    PeriodSearchParams,
    PlannerConfig,
    PredictionParams,
    PSOOnlyParams,
    PSOParams,
    RRTParams,
    load_planner_config,
)
from footstep_gym.planners.period_search import (
    PeriodChoice,
    PeriodSearch,
    PeriodSearchResult,
    longest_free_period,
    shortest_feasible_period,
    stride_window,
)
from footstep_gym.planners.prediction import BodyModel, ObstaclePredictor, body_path_points
from footstep_gym.planners.pso import (
    CommandRepair,
    PSOResult,
    RepairChoice,
    RepairResult,
    clip_command,
    feasibility_objective,
    increment_bounds,
    minimise,
    repair_command,
)
from footstep_gym.planners.oracle import OraclePlanner
from footstep_gym.planners.registry import (
    PAPER,
    PAPER_READINGS,
    POLICIES,
    PolicySpec,
    policy_spec,
    variant_name,
    with_name,
)
from footstep_gym.planners.rollouts import GoalRollouts, NextNodeFan
from footstep_gym.planners.rrt import ModifiedRRT, PathChoice, PathSearch, RRTPath
from footstep_gym.planners.staged import FixedPeriodPlanner, PeriodAwarePlanner, PSOOnlyPlanner
from footstep_gym.planners.walks import WalkStart, node_of_foot, walk_start

__all__ = [
    "PAPER", "PAPER_READINGS", "POLICIES", "AdditionsParams", "BodyModel", "CommandRepair", "FixedPeriodPlanner",
    "GoalRollouts", "ModifiedRRT", "NextNodeFan", "ObstaclePredictor", "OraclePlanner", "PSOOnlyParams", "PSOOnlyPlanner",
    "PSOParams", "PSOResult", "PathChoice", "PathSearch", "PeriodAwarePlanner", "PeriodChoice", "PeriodSearch",
    "PeriodSearchParams", "PeriodSearchResult", "PlannerConfig", "PolicySpec", "PredictionParams",
    "RRTParams", "RRTPath", "RepairChoice", "RepairResult", "WalkStart", "ablation_variants", "body_path_points",
    "clip_command", "feasibility_objective", "increment_bounds", "load_planner_config", "longest_free_period",
    "minimise", "node_of_foot", "policy_spec", "repair_command", "shortest_feasible_period",
    "stride_window", "variant_name", "walk_start", "with_name",
]
