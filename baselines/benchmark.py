"""How fast footstep_gym is: env steps/s, LIPM checks/s, planning time per footstep, memory, PPO training.

    python baselines/benchmark.py            # quick, the default (a few minutes on 2 cores)
    python baselines/benchmark.py --full     # more repetitions, more episodes
    python baselines/benchmark.py --out runs/benchmark --sections env,lipm
    python baselines/benchmark.py --sections env --compare-with /tmp/before   # + the steady walk on another checkout

Prints markdown tables and writes ``<out>/benchmark.json``. Every rate is the median and
spread (IQR and min/max) over repetitions measured in this one run, after a warm-up,
with ``time.perf_counter``. Measured:

* **env steps/s**, one process, for ``FootstepDoor-v0``, ``FootstepCrossing-v0`` and
  ``FootstepCrowd-v0`` with three kinds of commands: ``random`` (seeded
  ``action_space`` samples; these fall often, so most steps are short), ``near_nominal``
  (the nominal command walking forward at half the largest stride, plus small seeded
  noise, clipped to the robot's limits: full footsteps with their collision sweeps) and
  ``planner`` (the period-aware planner's commands, recorded once and replayed from the
  same seeds, so the planner's time is excluded and measured separately). Episodes reset
  when done and resets are inside the timed loop (the episode length is reported). The
  same through ``gym.make_vec(id, num_envs=2, vectorization_mode="sync"/"async")``
  (``AsyncVectorEnv``: 2 worker processes, checked and recorded; steps/s counts sub-env
  transitions, the reset-only steps of the default ``NEXT_STEP`` autoreset are timed but
  not counted), and the same for ``CartPole-v1``, ``Pendulum-v1`` and ``BipedalWalker-v3``
  (random commands; skipped when not installed). Single-process cells are interleaved
  round by round, so the FootstepDoor / BipedalWalker ratio is paired per round;
* **LIPM feasibility checks/s**: ``lipm.check_step`` (one command, plain Python) and
  ``lipm.check_steps`` with batches of 1, 32 and 1024 (commands/s);
* **planning time per footstep** (``policy.act``; median, p95, p99) of ``period-aware``,
  ``fixed-period`` and ``pso-only`` on each env, and their success rates on the same seeds
  (the planners alternate seed by seed);
* **PPO training throughput**: env steps/s inside ``model.learn`` with 1 and 2 envs for
  ``FootstepDoor-v0`` beside ``CartPole-v1`` with the same network and hyperparameters (the
  ceiling: what PPO itself costs), through ``footstep_gym.rl.training.ppo_throughput`` in a
  subprocess (torch stays out of this one);
* with ``--compare-with DIR``, the ``FootstepDoor-v0`` steady walk once more on the
  ``footstep_gym`` package of another checkout in ``DIR`` (a worker process, in the same
  interleaved rounds): a before/after figure from one run;
* **peak memory** of one env (make + reset + N near-nominal steps) and of the period-aware
  planner (M acts), on each env: the ``tracemalloc`` peak, and the peak RSS above the
  baseline (the kernel's ``VmHWM`` reset at the baseline; else sampled after every step;
  C allocations included), each figure in a fresh subprocess.

Targets (PASS/MISS in the output; they live here, never in timed tests): FootstepDoor
steps/s >= 2x BipedalWalker's on a steady walk (near-nominal commands; >= 1x with random
commands, which mostly time reset, and with the planner's commands); batched LIPM >= 1e6 commands/s at batch 1024; period-aware
planning median <= 1 % and p99 <= 5 % of the nominal period per footstep, and >= 10x
faster than pso-only at no lower success rate.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
import tracemalloc
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
if os.environ.get("FOOTSTEP_GYM_BEFORE"):  # a --compare-with worker: footstep_gym from that other checkout
    sys.path.insert(0, os.environ["FOOTSTEP_GYM_BEFORE"])

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import footstep_gym  # noqa: E402
from bench_utils import (  # noqa: E402
    RssPeak, finite_json, fmt_bytes, fmt_num, fmt_stat, loadavg, machine_info, markdown_table, max_rss_bytes,
    median_ratio_interval, rss_bytes, summary, tail_summary,
)
from footstep_gym import lipm  # noqa: E402
from footstep_gym.robot import load_robot  # noqa: E402

FOOTSTEP_ENVS = tuple(footstep_gym.ENV_IDS.values())
REFERENCE_ENVS = ("CartPole-v1", "Pendulum-v1", "BipedalWalker-v3")
PLANNERS = ("period-aware", "fixed-period", "pso-only")
VEC_MODES = ("sync", "async")
SECTIONS = ("env", "lipm", "planners", "memory", "ppo")
#: PPO throughput cells: (env id, whose configs/rl/ppo.yml entry to train with); CartPole with the door's network
#: and hyperparameters is the ceiling (an env step that costs next to nothing).
PPO_CELLS = (("FootstepDoor-v0", None), ("CartPole-v1", "FootstepDoor-v0"))
PPO_ENVS = (1, 2)
LIPM_BATCHES = (1, 32, 1024)
STAGE_KEYS = ("time_period_search_ms", "time_rrt_ms", "time_pso_ms")  # policy.last_info, when present
MEMORY_TIMEOUT_S = 900  # for the whole memory section (each probe also has a stepping budget)

# Targets (reported, never asserted in tests).
#: FootstepDoor-v0 steps/s over BipedalWalker-v3's, per kind of commands: 2x on a steady walk (issue 10);
#: random commands fall within a few footsteps, so that row mostly times reset; the planner's commands walk.
DOOR_VS_BIPEDAL = {"near_nominal": 2.0, "random": 1.0, "planner": 1.0}
BEFORE_ID = "FootstepDoor-v0 (before)"  # the row of --compare-with
LIPM_TARGET_PER_S = 1_000_000
PLAN_MEDIAN_FRACTION = 0.01  # of the nominal period
PLAN_P99_FRACTION = 0.05
PSO_SPEEDUP_TARGET = 10.0


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
    planner_warmup_steps: int  # untimed footsteps of each planner on an extra seed before the timed episodes
    planner_budget_s: float | None  # per env: no new seed after this (>= 2 seeds always run); None = no limit
    memory_steps: int  # env steps in the env's memory probe
    memory_acts: int  # planner acts in the planner's memory probe
    memory_budget_s: float | None  # a memory probe stops stepping after this (>= 1 step always runs)
    action_pool: int  # distinct pre-sampled commands per env cell (cycled; sampling is outside the timing)
    ppo_timesteps: int  # env steps of each timed PPO.learn (after a warm-up of one rollout)
    ppo_rounds: int  # interleaved rounds of the PPO cells


MODES = {
    "smoke": Settings("smoke", repetitions=2, rep_seconds=0.02, warmup_seconds=0.01, min_steps=5,
                      vec_repetitions=2, vec_rep_seconds=0.02, lipm_rep_seconds=0.01,
                      planner_episodes=1, planner_max_steps=2, planner_warmup_steps=1, planner_budget_s=None,
                      memory_steps=20, memory_acts=2, memory_budget_s=None, action_pool=64,
                      ppo_timesteps=128, ppo_rounds=1),
    "quick": Settings("quick", repetitions=7, rep_seconds=0.25, warmup_seconds=0.2, min_steps=50,
                      vec_repetitions=5, vec_rep_seconds=0.25, lipm_rep_seconds=0.1,
                      planner_episodes=4, planner_max_steps=None, planner_warmup_steps=3, planner_budget_s=45.0,
                      memory_steps=500, memory_acts=50, memory_budget_s=15.0, action_pool=1024,
                      ppo_timesteps=2048, ppo_rounds=2),
    "full": Settings("full", repetitions=21, rep_seconds=0.5, warmup_seconds=0.5, min_steps=200,
                     vec_repetitions=11, vec_rep_seconds=0.5, lipm_rep_seconds=0.3,
                     planner_episodes=12, planner_max_steps=None, planner_warmup_steps=3, planner_budget_s=600.0,
                     memory_steps=2000, memory_acts=200, memory_budget_s=120.0, action_pool=4096,
                     ppo_timesteps=8192, ppo_rounds=3),
}


_T0 = time.perf_counter()


def log(msg: str) -> None:
    """Progress on stderr (stdout carries only the report), with the time since start."""
    print(f"[{time.perf_counter() - _T0:6.1f} s] {msg}", file=sys.stderr, flush=True)


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
                 replay: list[tuple[int, np.ndarray]] | None = None) -> None:
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


class RemoteCell:
    """:class:`SingleCell` in a worker process whose ``footstep_gym`` is another checkout's (``--compare-with``).

    The worker (this script with ``--_cell-worker``) builds the cell with this file's timing
    code and times one repetition per request, while this process waits: its repetitions
    take their turn in the same interleaved rounds as every other cell.
    """

    def __init__(self, source: Path, env_id: str, commands: str, settings: Settings, seed: int) -> None:
        spec = {"env_id": env_id, "commands": commands, "mode": settings.name, "seed": seed}
        env = {**os.environ, "FOOTSTEP_GYM_BEFORE": str(Path(source).resolve())}
        self.proc = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--_cell-worker",
                                      json.dumps(spec)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     env=env)
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


def _cell_worker(spec: dict[str, Any]) -> None:
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
                   replay: list[tuple[int, np.ndarray]] | None = None, num_envs: int = 2) -> dict[str, Any]:
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


def _measure_replay_vector(vec: gym.vector.VectorEnv, episodes: list[tuple[int, np.ndarray]], settings: Settings,
                           num_envs: int) -> dict[str, Any]:
    """Replay recorded planner episodes seeds ``s, s+1`` side by side until the shorter one ends.

    ``vec.reset(seed=s)`` seeds sub-env ``i`` with ``s + i``, so pairs of consecutive seeds
    reproduce the recorded episodes exactly.
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


def _available(env_id: str) -> str | None:
    """``None`` when ``env_id`` can be made here, else the reason it cannot."""
    try:
        gym.make(env_id).close()
        return None
    except Exception as exc:  # noqa: BLE001 - missing optional dependencies come in many types
        return f"{type(exc).__name__}: {exc}".splitlines()[0][:200]


def bench_envs(settings: Settings, seed: int, replays: dict[str, list],
               compare_with: Path | None = None) -> dict[str, Any]:
    spec = [(e, c) for e in FOOTSTEP_ENVS for c in ("random", "near_nominal", "planner")]
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


# ------------------------------------------------------------------ LIPM
def bench_lipm(settings: Settings, seed: int) -> dict[str, Any]:
    robot = load_robot()
    rng = np.random.default_rng(seed)
    support = -1
    com, vel = lipm.steady_state(robot, robot.nominal_command, support)
    com2, vel2 = np.array([com.real, com.imag]), np.array([vel.real, vel.imag])
    pool = rng.uniform(robot.command_low, robot.command_high, (4096, 5))
    scalar_cmds = [tuple(float(v) for v in c) for c in pool]

    def timed(fn: Callable[[], int]) -> list[float]:
        # Warm-up and calibration: repeat fn until rep_seconds, then time repetitions of that many calls.
        calls, t = 1, 0.0
        while True:
            t0 = time.perf_counter()
            k = sum(fn() for _ in range(calls))
            t = time.perf_counter() - t0
            if t >= settings.lipm_rep_seconds / 4 or calls > 1 << 22:
                break
            calls *= 2
        calls = max(1, int(calls * settings.lipm_rep_seconds / max(t, 1e-9)))
        rates = []
        for _ in range(settings.repetitions):
            t0 = time.perf_counter()
            k = 0
            for _ in range(calls):
                k += fn()
            rates.append(k / (time.perf_counter() - t0))
        return rates

    it = [0]

    def one_scalar() -> int:
        i = it[0] = (it[0] + 1) % len(scalar_cmds)
        lipm.check_step(robot, com, vel, scalar_cmds[i], support)
        return 1

    log("  lipm check_step")
    out: dict[str, Any] = {"check_step": {"commands_per_s": summary(timed(one_scalar)), "batch": 1}}
    # What was timed: the verdicts of both paths on the whole pool (they should agree).
    scalar_ok = np.array([all(lipm.check_step(robot, com, vel, c, support)[:2]) for c in scalar_cmds])
    batch_ok = np.asarray(lipm.check_steps(robot, com2, vel2, pool, support).feasible, dtype=bool)
    out["commands"] = {"pool": len(pool), "sampling": "uniform in the command box, nominal steady-state CoM",
                       "feasible_fraction": float(batch_ok.mean()),
                       "scalar_batched_agreement": float((scalar_ok == batch_ok).mean())}
    out["check_steps"] = {}
    for batch in LIPM_BATCHES:
        log(f"  lipm check_steps batch {batch}")
        chunks = [pool[i:i + batch] for i in range(0, len(pool) - batch + 1, batch)]
        j = [0]

        def one_batch(chunks: list = chunks, j: list = j, batch: int = batch) -> int:
            j[0] = (j[0] + 1) % len(chunks)
            lipm.check_steps(robot, com2, vel2, chunks[j[0]], support)
            return batch

        out["check_steps"][str(batch)] = {"commands_per_s": summary(timed(one_batch)), "batch": batch}
    return out


# ------------------------------------------------------------------ planners
def _make_policy_fn() -> tuple[Callable | None, str | None]:
    try:
        import footstep_gym.planners  # noqa: F401  (the planners' modules, imported here once)
        from footstep_gym import make_policy
    except Exception as exc:  # noqa: BLE001
        return None, f"footstep_gym.planners unavailable: {type(exc).__name__}: {exc}"
    return make_policy, None


class PlannerRun:
    """One planner on one env: times ``sensing()``, ``policy.act`` and ``env.step`` per footstep.

    :func:`bench_planners` alternates the planners seed by seed (the same seeds for every
    planner), so that background load hits them alike and their time ratio is fair.
    """

    def __init__(self, make_policy: Callable, planner: str, env_id: str, seeds: list[int],
                 max_steps: int | None, warmup_steps: int = 3) -> None:
        self.planner, self.env_id, self.seeds, self.max_steps = planner, env_id, list(seeds), max_steps
        self.warmup_steps = warmup_steps
        self.env = gym.make(env_id)
        self.policy = make_policy(planner, self.env.unwrapped.robot, seed=self.seeds[0])
        self.plan_s: list[float] = []
        self.plan_by_episode: list[list[float]] = []  # the same times, one list per recorded episode
        self.sense_s: list[float] = []
        self.step_s: list[float] = []
        self.stages: dict[str, list[float]] = {}
        self.pso_ran = 0
        self.episodes: list[dict[str, Any]] = []
        self.recorded: list[tuple[int, np.ndarray, Any]] = []

    def episode(self, seed: int, warm: bool = False) -> int:
        """Run one episode from ``seed`` (a warm-up stops after ``warmup_steps``, unrecorded). Returns its footsteps."""
        env, policy = self.env, self.policy
        obs, info = env.reset(seed=seed)
        policy.reset(seed=seed)
        actions, n, info = [], 0, {}
        terminated = truncated = False
        sensing = env.unwrapped.sensing
        plan_times: list[float] = []
        while True:
            t0 = time.perf_counter()
            snapshot = sensing()
            t1 = time.perf_counter()
            action = policy.act(obs, snapshot)
            t2 = time.perf_counter()
            obs, _, terminated, truncated, info = env.step(action)
            t3 = time.perf_counter()
            n += 1
            actions.append(np.array(action, copy=True))
            if not warm:
                self.sense_s.append(t1 - t0)
                self.plan_s.append(t2 - t1)
                plan_times.append(t2 - t1)
                self.step_s.append(t3 - t2)
                li = getattr(policy, "last_info", None) or {}
                for key in STAGE_KEYS:
                    if isinstance(li.get(key), (int, float)):
                        self.stages.setdefault(key, []).append(1e-3 * li[key])
                self.pso_ran += bool(li.get("pso_ran", False))
            capped = self.max_steps is not None and n >= self.max_steps
            if terminated or truncated or capped or (warm and n >= self.warmup_steps):
                break
        if not warm:
            self.plan_by_episode.append(plan_times)
            self.episodes.append({"seed": seed, "steps": n, "termination": info.get("termination"),
                                  "success": bool(info.get("is_success", False)), "time": info.get("time"),
                                  "capped": not (terminated or truncated)})
            self.recorded.append((seed, np.array(actions), info.get("termination")))
        return n

    def result(self) -> dict[str, Any]:
        successes = sum(e["success"] for e in self.episodes)
        return {
            "plan_time_s": tail_summary(self.plan_s),
            "plan_time_by_episode_s": [[round(t, 7) for t in ep] for ep in self.plan_by_episode],
            "sensing_time_s": tail_summary(self.sense_s),
            "env_step_time_s": tail_summary(self.step_s),
            "stage_time_s": {k.removeprefix("time_").removesuffix("_ms"): tail_summary(v)
                             for k, v in self.stages.items()},
            "pso_ran_fraction": self.pso_ran / max(len(self.plan_s), 1),
            "footsteps": len(self.plan_s),
            "episodes": len(self.episodes),
            "successes": successes,
            "success_rate": successes / max(len(self.episodes), 1),
            "seeds": [e["seed"] for e in self.episodes],
            "per_episode": self.episodes,
        }

    def close(self) -> None:
        self.env.close()


def _error(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"[:300]


def bench_planners(settings: Settings, seed: int) -> tuple[dict[str, Any], dict[str, list]]:
    """Planning time per footstep and success of every planner on every env, on the same seeds.

    Also returns the period-aware planner's recorded commands per env (replayed by the
    env-steps section, so that the env is timed without the planner).
    """
    make_policy, reason = _make_policy_fn()
    if make_policy is None:
        return {"skipped": reason}, {}
    seeds = [seed + i for i in range(max(settings.planner_episodes, 2))]  # >= 2: the vector replay pairs seeds
    results: dict[str, Any] = {}
    replays: dict[str, list] = {}
    for env_id in FOOTSTEP_ENVS:
        runs: dict[str, PlannerRun] = {}
        failed: dict[str, str] = {}
        try:
            for planner in PLANNERS:
                try:
                    runs[planner] = PlannerRun(make_policy, planner, env_id, seeds, settings.planner_max_steps,
                                                settings.planner_warmup_steps)
                    runs[planner].episode(seed + 10_000, warm=True)
                except Exception as exc:  # noqa: BLE001 - one broken planner must not lose the rest
                    failed[planner] = _error(exc)
                    runs.pop(planner, None)
            t_env = time.perf_counter()
            budget_hit = False
            for i, s in enumerate(seeds):
                if settings.planner_budget_s is not None and i >= 2 and \
                        time.perf_counter() - t_env > settings.planner_budget_s:
                    budget_hit = True
                    log(f"  planners on {env_id}: time budget of {settings.planner_budget_s:.0f} s used up; "
                        f"{i} of {len(seeds)} seeds run (the same for every planner)")
                    break
                done = []
                for planner, run in list(runs.items()):
                    t0 = time.perf_counter()
                    try:
                        n = run.episode(s)
                    except Exception as exc:  # noqa: BLE001
                        failed[planner] = _error(exc)
                        run.close()
                        del runs[planner]
                        continue
                    done.append(f"{planner} {n} steps {time.perf_counter() - t0:.1f} s")
                log(f"  planners on {env_id:20s} seed {s} ({i + 1}/{len(seeds)}): " + ", ".join(done))
            results[env_id] = {}
            for planner in PLANNERS:
                if planner in failed:
                    results[env_id][planner] = {"skipped": failed[planner]}
                else:
                    results[env_id][planner] = {**runs[planner].result(), "seeds_planned": list(seeds),
                                                "budget_exhausted": budget_hit}
            if "period-aware" in runs:
                replays[env_id] = runs["period-aware"].recorded
        finally:
            for run in runs.values():
                run.close()
    return results, replays


# ------------------------------------------------------------------ memory (fresh subprocesses)
def _memory_child(spec: dict[str, Any]) -> dict[str, Any]:
    """Runs in a fresh interpreter: memory of make + reset + N steps (env) or of the period-aware planner.

    Modules are imported before the baseline (code is not the env's memory); for the
    planner, the env is made and stepped first so that only the planner's memory remains
    (its env keeps stepping, so the env's growth over those steps is included).
    Without tracemalloc, ``peak_rss_delta_bytes`` is the peak RSS above the baseline
    (``RssPeak``: the kernel's ``VmHWM`` reset at the baseline, else the current RSS sampled
    after every step and act). With tracemalloc (a separate child: tracing slows everything
    and allocates), the peak of Python-level allocations (numpy's buffers included).
    """
    import gc

    import footstep_gym.env  # noqa: F401 - pymunk, scenarios, world

    env_id, n, what, use_tm = spec["env_id"], spec["steps"], spec["what"], spec["tracemalloc"]
    budget = spec.get("budget_s")
    done = 0
    rng = np.random.default_rng(0)
    make_policy = None
    env = None
    obs = None
    if what == "planner":
        make_policy, reason = _make_policy_fn()
        if make_policy is None:
            return {"skipped": reason}
        env = gym.make(env_id)
        env.reset(seed=0)
        for _ in range(3):  # the env's own lazy allocations before the planner is measured
            env.step(env.unwrapped.robot.nominal_command)
        obs, _ = env.reset(seed=0)
    actions = list(near_nominal_commands(load_robot(), n, rng)) if what == "env" else []
    gc.collect()
    rss0, max0 = rss_bytes(), max_rss_bytes()
    sampler = RssPeak()
    if use_tm:
        tracemalloc.start()
    t0 = time.perf_counter()
    peak_all, peak_act, episodes = 0, None, 0
    if what == "env":
        env = gym.make(env_id)
        env.reset(seed=0)
        sampler.sample()
        for a in actions:
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                env.reset()
                episodes += 1
            sampler.sample()
            done += 1
            if budget is not None and time.perf_counter() - t0 > budget:
                break
    else:
        policy = make_policy("period-aware", env.unwrapped.robot, seed=0)
        policy.reset(seed=0)
        sampler.sample()
        peak_act = 0
        for _ in range(n):
            snap = env.unwrapped.sensing()
            if use_tm:
                cur, peak = tracemalloc.get_traced_memory()
                peak_all = max(peak_all, peak)
                tracemalloc.reset_peak()
            action = policy.act(obs, snap)
            if use_tm:
                peak_act = max(peak_act, tracemalloc.get_traced_memory()[1] - cur)
            sampler.sample()
            obs, _, term, trunc, _ = env.step(action)
            if term or trunc:
                episodes += 1
                obs, _ = env.reset(seed=episodes)
                policy.reset(seed=episodes)
            sampler.sample()
            done += 1
            if budget is not None and time.perf_counter() - t0 > budget:
                break
    elapsed = time.perf_counter() - t0
    out: dict[str, Any] = {"steps": done, "steps_planned": n, "episodes_ended": episodes, "seconds": elapsed,
                           "torch_imported": "torch" in sys.modules}
    if use_tm:
        current, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        out.update(tracemalloc_peak_bytes=max(peak_all, peak), tracemalloc_current_bytes=current)
        if peak_act is not None:
            out["tracemalloc_peak_per_act_bytes"] = peak_act
    else:
        sampler.sample()
        rss1, max1 = rss_bytes(), max_rss_bytes()
        out.update(rss_before_bytes=rss0, rss_after_bytes=rss1,
                   rss_delta_bytes=None if rss0 is None or rss1 is None else rss1 - rss0,
                   peak_rss_bytes=sampler.peak, peak_rss_method=sampler.method,
                   rss_samples=sampler.samples, sampled_peak_rss_bytes=sampler.sampled_peak,
                   peak_rss_delta_bytes=None if rss0 is None or sampler.peak is None else sampler.peak - rss0,
                   max_rss_bytes=max1, max_rss_delta_bytes=max1 - max0)
    sampler.close()
    return out


def _spawn_memory(spec: dict[str, Any]) -> dict[str, Any]:
    """One memory probe in a fresh interpreter (``--_memory-child``); the fallback without a fork server."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--_memory-child", json.dumps(spec)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=MEMORY_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return {"skipped": f"child timed out after {MEMORY_TIMEOUT_S} s"}
    if proc.returncode != 0:
        return {"skipped": f"child failed: {proc.stderr.strip().splitlines()[-1:]}"}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _memory_server(request: dict[str, Any]) -> list[dict[str, Any]]:
    """Runs in a fresh interpreter (``--_memory-server``): every (tracemalloc) probe in a child forked from it.

    This interpreter has imported numpy, gymnasium, pymunk, footstep_gym and the planners
    and allocated nothing else, so a forked child starts from the state of a fresh
    interpreter after its imports (what ``--_memory-child`` measures from), without paying
    ~0.5 s of imports per probe. ``workers`` children run at a time; each writes its
    result to a file of its own and leaves with ``os._exit``.
    """
    import tempfile

    import footstep_gym.env  # noqa: F401
    _make_policy_fn()  # import the planners once, here
    specs, workers = request["specs"], max(1, int(request["workers"]))
    results: list[dict[str, Any] | None] = [None] * len(specs)
    with tempfile.TemporaryDirectory(prefix="footstep-bench-mem-") as tmp:
        running: dict[int, int] = {}
        nxt = 0
        while nxt < len(specs) or running:
            while nxt < len(specs) and len(running) < workers:
                path = os.path.join(tmp, f"{nxt}.json")
                pid = os.fork()
                if pid == 0:  # child: measure, write, leave without cleanup handlers
                    code = 0
                    try:
                        out = finite_json(_memory_child(specs[nxt]))
                    except BaseException as exc:  # noqa: BLE001
                        out, code = {"skipped": _error(exc)}, 1
                    try:
                        with open(path, "w", encoding="utf-8") as f:
                            json.dump(out, f)
                    finally:
                        os._exit(code)
                running[pid] = nxt
                nxt += 1
            pid, status = os.wait()
            i = running.pop(pid)
            try:
                with open(os.path.join(tmp, f"{i}.json"), encoding="utf-8") as f:
                    results[i] = json.load(f)
            except (OSError, ValueError):
                results[i] = {"skipped": f"probe process ended with status {status} and no result"}
    return [r if r is not None else {"skipped": "no result"} for r in results]


def _serve_memory(specs: list[dict[str, Any]], workers: int) -> list[dict[str, Any]] | None:
    """The results of ``specs`` from one ``--_memory-server`` interpreter, or ``None`` if it failed."""
    cmd = [sys.executable, str(Path(__file__).resolve()), "--_memory-server"]
    try:
        proc = subprocess.run(cmd, input=json.dumps({"specs": specs, "workers": workers}),
                              capture_output=True, text=True, timeout=MEMORY_TIMEOUT_S)
        if proc.returncode == 0:
            results = json.loads(proc.stdout.strip().splitlines()[-1])
            if isinstance(results, list) and len(results) == len(specs):
                return results
        why = (proc.stderr.strip().splitlines() or ["no output"])[-1]
    except (subprocess.TimeoutExpired, ValueError, IndexError) as exc:
        why = _error(exc)
    log(f"  memory server failed ({why[:200]}); a fresh interpreter per probe instead")
    return None


def _run_memory_jobs(specs: list[dict[str, Any]], workers: int) -> list[dict[str, Any]]:
    """Run the probes ``workers`` at a time, each in a process of its own.

    RSS probes: a fresh ``--_memory-child`` interpreter each. A child forked from an
    interpreter would start with its shared-library pages unmapped and fault them back in
    as it runs, which shows up as RSS growth that is no allocation. tracemalloc probes
    count allocations only, so (where ``os.fork`` exists) they run in children forked from
    one ``--_memory-server`` interpreter, one at a time beside the RSS probes, which saves
    ~0.5 s of imports per probe. Each result says which (``process``).
    """
    from concurrent.futures import ThreadPoolExecutor

    forked = [i for i, sp in enumerate(specs) if sp["tracemalloc"]] if hasattr(os, "fork") and workers > 1 else []
    fresh = [i for i in range(len(specs)) if i not in forked]
    results: list[dict[str, Any] | None] = [None] * len(specs)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        served = pool.submit(_serve_memory, [specs[i] for i in forked], 1) if forked else None
        futures = {i: pool.submit(_spawn_memory, specs[i]) for i in fresh}
        for i, fut in futures.items():
            results[i] = {**fut.result(), "process": "fresh interpreter"}
        got = served.result() if served is not None else None
        if got is None:
            futures = {i: pool.submit(_spawn_memory, specs[i]) for i in forked}
            for i, fut in futures.items():
                results[i] = {**fut.result(), "process": "fresh interpreter"}
        else:
            for i, r in zip(forked, got):
                results[i] = {**r, "process": "forked from a fresh interpreter after its imports"}
    return [r or {"skipped": "no result"} for r in results]


def bench_memory(settings: Settings, workers: int | None = None) -> dict[str, Any]:
    """Memory of one env (each scenario) and of the period-aware planner (on each scenario).

    Every figure comes from a process of its own (see :func:`_run_memory_jobs`); they run
    ``workers`` at a time (default: the usable cores). Nothing is timed here, so running
    them side by side does not change what they measure (RSS and tracemalloc are per process).
    """
    n = settings.memory_steps
    planner_steps = settings.memory_acts
    jobs: list[tuple[str, str, str, dict[str, Any]]] = []
    for what, steps in (("env", n), ("planner", planner_steps)):
        for env_id in FOOTSTEP_ENVS:
            for kind in ("rss", "tracemalloc"):
                jobs.append((what, env_id, kind, {"env_id": env_id, "steps": steps, "what": what,
                                                  "tracemalloc": kind == "tracemalloc",
                                                  "budget_s": settings.memory_budget_s}))
    workers = workers or machine_info()["cores_usable"] or 1
    log(f"  {len(jobs)} memory probes ({workers} at a time): env x{n} steps and period-aware planner "
        f"x{planner_steps} acts, on {len(FOOTSTEP_ENVS)} envs")
    results = _run_memory_jobs([spec for *_, spec in jobs], workers)
    out: dict[str, Any] = {"env": {}, "planner": {"period-aware": {}}}
    for (what, env_id, kind, _), r in zip(jobs, results):
        if what == "env":
            out["env"].setdefault(env_id, {})[kind] = r
        else:
            out["planner"]["period-aware"].setdefault(env_id, {"env_id": env_id})[kind] = r
    return out


# ------------------------------------------------------------------ targets and report
def _median(cell: dict | None, key: str = "steps_per_s") -> float | None:
    if not cell or key not in cell:
        return None
    return cell[key]["median"]


def evaluate_targets(res: dict[str, Any], nominal_period: float) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    targets: list[dict[str, Any]] = []
    ratios: dict[str, Any] = {}

    def add(name: str, threshold: str, shown: str, ok: bool | None, **extra: Any) -> None:
        targets.append({"target": name, "threshold": threshold, "measured": shown,
                        "status": "N/A" if ok is None else ("PASS" if ok else "MISS"), **extra})

    envs = res.get("env_steps", {})
    bw_cell = envs.get("BipedalWalker-v3", {}).get("random", {}).get("single", {})
    door = envs.get("FootstepDoor-v0", {})
    for commands in ("random", "near_nominal", "planner"):
        d_cell = door.get(commands, {}).get("single", {})
        key = f"FootstepDoor_{commands}/BipedalWalker"
        goal = DOOR_VS_BIPEDAL[commands]
        name = (f"FootstepDoor-v0 steps/s >= {goal:g}x BipedalWalker-v3 (1 process, "
                f"{commands.replace('_', '-')} commands)")
        if "rates" in d_cell and "rates" in bw_cell:
            # Paired per interleaved round (the same background load on both), then the median.
            r = summary([d / b for d, b in zip(d_cell["rates"], bw_cell["rates"])])
            ratios[key] = r
            add(name, f"paired ratio >= {goal:g}", f"{r['median']:.2f} (IQR {r['q1']:.2f}–{r['q3']:.2f})",
                r["median"] >= goal, value=r["median"])
        else:
            ratios[key] = None
            if envs:
                why = d_cell.get("skipped") or bw_cell.get("skipped") or "not measured"
                add(name, f"paired ratio >= {goal:g}", f"n/a ({why})"[:120], None)
    before = envs.get(BEFORE_ID, {}).get("near_nominal", {}).get("single", {})
    now = door.get("near_nominal", {}).get("single", {})
    if "rates" in before:  # --compare-with: the same steady walk on another checkout's env, same rounds
        if "rates" in now:
            ratios["FootstepDoor_near_nominal/before"] = summary([a / b for a, b in zip(now["rates"], before["rates"])])
        if "rates" in bw_cell:
            ratios["FootstepDoor_near_nominal_before/BipedalWalker"] = summary(
                [a / b for a, b in zip(before["rates"], bw_cell["rates"])])

    lipm_res = res.get("lipm", {})
    if lipm_res:
        v = lipm_res["check_steps"][str(1024)]["commands_per_s"]["median"]
        add("LIPM check_steps, batch 1024", f">= {fmt_num(LIPM_TARGET_PER_S)} commands/s", f"{fmt_num(v)} /s",
            v >= LIPM_TARGET_PER_S, value=v)

    plans = res.get("planners", {})
    if plans and "skipped" not in plans:
        med_lim, p99_lim = PLAN_MEDIAN_FRACTION * nominal_period, PLAN_P99_FRACTION * nominal_period
        for env_id, by_planner in plans.items():
            pa, pso = by_planner.get("period-aware", {}), by_planner.get("pso-only", {})
            if "plan_time_s" not in pa:
                add(f"period-aware planning on {env_id}", "runs", pa.get("skipped", "n/a"), False)
                continue
            m, p99 = pa["plan_time_s"]["median"], pa["plan_time_s"]["p99"]
            add(f"period-aware median plan time, {env_id}", f"<= {med_lim * 1e3:.0f} ms (1% of T_n)",
                f"{m * 1e3:.2f} ms", m <= med_lim, value=m)
            add(f"period-aware p99 plan time, {env_id}", f"<= {p99_lim * 1e3:.0f} ms (5% of T_n)",
                f"{p99 * 1e3:.2f} ms", p99 <= p99_lim, value=p99)
            if "plan_time_s" in pso:
                speedup = pso["plan_time_s"]["median"] / m if m > 0 else math.inf
                ratios[f"pso-only/period-aware median plan time, {env_id}"] = speedup
                interval = ""
                if pa.get("seeds") and pa.get("seeds") == pso.get("seeds") and "plan_time_by_episode_s" in pa:
                    lo, hi = median_ratio_interval(pso["plan_time_by_episode_s"], pa["plan_time_by_episode_s"],
                                                   np.random.default_rng(0))
                    ratios[f"pso-only/period-aware median plan time, {env_id}, 95% CI"] = [lo, hi]
                    interval = f" (95% CI {lo:.1f}–{hi:.1f}, episodes resampled)"
                ok = speedup >= PSO_SPEEDUP_TARGET and pa["success_rate"] >= pso["success_rate"]
                add(f"period-aware vs pso-only, {env_id}",
                    f">= {PSO_SPEEDUP_TARGET:.0f}x faster, success >= pso-only's",
                    f"{speedup:.1f}x{interval}, success {pa['successes']}/{pa['episodes']} vs "
                    f"{pso['successes']}/{pso['episodes']}", ok, value=speedup)
            else:
                add(f"period-aware vs pso-only, {env_id}", f">= {PSO_SPEEDUP_TARGET:.0f}x faster, success >= "
                    "pso-only's", f"n/a (pso-only: {pso.get('skipped', 'not measured')})"[:120], None)
    elif plans:
        add("period-aware planning", "runs", f"n/a ({plans['skipped']})"[:120], None)
    return targets, ratios


def _cell_str(cell: dict | None) -> str:
    if not cell:
        return "n/a"
    if "skipped" in cell:
        return "skipped"
    return fmt_stat(cell["steps_per_s"])


def _busy(meta: dict[str, Any]) -> bool:
    """Whether the 1-minute load average suggests other work shared the CPUs during the run."""
    loads = [x[0] for x in (meta.get("load_average_start"), meta.get("load_average_end")) if x]
    return bool(loads) and max(loads) > 0.5 * (meta["machine"].get("cores_usable") or 1) + 1.0


def report(res: dict[str, Any]) -> str:
    m = res["meta"]
    mc = m["machine"]
    out = [f"# footstep_gym benchmark ({m['mode']} mode)", "",
           f"Machine: {mc['cpu']}, {mc['cores_usable']} usable / {mc['cores_logical']} logical cores, "
           f"{mc['os']}; Python {mc['python']}, numpy {mc['numpy']}, pymunk {mc['pymunk']}, "
           f"gymnasium {mc['gymnasium']}, box2d {mc['box2d']}.", "",
           f"Load average (1/5/15 min) at start {m.get('load_average_start')}, at end {m.get('load_average_end')}"
           + (" — other processes were running: rates are lower and noisier than on an idle machine."
              if _busy(m) else "."), "",
           "All rates: median (IQR) over repetitions in this run; min/max are in benchmark.json.", ""]
    envs = res.get("env_steps")
    if envs:
        out += ["## Env steps per second (resets timed; vector rates count sub-env transitions, 2 sub-envs)", ""]
        rows = []
        for env_id, by_cmd in envs.items():
            for commands, cell in by_cmd.items():
                single = cell.get("single", {})
                eplen = single.get("mean_episode_steps")
                rows.append([env_id, commands, _cell_str(single), _cell_str(cell.get("sync")),
                             _cell_str(cell.get("async")),
                             f"{eplen:.1f}" if isinstance(eplen, (int, float)) else "n/a"])
        out += [markdown_table(["env", "commands", "1 process", "sync ×2", "async ×2", "steps/episode"], rows), ""]
        vec_info = {mode: {(c.get(mode) or {}).get("vector", {}).get("class") for bc in envs.values()
                           for c in bc.values()} - {None} for mode in VEC_MODES}
        procs = {(c.get("async") or {}).get("vector", {}).get("worker_processes") for bc in envs.values()
                 for c in bc.values()} - {None}
        out.append(f"- `gym.make_vec(id, num_envs=2, vectorization_mode=...)`: sync = {sorted(vec_info['sync'])} "
                   f"(both sub-envs in this process), async = {sorted(vec_info['async'])} with "
                   f"{sorted(procs)} worker process(es); default autoreset (NEXT_STEP): the reset-only vector "
                   "steps are timed, not counted.")
        skipped: dict[str, str] = {}
        for e, bc in envs.items():
            for commands, c in bc.items():
                for mode, cell in c.items():
                    if isinstance(cell, dict) and "skipped" in cell:
                        key = e if "skipped" in c.get("single", {}) else f"{e} {commands} {mode}"
                        skipped.setdefault(key, cell["skipped"])
        for e, why in skipped.items():
            out.append(f"- {e}: skipped ({why[:200]})")
        for env_id, by_cmd in envs.items():
            if by_cmd.get("planner", {}).get("single", {}).get("replay_matches_recording") is False:
                out.append(f"- {env_id}: replaying the planner's commands did NOT end the episodes as recorded "
                           "(the env is not deterministic given the seed?)")
        ratio_rows = [[k, f"{v['median']:.2f} ({v['q1']:.2f}–{v['q3']:.2f})" if v else "n/a"]
                      for k, v in res["ratios"].items() if k.startswith("FootstepDoor")]
        out += ["", markdown_table(["single-process steps/s ratio (paired per round)", "median (IQR)"], ratio_rows),
                ""]
    lp = res.get("lipm")
    if lp:
        rows = [["check_step (scalar)", 1, fmt_stat(lp["check_step"]["commands_per_s"]),
                 f"{1e6 / lp['check_step']['commands_per_s']['median']:.1f}"]]
        for b, cell in lp["check_steps"].items():
            s = cell["commands_per_s"]
            rows.append(["check_steps", b, fmt_stat(s), f"{1e6 * int(b) / s['median']:.1f}"])
        out += ["## LIPM feasibility checks", "",
                markdown_table(["function", "batch", "commands/s", "µs per call"], rows), ""]
        c = lp.get("commands")
        if c:
            out += [f"{c['pool']} commands {c['sampling']}: {100 * c['feasible_fraction']:.1f}% feasible; "
                    f"check_step and check_steps agree on {100 * c['scalar_batched_agreement']:.2f}%.", ""]
    pl = res.get("planners")
    if pl:
        out += ["## Planning time per footstep (policy.act; sensing and env.step timed apart)", ""]
        if "skipped" in pl:
            out += [f"skipped: {pl['skipped']}", ""]
        else:
            rows = []
            for env_id, by_planner in pl.items():
                for planner, r in by_planner.items():
                    if "skipped" in r:
                        rows.append([env_id, planner, "skipped", "", "", "", "", "", r["skipped"][:60]])
                        continue
                    p = r["plan_time_s"]
                    rows.append([env_id, planner, f"{p['median'] * 1e3:.2f}", f"{p['p95'] * 1e3:.2f}",
                                 f"{p['p99'] * 1e3:.2f}", f"{r['sensing_time_s']['median'] * 1e3:.3f}",
                                 f"{100 * r['pso_ran_fraction']:.0f}%", f"{r['successes']}/{r['episodes']}",
                                 r["footsteps"]])
            out += [markdown_table(["env", "planner", "median ms", "p95 ms", "p99 ms", "sensing ms", "PSO ran",
                                    "success", "footsteps"], rows), ""]
            for env_id, by_planner in pl.items():
                r = next((r for r in by_planner.values() if "seeds" in r), None)
                if r and r.get("budget_exhausted"):
                    out.append(f"- {env_id}: the time budget ({res['meta']['settings']['planner_budget_s']:.0f} s "
                               f"per env) was used up after {len(r['seeds'])} of {len(r['seeds_planned'])} seeds "
                               "(the same seeds for every planner).")
            if any(r.get("footsteps", 1e9) < 100 for bp in pl.values() for r in bp.values()):
                out.append("- With fewer than 100 footsteps, p99 is close to the maximum; `--full` runs more seeds.")
            out.append("")
    mem = res.get("memory")
    if mem:
        rows = []

        def mem_row(label: str, r: dict[str, Any], per_act: bool = False) -> list[str]:
            rss, tm = r.get("rss", {}), r.get("tracemalloc", {})
            tm_s = tm.get("skipped", "")[:60] or fmt_bytes(tm.get("tracemalloc_peak_bytes"))
            if per_act and "skipped" not in tm:
                tm_s += f" (one act: {fmt_bytes(tm.get('tracemalloc_peak_per_act_bytes'))})"
            if "skipped" in rss:
                return [label, tm_s, rss["skipped"][:60], "", ""]
            return [label, tm_s, fmt_bytes(rss.get("peak_rss_delta_bytes")), fmt_bytes(rss.get("rss_delta_bytes")),
                    fmt_bytes(rss.get("max_rss_bytes"))]

        for env_id, r in mem["env"].items():
            rows.append(mem_row(f"env {env_id} (make+reset+{r.get('rss', {}).get('steps', '?')} steps)", r))
        for name, by_env in mem["planner"].items():
            for env_id, r in by_env.items():
                rows.append(mem_row(f"planner {name} on {env_id} ({r.get('rss', {}).get('steps', '?')} acts)",
                                    r, per_act=True))
        out += ["## Peak memory (a process of its own per figure; modules imported before the baseline)", "",
                markdown_table(["what", "tracemalloc peak", "peak RSS above baseline", "RSS growth at end",
                                "process peak RSS"], rows), "",
                "tracemalloc: peak of Python-level allocations (numpy buffers included), in a child forked "
                "from a fresh interpreter after its imports. RSS figures: a fresh interpreter each; peak RSS "
                "above baseline is the kernel's VmHWM reset at the baseline (C allocations of pymunk and "
                "numpy included); process peak RSS (getrusage) is the whole process, interpreter and imports "
                "included.", ""]
    ppo = res.get("ppo")
    if ppo:
        out += ["## PPO training throughput (env steps/s inside model.learn; configs/rl/ppo.yml, one torch thread)",
                ""]
        if "skipped" in ppo:
            out += [f"skipped: {ppo['skipped']}", ""]
        else:
            rows = []
            for env_id, by_n in ppo["cells"].items():
                hyper = ppo["hyperparameters"].get(env_id, env_id)
                name = env_id if hyper == env_id else f"{env_id} ({hyper}'s network and hyperparameters: the ceiling)"
                rows.append([name] + [fmt_stat(by_n[str(n)]["steps_per_s"]) if str(n) in by_n else "n/a"
                                      for n in PPO_ENVS])
            r = ppo["ratios"]
            rows.append([f"{PPO_CELLS[0][0]} / {PPO_CELLS[1][0]} (paired per round)"]
                        + [f"{r[str(n)]['median']:.2f}" if str(n) in r else "n/a" for n in PPO_ENVS])
            out += [markdown_table(["env", *(f"{n} env{'s' if n > 1 else ''} (DummyVecEnv)" for n in PPO_ENVS)],
                                   rows), "",
                    f"{ppo['timesteps']} timed env steps per cell after a one-rollout warm-up, {ppo['rounds']} "
                    "interleaved round(s); median (IQR) over rounds.", ""]
    if res.get("targets"):
        out += ["## Targets", "", markdown_table(["target", "threshold", "measured", "status"],
                                                 [[t["target"], t["threshold"], t["measured"], t["status"]]
                                                  for t in res["targets"]]), ""]
    out.append(f"Total benchmark time: {m['duration_s']:.0f} s.")
    return "\n".join(out)


# ------------------------------------------------------------------ PPO training throughput
def _ppo_child(spec: dict[str, Any]) -> dict[str, Any]:
    """Runs in its own interpreter (torch stays out of this one): PPO env steps/s per cell and round.

    :func:`footstep_gym.rl.training.ppo_throughput` (what ``train_rl.py --throughput`` reports):
    ``configs/rl/ppo.yml``'s model, wrappers and normalisation, ``n_envs`` envs in a
    ``DummyVecEnv``, one torch thread, a warm-up ``learn`` of one rollout, then a timed one.
    """
    from footstep_gym.rl import training

    rates: dict[str, dict[str, list[float]]] = {}
    for _ in range(spec["rounds"]):  # rounds interleave the cells: background load hits them alike
        for env_id, hyper in PPO_CELLS:
            for n in PPO_ENVS:
                rate = training.ppo_throughput(env_id, n, spec["timesteps"], hyperparams_of=hyper)
                rates.setdefault(env_id, {}).setdefault(str(n), []).append(rate)
    return rates


def bench_ppo(settings: Settings) -> dict[str, Any]:
    """PPO's env steps/s inside ``model.learn`` with 1 and 2 envs: FootstepDoor-v0 beside CartPole-v1 (same
    network and hyperparameters: the ceiling), and their ratio paired per round. In a subprocess."""
    spec = {"timesteps": settings.ppo_timesteps, "rounds": settings.ppo_rounds}
    cmd = [sys.executable, str(Path(__file__).resolve()), "--_ppo-child", json.dumps(spec)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=3600)
    except subprocess.TimeoutExpired:
        return {"skipped": "PPO child timed out after 3600 s"}
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        return {"skipped": f"PPO child failed: {last}"[:300]}
    rates = json.loads(proc.stdout.strip().splitlines()[-1])
    out: dict[str, Any] = {"timesteps": settings.ppo_timesteps, "rounds": settings.ppo_rounds,
                           "hyperparameters": {e: h or e for e, h in PPO_CELLS}, "cells": {}, "ratios": {}}
    for env_id, by_n in rates.items():
        out["cells"][env_id] = {n: {"steps_per_s": summary(r), "rates": r} for n, r in by_n.items()}
    door, ceiling = (rates.get(e) for e, _ in PPO_CELLS)
    if door and ceiling:
        for n in door:
            out["ratios"][n] = summary([a / b for a, b in zip(door[n], ceiling[n])])
    return out


# ------------------------------------------------------------------ main
def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n")[0] + " Quick mode by default (a few minutes at most on 2 cores); "
        "--full for more repetitions and episodes. Prints markdown tables (with each target's PASS/MISS) on "
        "stdout, progress on stderr, and writes <out>/benchmark.json and <out>/benchmark.md.")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="the default: few repetitions, 4 seeds per planner and env")
    g.add_argument("--full", action="store_true",
                   help="more repetitions (21 per cell) and 12 seeds per planner and env (several minutes)")
    g.add_argument("--smoke", action="store_true", help=argparse.SUPPRESS)  # tiny, for the tests
    p.add_argument("--out", type=Path, default=Path("runs/benchmark"), help="directory for benchmark.json")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--sections", default=",".join(SECTIONS),
                   help=f"comma-separated subset of {','.join(SECTIONS)}")
    p.add_argument("--compare-with", type=Path, default=None, metavar="DIR",
                   help="also time the FootstepDoor-v0 steady walk on the footstep_gym package found in DIR "
                        "(another checkout: the 'before' of a change), in the same interleaved rounds")
    p.add_argument("--_memory-child", dest="memory_child", default=None, help=argparse.SUPPRESS)
    p.add_argument("--_cell-worker", dest="cell_worker", default=None, help=argparse.SUPPRESS)
    p.add_argument("--_ppo-child", dest="ppo_child", default=None, help=argparse.SUPPRESS)
    p.add_argument("--_memory-server", dest="memory_server", action="store_true", help=argparse.SUPPRESS)
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    args = parse_args(argv)
    if args.memory_child:
        print(json.dumps(finite_json(_memory_child(json.loads(args.memory_child)))))
        return {}
    if args.memory_server:
        print(json.dumps(_memory_server(json.loads(sys.stdin.read()))))
        return {}
    if args.cell_worker:
        _cell_worker(json.loads(args.cell_worker))
        return {}
    if args.ppo_child:
        print(json.dumps(finite_json(_ppo_child(json.loads(args.ppo_child)))))
        return {}
    if args.compare_with is not None and not (args.compare_with / "footstep_gym" / "__init__.py").is_file():
        raise SystemExit(f"--compare-with {args.compare_with}: no footstep_gym package there")
    settings = MODES["full" if args.full else "smoke" if args.smoke else "quick"]
    sections = [s.strip() for s in args.sections.split(",") if s.strip()]
    unknown = set(sections) - set(SECTIONS)
    if unknown:
        raise SystemExit(f"unknown section(s) {sorted(unknown)}; choose from {SECTIONS}")
    robot = load_robot()
    started = time.time()
    t0 = time.perf_counter()
    res: dict[str, Any] = {"meta": {"mode": settings.name, "settings": settings.__dict__, "seed": args.seed,
                                    "sections": sections, "machine": machine_info(),
                                    "started_unix": started, "nominal_period_s": robot.nominal_period}}
    res["meta"]["load_average_start"] = loadavg()
    replays: dict[str, list] = {}
    if "planners" in sections or "env" in sections:
        log("planners ...")
        planners, replays = bench_planners(settings, args.seed)
        if "planners" in sections:
            res["planners"] = planners
    if "lipm" in sections:
        log("lipm ...")
        res["lipm"] = bench_lipm(settings, args.seed)
    if "env" in sections:
        log("env steps ...")
        res["env_steps"] = bench_envs(settings, args.seed, replays, args.compare_with)
        if args.compare_with is not None:
            res["meta"]["compare_with"] = str(args.compare_with)
    if "memory" in sections:
        log("memory ...")
        res["memory"] = bench_memory(settings)
    if "ppo" in sections:
        log("ppo ...")
        res["ppo"] = bench_ppo(settings)
    res["meta"]["duration_s"] = time.perf_counter() - t0
    res["meta"]["torch_imported"] = "torch" in sys.modules  # the benchmarked paths are torch-free
    res["meta"]["load_average_end"] = loadavg()
    res["targets"], res["ratios"] = evaluate_targets(res, robot.nominal_period)
    text = report(res)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "benchmark.json").write_text(json.dumps(finite_json(res), indent=2) + "\n", encoding="utf-8")
    (args.out / "benchmark.md").write_text(text + "\n", encoding="utf-8")
    log(f"wrote {args.out / 'benchmark.json'}")
    return res


if __name__ == "__main__":
    main()
