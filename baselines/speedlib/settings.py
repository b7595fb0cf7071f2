"""How much the speed run (``baselines/speed.py``) measures (:class:`Settings`, one per mode in :data:`MODES`), its sections, and
its progress lines (:func:`log`, on stderr: stdout carries only the report). Standard library only."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

#: The speed run's sections, in the order of ``--sections``' default.
SECTIONS = ("env", "lipm", "planners", "memory", "ppo", "tiers")


@dataclass(frozen=True)
class Settings:
    """How much to measure; one instance per mode (quick / full / smoke)."""

    name: str
    repetitions: int  # timed repetitions per env cell and LIPM cell
    rep_seconds: float  # target duration of one repetition (steps per rep calibrated from the warm-up)
    warmup_seconds: float
    min_steps: int  # at least this many steps per repetition
    vec_repetitions: int
    vec_rep_seconds: float
    lipm_rep_seconds: float
    planner_episodes: int  # seeds per env (the same seeds for every planner)
    planner_max_steps: int | None  # cap on footsteps per planner episode (smoke only; None = the env's limit)
    #: untimed acts of each planner on each env before its timed episodes: the evaluation runner's warm-up
    #: (footstep_gym.evaluation.runner.warm_up, once per process and cell; its WARMUP_ACTS is 10)
    planner_warmup_steps: int
    planner_budget_s: float | None  # per env: no new seed after this (>= 2 seeds always run); None = no limit
    memory_steps: int  # env steps in the env's memory probe
    memory_acts: int  # planner acts in the planner's memory probe
    memory_budget_s: float | None  # a memory probe stops stepping after this (>= 1 step always runs)
    action_pool: int  # distinct pre-sampled commands per env cell (cycled; sampling is outside the timing)
    ppo_timesteps: int  # env steps of each timed PPO.learn (after a warm-up of one rollout)
    ppo_rounds: int  # interleaved rounds of the PPO cells
    #: the tiers section (speedlib.tier_rates): at most this many cells per scene and tier, in the file's
    #: order (None = every cell); the seeds per cell are planner_episodes, its env repetitions `repetitions`
    tier_max_cells: int | None = None
    tier_budget_s: float | None = None  # per tier cell: no new planner seed after this (>= 1 seed always runs)


MODES = {
    "smoke": Settings("smoke", repetitions=2, rep_seconds=0.02, warmup_seconds=0.01, min_steps=5,
                      vec_repetitions=2, vec_rep_seconds=0.02, lipm_rep_seconds=0.01,
                      planner_episodes=1, planner_max_steps=2, planner_warmup_steps=1, planner_budget_s=None,
                      memory_steps=20, memory_acts=2, memory_budget_s=None, action_pool=64,
                      ppo_timesteps=128, ppo_rounds=1, tier_max_cells=1, tier_budget_s=None),
    "quick": Settings("quick", repetitions=7, rep_seconds=0.25, warmup_seconds=0.2, min_steps=50,
                      vec_repetitions=5, vec_rep_seconds=0.25, lipm_rep_seconds=0.1,
                      planner_episodes=4, planner_max_steps=None, planner_warmup_steps=10, planner_budget_s=45.0,
                      memory_steps=500, memory_acts=50, memory_budget_s=15.0, action_pool=1024,
                      ppo_timesteps=2048, ppo_rounds=2, tier_max_cells=None, tier_budget_s=10.0),
    "full": Settings("full", repetitions=21, rep_seconds=0.5, warmup_seconds=0.5, min_steps=200,
                     vec_repetitions=11, vec_rep_seconds=0.5, lipm_rep_seconds=0.3,
                     planner_episodes=12, planner_max_steps=None, planner_warmup_steps=10, planner_budget_s=600.0,
                     memory_steps=2000, memory_acts=200, memory_budget_s=120.0, action_pool=4096,
                     ppo_timesteps=8192, ppo_rounds=3, tier_max_cells=None, tier_budget_s=40.0),
}

_T0 = time.perf_counter()


def log(msg: str) -> None:
    """Progress on stderr (stdout carries only the report), with the time since start."""
    print(f"[{time.perf_counter() - _T0:6.1f} s] {msg}", file=sys.stderr, flush=True)


def error(exc: BaseException) -> str:
    """``"Type: message"`` of an exception, at most 300 characters (what a skipped cell says)."""
    return f"{type(exc).__name__}: {exc}"[:300]
