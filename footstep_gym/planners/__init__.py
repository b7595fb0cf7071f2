"""Reference planners (Lee et al.): period search, modified RRT, PSO, and the policies built on them.

The maths here never imports pygame or torch. See :mod:`.reference` for the policy
interface and the three planners (``period-aware``, ``fixed-period``, ``pso-only``).
"""

from footstep_gym.planners.params import (
    PeriodSearchParams,
    PlannerConfig,
    PredictionParams,
    PSOOnlyParams,
    PSOParams,
    RRTParams,
    load_planner_config,
)
from footstep_gym.planners.period_search import (
    GoalRollouts,
    PeriodSearchResult,
    WalkStart,
    longest_free_period,
    node_of_foot,
    shortest_feasible_period,
    walk_start,
)
from footstep_gym.planners.prediction import ObstaclePredictor, body_path_points
from footstep_gym.planners.pso import (
    PSOResult,
    RepairResult,
    clip_command,
    feasibility_objective,
    increment_bounds,
    minimise,
    repair_command,
)
from footstep_gym.planners.reference import (
    POLICIES,
    FixedPeriodPlanner,
    PeriodAwarePlanner,
    Policy,
    PSOOnlyPlanner,
    make_policy,
)
from footstep_gym.planners.rrt import ModifiedRRT, RRTPath

__all__ = [
    "POLICIES", "FixedPeriodPlanner", "GoalRollouts", "ModifiedRRT", "ObstaclePredictor", "PSOOnlyParams",
    "PSOOnlyPlanner", "PSOParams", "PSOResult", "PeriodAwarePlanner", "PeriodSearchParams", "PeriodSearchResult",
    "PlannerConfig", "Policy", "PredictionParams", "RRTParams", "RRTPath", "RepairResult", "WalkStart",
    "body_path_points", "clip_command", "feasibility_objective", "increment_bounds", "load_planner_config",
    "longest_free_period", "make_policy", "minimise", "node_of_foot", "repair_command",
    "shortest_feasible_period", "walk_start",
]
