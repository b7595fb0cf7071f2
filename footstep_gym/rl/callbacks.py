"""Training callbacks for rl_zoo3 runs: success on the validation split as training goes.

The zoo's own ``EvalCallback`` plays episodes of an env seeded from the *training* seed, and
without ``--eval-env-kwargs`` on the scene's default settings, not the training distribution.
:class:`ValidationCallback` measures what a learning curve should: every ``eval_freq`` env
steps, the deterministic policy's success on the first ``episodes`` seeds of the validation
split (``configs/eval.yaml``), each episode ``reset(seed=s)`` on the env the agent trains on
(its id and keywords, its action rescaling, its observation normalisation), and appends a row
``timesteps, wall_time_s, success_rate, episodes`` to ``validation.csv`` in the run folder,
beside the zoo's ``*.monitor.csv``. ``wall_time_s`` counts training only: the evaluations'
own time is left out, so a curve against wall time is the algorithm's cost.

Used from a zoo hyperparameter file (``configs/rl/*.yml``)::

    callback:
      - footstep_gym.rl.callbacks.ValidationCallback:
          eval_freq: 25000
          episodes: 20

A recurrent policy (sb3-contrib's ``RecurrentPPO``) gets its state carried over each episode. In a run without
a ``Monitor`` file (rl_zoo3's ``-optimize`` trials) the callback warns and measures nothing.
"""

from __future__ import annotations

import csv
import time
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.monitor import Monitor

from footstep_gym.rl.training import VALIDATION_CURVE as CURVE_FILE

CURVE_FIELDS = ("timesteps", "wall_time_s", "success_rate", "episodes")


def _monitor_dir(vec_env: Any) -> Path | None:
    """The folder of the training env's ``Monitor`` file (the zoo's run folder); None without one (the zoo's
    hyperparameter trials: ``-optimize`` gives them the config's callbacks but no run folder)."""
    env = vec_env.envs[0]
    while env is not None:
        if isinstance(env, Monitor) and env.results_writer is not None:
            return Path(env.results_writer.file_handler.name).parent
        env = getattr(env, "env", None)
    return None


def evaluation_env(training_env: Any, action_space: gym.spaces.Box) -> gym.Env:
    """The env a model trains on, made anew from its spec (id and keywords), with the action box mapped to the
    model's (``RescaleAction``) when they differ."""
    spec = training_env.envs[0].unwrapped.spec
    env = gym.make(spec.id, **dict(spec.kwargs))
    box = env.action_space
    if box.shape != action_space.shape or not (np.array_equal(box.low, action_space.low)
                                               and np.array_equal(box.high, action_space.high)):
        env = gym.wrappers.RescaleAction(env, action_space.low.astype(box.dtype), action_space.high.astype(box.dtype))
    return env


def play(model: Any, env: gym.Env, seeds: list[int], normalizer: Any = None) -> list[tuple[bool, int]]:
    """``(success, footsteps)`` of each episode ``reset(seed=s)`` for ``s`` in ``seeds``, the model acting
    deterministically on the observation (normalised by ``normalizer``, a ``VecNormalize``); success is the last
    step's ``info["is_success"]``."""
    episodes = []
    for seed in seeds:
        obs, _ = env.reset(seed=seed)
        state, start = None, np.ones((1,), dtype=bool)
        done, info, steps = False, {}, 0
        while not done:
            x = np.asarray(obs, dtype=np.float32)[None]
            if normalizer is not None:
                x = normalizer.normalize_obs(x)
            action, state = model.predict(x, state=state, episode_start=start, deterministic=True)
            start = np.zeros((1,), dtype=bool)
            obs, _, terminated, truncated, info = env.step(action[0])
            done, steps = terminated or truncated, steps + 1
        episodes.append((bool(info.get("is_success", False)), steps))
    return episodes


class ValidationCallback(BaseCallback):
    """Every ``eval_freq`` env steps (all envs together) and at the end: the success rate on the validation
    split's first ``episodes`` seeds, appended to ``<run folder>/validation.csv`` (see the module doc)."""

    def __init__(self, eval_freq: int = 25_000, episodes: int = 20, split: str = "validation", verbose: int = 0):
        super().__init__(verbose)
        if int(eval_freq) < 1 or int(episodes) < 1:
            raise ValueError(f"ValidationCallback: eval_freq and episodes must be >= 1, got {eval_freq}, {episodes}")
        from footstep_gym.evaluation.splits import split_seeds

        self.eval_freq, self.episodes = int(eval_freq), int(episodes)
        self.seeds = split_seeds(split, self.episodes)
        self._next = self.eval_freq
        self._last = -1
        self._eval_time = 0.0
        self._start = 0.0
        self._env: gym.Env | None = None
        self.path: Path | None = None

    def _init_callback(self) -> None:
        folder = _monitor_dir(self.training_env)
        if folder is None:  # no run folder, no curve to write: measuring it would only slow the trial down
            warnings.warn("ValidationCallback: the training env has no Monitor writing to a file (an rl_zoo3 "
                          "-optimize trial); no validation curve is measured", stacklevel=2)
            return
        self.path = folder / CURVE_FILE
        self._env = evaluation_env(self.training_env, self.model.action_space)
        with open(self.path, "w", newline="", encoding="utf-8") as fh:
            csv.writer(fh).writerow(CURVE_FIELDS)
        self._start = time.perf_counter()

    def _evaluate(self) -> None:
        t0 = time.perf_counter()
        self._last = self.num_timesteps
        episodes = play(self.model, self._env, self.seeds, self.model.get_vec_normalize_env())
        rate = sum(win for win, _ in episodes) / len(episodes)
        wall = t0 - self._start - self._eval_time
        self._eval_time += time.perf_counter() - t0
        with open(self.path, "a", newline="", encoding="utf-8") as fh:
            csv.writer(fh).writerow([self.num_timesteps, f"{wall:.1f}", f"{rate:.4f}", len(self.seeds)])
        self.logger.record("validation/success_rate", rate)
        if self.verbose:
            print(f"validation: {self.num_timesteps} steps, success {rate:.2f} on {len(self.seeds)} seeds")

    def _on_step(self) -> bool:
        if self.path is not None and self.num_timesteps >= self._next:
            self._evaluate()
            while self._next <= self.num_timesteps:
                self._next += self.eval_freq
        return True

    def _on_training_end(self) -> None:
        if self._env is not None:
            if self._last != self.num_timesteps:
                self._evaluate()
            self._env.close()
            self._env = None
