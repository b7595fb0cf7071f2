"""Env steps per second: one process (:class:`SingleCell`, interleaved round by round in
:func:`measure_singles`), ``gym.make_vec`` with sync and async vectorisation
(:func:`measure_vector`), the env of another checkout (:class:`RemoteCell`, ``--compare-with``), and
the section as a whole (:func:`bench_envs`).

This module (with :mod:`.settings`, :mod:`.timing` and :mod:`.fmt`, which it imports) also runs in
the ``--compare-with`` worker against *another checkout's* ``footstep_gym``: it may use nothing
of ``footstep_gym`` but the env ids (``footstep_gym.ENV_IDS``), the envs and
``footstep_gym.robot.load_robot``, and it imports its siblings relatively.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np

import footstep_gym
from footstep_gym.robot import load_robot

from .fmt import finite_json
from .settings import MODES, Settings, log
from .timing import summary

FOOTSTEP_ENVS = tuple(footstep_gym.ENV_IDS.values())
REFERENCE_ENVS = ("CartPole-v1", "Pendulum-v1", "BipedalWalker-v3")
VEC_MODES = ("sync", "async")
COMMANDS = ("random", "near_nominal", "planner")
BEFORE_ID = "FootstepDoor-v0 (before)"  # the row of --compare-with


# ------------------------------------------------------------------ commands
def near_nominal_commands(robot: Any, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` commands: nominal period and side stride, half the largest forward stride, small noise.

    Noise: 3 % of each field's range (s.d.); clipped to the robot's limits in float64 (the
    commands stay feasible, apart from what the carried CoM state decides).
    """
    low, high = robot.command_low, robot.command_high
    base = robot.nominal_command.copy()
    base[0] = 0.5 * robot.stride_front[1]
    noise = rng.normal(0.0, 1.0, (n, 5)) * (0.03 * (high - low))
    return np.clip(base + noise, low, high)


def random_commands(space: gym.Space, n: int, seed: int) -> list[np.ndarray]:
    space.seed(seed)
    return [space.sample() for _ in range(n)]


# ------------------------------------------------------------------ timing loops
def _run_single(env: gym.Env, actions: list, n: int, start: int = 0) -> tuple[float, int, int]:
    """Step ``n`` times cycling through ``actions`` from ``start``; reset when done. Returns (seconds, steps, episodes)."""
    m = len(actions)
    episodes = 0
    step, reset = env.step, env.reset
    t0 = time.perf_counter()
    for i in range(start, start + n):
        _, _, terminated, truncated, _ = step(actions[i % m])
        if terminated or truncated:
            reset()
            episodes += 1
    return time.perf_counter() - t0, n, episodes


def _calibrate(run_once: Callable[[int], tuple[float, int, int]], settings: Settings, rep_seconds: float) -> int:
    """Warm up and return the steps per repetition that take about ``rep_seconds``."""
    n, spent, steps = max(settings.min_steps // 5, 1), 0.0, 0
    while spent < settings.warmup_seconds:
        dt, k, _ = run_once(n)
        spent, steps = spent + dt, steps + k
        n *= 2
    per_step = spent / max(steps, 1)
    return max(settings.min_steps, int(rep_seconds / per_step))


def _replay_episodes(env: gym.Env, episodes: list[tuple[int, np.ndarray]]) -> tuple[float, int, int, list]:
    """Reset to each recorded seed and step its actions. Returns (seconds, steps, episodes, terminations)."""
    steps, out = 0, []
    step, reset = env.step, env.reset
    t0 = time.perf_counter()
    for seed, actions in episodes:
        reset(seed=seed)
        info: dict = {}
        for a in actions:
            _, _, terminated, truncated, info = step(a)
        steps += len(actions)
        out.append(info.get("termination"))
    return time.perf_counter() - t0, steps, len(episodes), out


class SingleCell:
    """One env in this process with one kind of commands; :meth:`rep` times one repetition.

    Cells are built (and warmed up) first, then their repetitions are interleaved, so that
    background load hits every env alike and ratios between envs can be paired per round.
    """

    def __init__(self, env_id: str, commands: str, settings: Settings, seed: int,
                 replay: list[tuple[int, np.ndarray, Any]] | None = None) -> None:
        self.env_id, self.commands = env_id, commands
        self.env = env = gym.make(env_id)
        self.rates: list[float] = []
        self.steps = self.episodes = 0
        self.skipped: str | None = None
        if commands == "planner":
            self.replay = [(s, a) for s, a, _ in (replay or []) if len(a)]
            self.recorded_terminations = [t for _, a, t in (replay or []) if len(a)]
            if not self.replay:
                self.skipped = "no recorded planner episodes"
                return
            self._replay_check = _replay_episodes(env, self.replay)[3]  # warm-up; terminations
            dt, k, _, _ = _replay_episodes(env, self.replay)
            self.unit = k
            self.loops = max(1, math.ceil(max(settings.rep_seconds / (dt / k), settings.min_steps) / k))
            self.steps_per_rep = self.loops * k
            return
        env.reset(seed=seed)
        pool = settings.action_pool
        if commands == "random":
            self.actions = random_commands(env.action_space, pool, seed)
        else:
            self.actions = list(near_nominal_commands(env.unwrapped.robot, pool, np.random.default_rng(seed)))
        self.cursor = 0
        self.steps_per_rep = _calibrate(self._run, settings, settings.rep_seconds)

    def _run(self, n: int) -> tuple[float, int, int]:
        out = _run_single(self.env, self.actions, n, self.cursor)
        self.cursor += n
        return out

    def rep(self) -> float | None:
        if self.skipped:
            return None
        if self.commands == "planner":
            t, k, e = 0.0, 0, 0
            for _ in range(self.loops):
                dt, s, n_eps, _ = _replay_episodes(self.env, self.replay)
                t, k, e = t + dt, k + s, e + n_eps
        else:
            t, k, e = self._run(self.steps_per_rep)
        self.rates.append(k / t)
        self.steps, self.episodes = self.steps + k, self.episodes + e
        return self.rates[-1]

    def result(self) -> dict[str, Any]:
        if self.skipped:
            return {"skipped": self.skipped}
        out: dict[str, Any] = {"steps_per_s": summary(self.rates), "rates": self.rates,
                               "steps_per_rep": self.steps_per_rep, "steps": self.steps,
                               "episodes": self.episodes, "mean_episode_steps": self.steps / max(self.episodes, 1)}
        if self.commands == "planner":
            # The env is deterministic given the seed: replaying must end each episode as recorded.
            out["replay_terminations"] = self._replay_check
            out["replay_matches_recording"] = self._replay_check == self.recorded_terminations
        return out

    def close(self) -> None:
        self.env.close()


#: The ``--compare-with`` worker's program (``python -c``): this package (``baselines/speedlib``) loaded
#: under another name, ``_footstep_speed``, so that ``import footstep_gym`` finds the other checkout's
#: (the worker runs in that checkout, which is first on its path), while this timing code stays ours.
_WORKER = """\
import importlib, importlib.util, json, sys
here = sys.argv[1]
spec = importlib.util.spec_from_file_location("_footstep_speed", here + "/__init__.py",
                                              submodule_search_locations=[here])
package = importlib.util.module_from_spec(spec)
sys.modules["_footstep_speed"] = package
spec.loader.exec_module(package)
importlib.import_module("_footstep_speed.env_rates").cell_worker(json.loads(sys.argv[2]))
"""


class RemoteCell:
    """:class:`SingleCell` in a worker process whose ``footstep_gym`` is another checkout's (``--compare-with``).

    The worker (:data:`_WORKER`, run in ``source`` with ``source`` on its ``PYTHONPATH``)
    builds the cell with this module's timing code and times one repetition per request,
    while this process waits: its repetitions take their turn in the same interleaved
    rounds as every other cell.
    """

    def __init__(self, source: Path, env_id: str, commands: str, settings: Settings, seed: int) -> None:
        spec = {"env_id": env_id, "commands": commands, "mode": settings.name, "seed": seed}
        source = Path(source).resolve()
        path = os.pathsep.join(p for p in (str(source), os.environ.get("PYTHONPATH")) if p)
        self.proc = subprocess.Popen([sys.executable, "-c", _WORKER, str(Path(__file__).resolve().parent),
                                      json.dumps(spec)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     cwd=str(source), env={**os.environ, "PYTHONPATH": path})
        hello = self._read()
        self.package = hello["footstep_gym"]

    def _read(self) -> dict[str, Any]:
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"--compare-with worker exited with status {self.proc.wait()}")
        return json.loads(line)

    def _ask(self, what: str) -> dict[str, Any]:
        self.proc.stdin.write(what + "\n")
        self.proc.stdin.flush()
        return self._read()

    def rep(self) -> float | None:
        return self._ask("rep")["rate"]

    def result(self) -> dict[str, Any]:
        return {**self._ask("result"), "footstep_gym": self.package}

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self._ask("quit")
            except (OSError, RuntimeError, ValueError):
                pass
            self.proc.wait(timeout=60)


def cell_worker(spec: dict[str, Any]) -> None:
    """The worker of :class:`RemoteCell`: one SingleCell, a repetition per ``rep`` line on stdin."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cell = SingleCell(spec["env_id"], spec["commands"], MODES[spec["mode"]], spec["seed"])
        print(json.dumps({"footstep_gym": str(Path(footstep_gym.__file__).resolve().parent)}), flush=True)
        for line in sys.stdin:
            what = line.strip()
            if what == "rep":
                print(json.dumps({"rate": cell.rep()}), flush=True)
            elif what == "result":
                print(json.dumps(finite_json(cell.result())), flush=True)
            else:
                print(json.dumps({"bye": True}), flush=True)
                break
    cell.close()


def measure_singles(cells_spec: list[tuple[str, str]], settings: Settings, seed: int,
                    replays: dict[str, list], compare_with: Path | None = None
                    ) -> dict[tuple[str, str], dict[str, Any]]:
    """Build every single-process cell, then interleave their repetitions (round-robin).

    With ``compare_with``, a cell ``(BEFORE_ID, "near_nominal")`` runs the FootstepDoor-v0
    steady walk in a worker process on that checkout's ``footstep_gym``, in the same rounds.
    """
    cells: dict[tuple[str, str], Any] = {}
    out: dict[tuple[str, str], dict[str, Any]] = {}
    if compare_with is not None:
        cells_spec = [*cells_spec, (BEFORE_ID, "near_nominal")]
    try:
        for env_id, commands in cells_spec:
            log(f"  env {env_id:20s} {commands:12s} single (warm-up)")
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    if env_id == BEFORE_ID:
                        cells[(env_id, commands)] = RemoteCell(compare_with, "FootstepDoor-v0", commands, settings,
                                                               seed)
                    else:
                        cells[(env_id, commands)] = SingleCell(env_id, commands, settings, seed,
                                                               replays.get(env_id))
            except Exception as exc:  # noqa: BLE001 - one broken cell must not lose the rest
                out[(env_id, commands)] = {"skipped": f"{type(exc).__name__}: {exc}"[:300]}
        log(f"  {len(cells)} single-process cells x {settings.repetitions} interleaved repetitions")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for _ in range(settings.repetitions):
                for cell in cells.values():
                    cell.rep()
        for key, cell in cells.items():
            out[key] = cell.result()
    finally:
        for cell in cells.values():
            cell.close()
    return out


# ------------------------------------------------------------------ vector envs
def vector_workers(vec: gym.vector.VectorEnv) -> dict[str, Any]:
    """How ``vec`` runs its sub-envs: class, autoreset mode, sub-env count and worker processes.

    ``AsyncVectorEnv`` keeps one ``multiprocessing.Process`` per sub-env; a
    ``SyncVectorEnv`` steps its sub-envs one after the other in this process.
    """
    procs = getattr(vec, "processes", None)
    pids = [p.pid for p in procs] if procs else []
    mode = getattr(vec, "autoreset_mode", None) or vec.metadata.get("autoreset_mode")
    return {"class": type(vec).__name__, "num_envs": vec.num_envs,
            "autoreset_mode": getattr(mode, "name", None) or (str(mode) if mode is not None else None),
            "worker_processes": len(pids),
            "workers_alive": sum(bool(p.is_alive()) for p in procs) if procs else 0,
            "worker_pids_distinct_from_parent": len(set(pids)) == len(pids) and os.getpid() not in pids}


def measure_vector(env_id: str, mode: str, commands: str, settings: Settings, seed: int,
                   replay: list[tuple[int, np.ndarray, Any]] | None = None, num_envs: int = 2) -> dict[str, Any]:
    """Sub-env steps/s through ``gym.make_vec(id, num_envs, vectorization_mode=mode)``.

    Only transitions count as steps: with gymnasium's default ``NEXT_STEP`` autoreset, the
    vector step after a sub-env's episode ended only resets that sub-env (the action is
    ignored). That reset is timed (as the single-process loop times its resets) but not
    counted, so vector and single-process steps/s count the same thing.
    """
    vec = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode=mode)
    try:
        vec.reset(seed=seed)  # async: the workers are up before anything is timed
        workers = vector_workers(vec)
        if commands == "planner":
            return {**_measure_replay_vector(vec, replay or [], settings, num_envs), "vector": workers}
        pool = settings.action_pool
        if commands == "random":
            actions = random_commands(vec.action_space, pool, seed)
        else:
            robot = load_robot()  # the envs are made with the default robot
            rng = np.random.default_rng(seed)
            actions = list(near_nominal_commands(robot, pool * num_envs, rng).reshape(pool, num_envs, 5))
        cursor = [0]
        next_step_reset = workers["autoreset_mode"] == "NEXT_STEP"
        pending = [np.zeros(num_envs, dtype=bool)]  # sub-envs whose next step is an autoreset
        resets = [0]

        def run_once(n: int) -> tuple[float, int, int]:
            step = vec.step
            m = len(actions)
            episodes, autoresets, done = 0, 0, pending[0]
            t0 = time.perf_counter()
            for i in range(cursor[0], cursor[0] + n):
                _, _, term, trunc, _ = step(actions[i % m])
                if next_step_reset:
                    autoresets += int(np.count_nonzero(done))
                    ended = (term | trunc) & ~done
                else:
                    ended = term | trunc
                episodes += int(np.count_nonzero(ended))
                done = term | trunc
            dt = time.perf_counter() - t0
            cursor[0] += n
            pending[0] = done
            resets[0] += autoresets
            return dt, n * num_envs - autoresets, episodes

        n_sub = _calibrate(run_once, settings, settings.vec_rep_seconds)
        n = max(1, n_sub // num_envs)
        rates, steps, episodes = [], 0, 0
        resets[0] = 0
        for _ in range(settings.vec_repetitions):
            dt, k, e = run_once(n)
            rates.append(k / dt)
            steps, episodes = steps + k, episodes + e
        return {"steps_per_s": summary(rates), "rates": rates, "vector_steps_per_rep": n, "steps": steps,
                "autoreset_steps": resets[0], "episodes": episodes,
                "mean_episode_steps": steps / max(episodes, 1), "num_envs": num_envs, "vector": workers}
    finally:
        vec.close()


def _measure_replay_vector(vec: gym.vector.VectorEnv, episodes: list[tuple[int, np.ndarray, Any]],
                           settings: Settings, num_envs: int) -> dict[str, Any]:
    """Replay recorded planner episodes seeds ``s, s+1`` side by side until the shorter one ends.

    ``vec.reset(seed=s)`` seeds sub-env ``i`` with ``s + i``, so pairs of consecutive seeds
    reproduce the recorded episodes exactly on the machine that recorded them (the same libm).
    """
    by_seed = {s: a for s, a, _ in episodes}
    groups = []
    for s in by_seed:
        members = [by_seed.get(s + i) for i in range(num_envs)]
        if all(m is not None and len(m) for m in members):
            n = min(len(m) for m in members)
            groups.append((s, np.stack([m[:n] for m in members], axis=1)))
    if not groups:
        return {"skipped": f"no {num_envs} recorded planner episodes with consecutive seeds"}

    def run_all() -> tuple[float, int]:
        t, k = 0.0, 0
        for s, acts in groups:
            t0 = time.perf_counter()
            vec.reset(seed=s)
            for a in acts:
                vec.step(a)
            t += time.perf_counter() - t0
            k += len(acts) * num_envs
        return t, k

    run_all()  # warm-up
    dt, k = run_all()
    loops = max(1, math.ceil(max(settings.vec_rep_seconds / (dt / k), settings.min_steps) / k))
    rates, total = [], 0
    for _ in range(settings.vec_repetitions):
        t, s = 0.0, 0
        for _ in range(loops):
            dt, k = run_all()
            t, s = t + dt, s + k
        rates.append(s / t)
        total += s
    return {"steps_per_s": summary(rates), "rates": rates,
            "steps_per_rep": loops * sum(len(a) * num_envs for _, a in groups), "steps": total,
            "autoreset_steps": 0, "episodes": loops * len(groups) * num_envs * settings.vec_repetitions,
            "mean_episode_steps": sum(len(a) for _, a in groups) / len(groups), "num_envs": num_envs}


# ------------------------------------------------------------------ the section
def _available(env_id: str) -> str | None:
    """``None`` when ``env_id`` can be made here, else the reason it cannot."""
    try:
        gym.make(env_id).close()
        return None
    except Exception as exc:  # noqa: BLE001 - missing optional dependencies come in many types
        return f"{type(exc).__name__}: {exc}".splitlines()[0][:200]


def bench_envs(settings: Settings, seed: int, replays: dict[str, list],
               compare_with: Path | None = None) -> dict[str, Any]:
    """Env steps/s of every footstep env with each kind of :data:`COMMANDS` and of the reference envs with random
    commands: one process (interleaved), then sync and async ``make_vec``. ``replays``: the planner's recorded
    episodes per env (:func:`speedlib.planner_times.bench_planners`)."""
    spec = [(e, c) for e in FOOTSTEP_ENVS for c in COMMANDS]
    spec += [(e, "random") for e in REFERENCE_ENVS]
    reasons = {e: _available(e) for e in dict.fromkeys(e for e, _ in spec)}
    singles = measure_singles([(e, c) for e, c in spec if reasons[e] is None], settings, seed, replays,
                              compare_with)
    results: dict[str, Any] = {}
    if compare_with is not None:
        results[BEFORE_ID] = {"near_nominal": {"single": singles[(BEFORE_ID, "near_nominal")]}}
    for env_id, commands in spec:
        cell: dict[str, Any] = {}
        for vec_mode in ("single", *VEC_MODES):
            if reasons[env_id]:
                cell[vec_mode] = {"skipped": reasons[env_id]}
            elif vec_mode == "single":
                cell[vec_mode] = singles[(env_id, commands)]
            else:
                log(f"  env {env_id:20s} {commands:12s} {vec_mode}")
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        cell[vec_mode] = measure_vector(env_id, vec_mode, commands, settings, seed,
                                                        replays.get(env_id))
                except Exception as exc:  # noqa: BLE001 - one broken cell must not lose the rest
                    cell[vec_mode] = {"skipped": f"{type(exc).__name__}: {exc}"[:300]}
        results.setdefault(env_id, {})[commands] = cell
    return results
