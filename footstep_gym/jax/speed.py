"""Throughput of the batched backend beside the reference env (the engine of ``baselines/jax_speed.py``).

A batch of ``n`` envs runs ``steps`` footsteps in one compiled ``lax.scan`` (actions drawn inside it, ended
episodes reset on the same step), so the figure is the backend's, not numpy's or Python's. Compile time is
measured apart, on the first call. Two workloads:

* ``random``: actions uniform in the action box (about half fall at once and reset: resets weigh heavily,
  as in the reference env's speed tiers);
* ``walk``: every env walks 5 cm strides at the nominal period towards the goal (the sweep's checks weigh
  heavily: envs walk the door's corridor, reach the door and hit it or pass; in the crowd the ring closes in);
* ``jitter``: a jittery near-nominal walker: the walk's command plus Gaussian noise of :data:`JITTER` per field,
  clipped to the action box (envs end at different steps, as a learner's early policy does).

:func:`vector_rate` times the same workloads through ``gymnasium.make_vec`` (numpy in and out, what an SB3 or
CleanRL user steps), so the in-JAX figure and the Gymnasium one can be printed from one run.

``devices``: the batch split evenly over that many JAX devices (``jax.shard_map``), each running its share as one
program. On a CPU, XLA runs one program on one core; :func:`use_cpu_devices` splits the CPU into as many devices
as it has cores (before JAX starts), so a batch uses them all.
"""

from __future__ import annotations

import functools
import os
import statistics
import time
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np

import footstep_gym  # noqa: F401
from footstep_gym.jax.autoreset import step_autoreset
from footstep_gym.jax.env import FootstepJaxEnv

WORKLOADS = ("random", "walk", "jitter")
WALK = (0.05, 0.08, 0.0, 0.6, 0.2)
#: The ``jitter`` workload's standard deviations about :data:`WALK` (S [m], L [m], theta [rad], T_SS [s], T_DS [s]).
JITTER = (0.01, 0.005, 0.05, 0.03, 0.02)


@dataclass
class Rate:
    """One measurement: ``n`` envs, ``steps_per_s`` (median of the repeats), the first call's compile time."""

    n: int
    steps_per_s: float
    compile_s: float
    repeats: list[float]
    state_bytes: int


def use_cpu_devices(count: int | None = None) -> int:
    """Split the CPU into ``count`` JAX devices (default: one per core), before JAX has started its backends;
    returns the number of devices JAX then has. Raises ``RuntimeError`` once JAX has started."""
    if count is None:
        count = os.cpu_count() or 1
    if count < 1:
        raise ValueError(f"use_cpu_devices: count must be >= 1, got {count}")
    jax.config.update("jax_num_cpu_devices", int(count))
    return len(jax.devices())


def rollout_fn(env: FootstepJaxEnv, n: int, steps: int, workload: str, chunk: int = 64, devices: int = 1,
               observe: bool = False) -> Any:
    """``(state, keys) -> (state, keys, rewards sum per device)``: ``steps`` batched footsteps with same-step resets,
    the batch split over the first ``devices`` devices (``keys``: one per device). Without ``observe`` nothing reads
    the observations, so XLA leaves them uncomputed (the backend's step alone); with it the sum also takes in each
    env's next observation (the step's, or the fresh episode's first where one ended), which a learner reads."""
    if workload not in WORKLOADS:
        raise ValueError(f"workload must be one of {WORKLOADS}, got {workload!r}")
    if devices < 1 or n % devices or devices > len(jax.devices()):
        raise ValueError(f"rollout_fn: {n} envs do not split over {devices} device(s) ({len(jax.devices())} exist)")
    local = n // devices  # envs per device
    low = jnp.asarray(env.action_space.low)
    high = jnp.asarray(env.action_space.high)
    walk = jnp.asarray(WALK, jnp.float32)
    jitter = jnp.asarray(JITTER, jnp.float32)

    def body(carry, _):
        state, key, total = carry
        key, k_act = jax.random.split(key)
        if workload == "random":
            actions = jax.random.uniform(k_act, (local, 5), jnp.float32, low, high)
        elif workload == "jitter":
            actions = jnp.clip(walk + jitter * jax.random.normal(k_act, (local, 5), jnp.float32), low, high)
        else:
            actions = jnp.broadcast_to(walk, (local, 5))
        out = step_autoreset(env, state, actions, chunk)
        if observe:
            total = total + jnp.sum(out.obs).astype(total.dtype)
        return (out.state, key, total + jnp.sum(out.reward)), None

    def run(state, keys):
        (state, key, total), _ = jax.lax.scan(body, (state, keys[0], jnp.zeros((), env.dtype)), None, length=steps)
        return state, key[None], total[None]

    return jax.jit(on_devices(run, devices))


def on_devices(fn: Any, devices: int) -> Any:
    """``fn`` (every argument and result leading with the batch) run by each of the first ``devices`` devices on its
    share of the batch (``jax.shard_map``); ``fn`` itself for one. Keywords are passed to ``fn`` as they are."""
    if devices == 1:
        return fn
    mesh, spec = batch_mesh(devices), jax.sharding.PartitionSpec("env")

    def run(*args: Any, **static: Any) -> Any:
        return jax.shard_map(functools.partial(fn, **static), mesh=mesh, in_specs=spec, out_specs=spec,
                             check_vma=False)(*args)  # each device steps its own envs: nothing is shared

    return run


def batch_mesh(devices: int) -> jax.sharding.Mesh:
    """The first ``devices`` JAX devices along one axis, ``"env"``: the batch's."""
    return jax.make_mesh((devices,), ("env",), devices=jax.devices()[:devices])


def split_over(tree: Any, devices: int) -> Any:
    """``tree``'s leaves (leading with the batch) laid out evenly over the first ``devices`` devices."""
    if devices == 1:
        return tree
    return jax.device_put(tree, jax.sharding.NamedSharding(batch_mesh(devices), jax.sharding.PartitionSpec("env")))


def measure(env: FootstepJaxEnv, n: int, steps: int, repeats: int, workload: str, seed: int = 0, chunk: int = 64,
            devices: int = 1, observe: bool = False) -> Rate:
    """Steps/s of ``n`` envs over ``repeats`` runs of ``steps`` batched footsteps (median), compile apart
    (``chunk``: :meth:`FootstepJaxEnv.step_batch`'s; ``devices``, ``observe``: :func:`rollout_fn`'s)."""
    fn = rollout_fn(env, n, steps, workload, chunk, devices, observe)
    key = split_over(jax.random.split(jax.random.key(seed), devices), devices)
    state, _ = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(jax.random.split(jax.random.key(seed + 1), n),
                                                                env.default_params)
    state = split_over(state, devices)
    t0 = time.perf_counter()
    state, key, total = fn(state, key)
    total.block_until_ready()
    compile_s = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        state, key, total = fn(state, key)
        total.block_until_ready()
        times.append(time.perf_counter() - t0)
    rates = [n * steps / t for t in times]
    state_bytes = sum(x.nbytes // n for x in jax.tree.leaves(state) if hasattr(x, "nbytes"))
    return Rate(n, statistics.median(rates), compile_s, rates, int(state_bytes))


def host_actions(workload: str, space: gym.spaces.Box, rng: np.random.Generator) -> np.ndarray:
    """One batch of ``workload``'s actions (numpy float32, ``space``'s shape: one env's or a batch's) for the
    envs stepped from Python."""
    if workload not in WORKLOADS:
        raise ValueError(f"workload must be one of {WORKLOADS}, got {workload!r}")
    walk = np.broadcast_to(np.asarray(WALK, np.float32), space.shape)
    if workload == "walk":
        return walk.copy()
    if workload == "random":
        return rng.uniform(space.low, space.high).astype(np.float32)
    noise = rng.normal(size=space.shape).astype(np.float32) * np.asarray(JITTER, np.float32)
    return np.clip(walk + noise, space.low, space.high)


def vector_rate(env_id: str, n: int, steps: int, repeats: int, workload: str, env_kwargs: dict, seed: int = 0,
                devices: int = 1, bank: int = 16) -> Rate:
    """Env steps/s of ``gymnasium.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")`` (the
    batched backend, numpy actions in, numpy observations and infos out, Gymnasium's autoreset): the median of
    ``repeats`` runs of ``steps`` steps after 3 of warm-up (the first call's compile apart). The actions cycle
    through ``bank`` batches drawn before timing, so the figure is the env's, not the action generator's."""
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", devices=devices, **env_kwargs)
    rng = np.random.default_rng(seed)
    actions = [host_actions(workload, envs.action_space, rng) for _ in range(bank)]
    t0 = time.perf_counter()
    envs.reset(seed=seed)
    envs.step(actions[0])
    compile_s = time.perf_counter() - t0
    for i in range(2):
        envs.step(actions[1 + i])
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for i in range(steps):
            envs.step(actions[i % bank])
        rates.append(n * steps / (time.perf_counter() - t0))
    envs.close()
    return Rate(n, statistics.median(rates), compile_s, rates, 0)


def sync_vector_rate(steps: int, workload: str, env_kwargs: dict, num_envs: int, seed: int = 0,
                     env_id: str = "FootstepDoor-v0") -> float:
    """Env steps/s of Gymnasium's ``SyncVectorEnv`` of ``num_envs`` reference envs on the same workload (its own
    autoreset), ``steps`` batched steps after 20 of warm-up."""
    if workload not in WORKLOADS:
        raise ValueError(f"workload must be one of {WORKLOADS}, got {workload!r}")
    envs = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="sync", **env_kwargs)
    rng = np.random.default_rng(seed)
    envs.reset(seed=seed)

    def act() -> np.ndarray:
        return host_actions(workload, envs.action_space, rng)

    for _ in range(20):
        envs.step(act())
    t0 = time.perf_counter()
    for _ in range(steps):
        envs.step(act())
    rate = steps * num_envs / (time.perf_counter() - t0)
    envs.close()
    return rate


def reference_rate(steps: int, workload: str, env_kwargs: dict, seed: int = 0, env_id: str = "FootstepDoor-v0"
                   ) -> float:
    """Steps/s of one reference env (``gymnasium.make(env_id)``) on the same workload, reset at episode end."""
    if workload not in WORKLOADS:
        raise ValueError(f"workload must be one of {WORKLOADS}, got {workload!r}")
    env = gym.make(env_id, **env_kwargs)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    actions = [host_actions(workload, env.action_space, rng) for _ in range(256)]
    for i in range(50):  # warm-up (numba's sweep loads on the first step)
        _, _, te, tr, _ = env.step(actions[i])
        if te or tr:
            env.reset()
    t0 = time.perf_counter()
    for i in range(steps):
        _, _, te, tr, _ = env.step(actions[i % 256])
        if te or tr:
            env.reset()
    rate = steps / (time.perf_counter() - t0)
    env.close()
    return rate


def orca_crowds(cell: str, count: int, tier: str = "structure", seed: int = 0) -> list:
    """``count`` reference ORCA crowds (:class:`~footstep_gym.scenarios.orca.OrcaCrowd`) of ``tier``'s ``cell``, the
    episodes of seeds ``seed``, ``seed + 1``, ... as the reference env draws them."""
    env = gym.make("FootstepCrowd-v0", tier=tier, tier_cell=cell).unwrapped
    crowds = []
    for s in range(seed, seed + count):
        env.reset(seed=s)
        if env.scenario.orca is None:
            raise ValueError(f"orca_crowds: cell {cell!r} of tier {tier!r} is not an ORCA crowd")
        crowds.append(env.scenario.orca)
    env.close()
    return crowds


def orca_rates(crowds: list, n: int, steps: int, repeats: int, duration: float = 0.8, chunk: int = 64
               ) -> tuple[float, Rate]:
    """Crowd footsteps/s of ``duration`` [s]: one reference crowd after another (pyrvo, ``OrcaCrowd.advance``: each
    crowd's second to fifth footsteps) and
    ``n`` crowds at once in JAX (:func:`footstep_gym.scenes.orca.advance` under ``jit``, ``vmap`` over chunks of
    ``chunk`` crowds run one after another, so each chunk's loops stop where its own crowds' do; the ``crowds``
    repeated to ``n``; median of ``repeats`` runs of ``steps`` footsteps, compile apart)."""
    import copy

    from footstep_gym.scenes import orca

    ref = [copy.deepcopy(c) for c in crowds]
    for c in ref:  # warm-up: each crowd's first footstep
        c.advance(duration)
    t0 = time.perf_counter()
    for _ in range(4):
        for c in ref:
            c.advance(duration)
    ref_rate = 4 * len(ref) / (time.perf_counter() - t0)
    c0, p = crowds[0], crowds[0].params
    if any(c.robot_radius is not None for c in crowds):
        raise ValueError("orca_rates: crowds that see the robot are not timed here")

    def crowd_of(c: Any) -> Any:
        return orca.crowd_of(c.positions, c.goals, c.radii, c.speeds, p.neighbor_dist, p.max_neighbors,
                             p.time_horizon, p.safety_space, None, xp=np, dtype=np.float32)

    one = [crowd_of(c) for c in crowds]
    batch = jax.tree.map(lambda *x: jnp.asarray(np.stack([x[i % len(x)] for i in range(n)])), *one)
    k = orca.neighbor_slots(one[0].agents.max_neighbors, len(c0.radii))
    subs = int(orca.substeps(duration, p.time_step))
    one_step = jax.vmap(lambda c: orca.advance(c, jnp.asarray(duration, jnp.float32), p.time_step, subs, None, k, jnp))

    @jax.jit
    def step(batch: Any) -> Any:
        if n <= chunk or n % chunk:
            return one_step(batch)
        out = jax.lax.map(one_step, jax.tree.map(lambda x: x.reshape((n // chunk, chunk) + x.shape[1:]), batch))
        return jax.tree.map(lambda x: x.reshape((n,) + x.shape[2:]), out)

    t0 = time.perf_counter()
    out = step(batch)
    jax.block_until_ready(out)
    compile_s = time.perf_counter() - t0
    rates = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(steps):
            batch = step(batch)[0]
        jax.block_until_ready(batch)
        rates.append(n * steps / (time.perf_counter() - t0))
    return ref_rate, Rate(n, statistics.median(rates), compile_s, rates, 0)
