"""LIPM feasibility checks per second: ``lipm.check_step`` (one command, plain Python) and
``lipm.check_steps`` with batches of :data:`LIPM_BATCHES` (:func:`bench_lipm`)."""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from footstep_gym import lipm
from footstep_gym.robot import load_robot

from .settings import Settings, log
from .timing import summary

LIPM_BATCHES = (1, 32, 1024)


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
