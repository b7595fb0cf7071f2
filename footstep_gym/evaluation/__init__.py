"""Evaluation of footstep policies (planners and trained agents) over many seeds.

* :mod:`.runner`: episodes (:class:`Cell`, :class:`Task`, :func:`run_episode`) and
  :func:`run_tasks` on local worker processes or Ray;
* :mod:`.records`: a cell's record (:class:`CellRecord`: success with a Wilson interval, collisions, falls,
  clearance, ZMP margin, planning time; each field says how it pools over training runs) and :func:`over_runs`;
  :mod:`.stats`: the Wilson interval and rliable's intervals over training runs;
* the policies come from the registry (:mod:`footstep_gym.registry`; trained agents in :mod:`footstep_gym.rl`):
  a name is resolved once, where a run's settings are made, and its entry travels with the cells to every
  worker (:attr:`Cell.entry`), which builds each episode's policy from it; :mod:`.submission`: a user's
  agents (``--agent [SCENE=]PATH``) and callables (:func:`footstep_gym.benchmark.evaluate`);
* :mod:`.splits`: the seed ranges for training, validation and the reported test;
* :mod:`.report`: an evaluation's tables and files (pandas, :mod:`.tables`); :mod:`.figures`: trajectory pictures
  and command tables.
* :mod:`.profiles`: a run's profiles, settings and cells; :mod:`.outputs`: a finished run's files;
  :mod:`.outfolder`: ``--out``, written only once a run has finished; :mod:`.benchmark`: the benchmark.

Nothing here imports torch until an agent is loaded, nor matplotlib until a figure is drawn.
"""

from footstep_gym.evaluation.runner import Cell, Task, Trace, run_episode, run_tasks
from footstep_gym.evaluation.splits import SPLITS, split_seeds
from footstep_gym.evaluation.records import CellRecord, cell_record, over_runs
from footstep_gym.evaluation.stats import EpisodeResult, wilson_interval

__all__ = [
    "SPLITS", "Cell", "CellRecord", "EpisodeResult", "Task", "Trace", "cell_record", "over_runs", "run_episode",
    "run_tasks", "split_seeds", "wilson_interval",
]
