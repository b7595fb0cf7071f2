"""PPO training throughput: env steps/s inside ``model.learn`` with :data:`PPO_ENVS` envs, FootstepDoor-v0
beside CartPole-v1 with the same network and hyperparameters (the ceiling: what PPO itself costs), in a
fresh interpreter (torch stays out of the speed run's process) (:func:`bench_ppo`)."""

from __future__ import annotations

from typing import Any

from .fresh import ChildFailed, call_fresh
from .settings import Settings
from .timing import summary

#: PPO throughput cells: (env id, whose configs/rl/ppo.yml entry to train with); CartPole with the door's network
#: and hyperparameters is the ceiling (an env step that costs next to nothing).
PPO_CELLS = (("FootstepDoor-v0", None), ("CartPole-v1", "FootstepDoor-v0"))
PPO_ENVS = (1, 2)
PPO_TIMEOUT_S = 3600


def ppo_child(spec: dict[str, Any]) -> dict[str, dict[str, list[float]]]:
    """Runs in its own interpreter (torch stays out of the speed run's): PPO env steps/s per cell and round.

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
    network and hyperparameters: the ceiling), and their ratio paired per round. In a fresh interpreter."""
    spec = {"timesteps": settings.ppo_timesteps, "rounds": settings.ppo_rounds}
    try:
        rates = call_fresh(ppo_child, spec, timeout=PPO_TIMEOUT_S, quiet=True)
    except ChildFailed as exc:
        if exc.status is None:
            return {"skipped": f"PPO child timed out after {PPO_TIMEOUT_S} s"}
        return {"skipped": f"PPO child failed: {exc}"[:300]}
    out: dict[str, Any] = {"timesteps": settings.ppo_timesteps, "rounds": settings.ppo_rounds,
                           "hyperparameters": {e: h or e for e, h in PPO_CELLS}, "cells": {}, "ratios": {}}
    for env_id, by_n in rates.items():
        out["cells"][env_id] = {n: {"steps_per_s": summary(r), "rates": r} for n, r in by_n.items()}
    door, ceiling = (rates.get(e) for e, _ in PPO_CELLS)
    if door and ceiling:
        for n in door:
            out["ratios"][n] = summary([a / b for a, b in zip(door[n], ceiling[n])])
    return out
