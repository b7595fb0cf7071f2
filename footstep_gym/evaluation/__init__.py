"""Evaluation of footstep policies (planners and trained agents) over many seeds.

* :mod:`.runner`: episodes (:class:`Cell`, :class:`Task`, :func:`run_episode`) and
  :func:`run_tasks` on local worker processes or Ray;
* :mod:`.stats`: per-cell records (success with a Wilson interval, collisions, falls,
  clearance, ZMP margin, planning time) and summaries over training seeds (rliable IQM);
* :mod:`.policies`: one registry of planners and agents; :mod:`.agents`: rl_zoo3 runs as policies;
* :mod:`.splits`: the seed ranges for training, validation and the reported test;
* :mod:`.report`: tables and files; :mod:`.figures`: trajectory pictures and command tables.

Nothing here imports torch until an agent is loaded, nor matplotlib until a figure is drawn.
"""

from footstep_gym.evaluation.policies import AGENTS, agent_runs, make_policy, policy_names
from footstep_gym.evaluation.runner import Cell, Task, Trace, run_episode, run_tasks
from footstep_gym.evaluation.splits import SPLITS, split_seeds
from footstep_gym.evaluation.stats import EpisodeResult, cell_record, over_runs, wilson_interval

__all__ = [
    "AGENTS", "SPLITS", "Cell", "EpisodeResult", "Task", "Trace", "agent_runs", "cell_record", "make_policy",
    "over_runs", "policy_names", "run_episode", "run_tasks", "split_seeds", "wilson_interval",
]
