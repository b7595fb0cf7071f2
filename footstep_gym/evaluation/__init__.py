"""Evaluation of footstep policies (planners and trained agents) over many seeds.

* :mod:`.runner`: episodes (:class:`Cell`, :class:`Task`, :func:`run_episode`) and
  :func:`run_tasks` on local worker processes or Ray;
* :mod:`.stats`: per-cell records (success with a Wilson interval, collisions, falls,
  clearance, ZMP margin, planning time) and summaries over training seeds (rliable IQM);
* the policies come from the one factory :func:`footstep_gym.make_policy` (names in
  :mod:`footstep_gym.policies`; trained agents in :mod:`footstep_gym.rl`);
* :mod:`.splits`: the seed ranges for training, validation and the reported test;
* :mod:`.report`: tables and files; :mod:`.figures`: trajectory pictures and command tables.
* :mod:`.profiles`: a run's profiles, settings and cells; :mod:`.outputs`: a finished run's files;
  :mod:`.outfolder`: ``--out``, written only once a run has finished; :mod:`.benchmark`: the benchmark.

Nothing here imports torch until an agent is loaded, nor matplotlib until a figure is drawn.
"""

from footstep_gym.evaluation.runner import Cell, Task, Trace, run_episode, run_tasks
from footstep_gym.evaluation.splits import SPLITS, split_seeds
from footstep_gym.evaluation.stats import EpisodeResult, cell_record, over_runs, wilson_interval

__all__ = [
    "SPLITS", "Cell", "EpisodeResult", "Task", "Trace", "cell_record", "over_runs", "run_episode", "run_tasks",
    "split_seeds", "wilson_interval",
]
