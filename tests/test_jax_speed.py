"""The throughput engine (footstep_gym/jax/speed.py): a batch split over devices runs each device's envs as the
one-device rollout of that share would, and bad splits are refused.

JAX fixes its device count when it starts, so the two-device run is a fresh interpreter.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import jax
import pytest

from footstep_gym.jax import speed
from footstep_gym.jax.env import FootstepJaxEnv

SPLIT = textwrap.dedent("""
    import jax, numpy as np
    from footstep_gym.jax import speed
    assert speed.use_cpu_devices(2) == 2
    from footstep_gym.jax.env import FootstepJaxEnv
    env = FootstepJaxEnv("door", tier="train")
    n, steps = 8, 6
    keys = jax.random.split(jax.random.key(3), 2)
    state, _ = jax.jit(jax.vmap(lambda k: env.reset(k, env.default_params)))(jax.random.split(jax.random.key(4), n))
    for workload in ("walk", "random"):
        both = speed.rollout_fn(env, n, steps, workload, chunk=2, devices=2)(speed.split_over(state, 2),
                                                                            speed.split_over(keys, 2))
        one = speed.rollout_fn(env, n // 2, steps, workload, chunk=2)
        halves = [one(jax.tree.map(lambda x: x[i * n // 2:(i + 1) * n // 2], state), keys[i:i + 1]) for i in (0, 1)]
        assert len(both[0].feet.sharding.device_set) == 2
        assert np.array_equal(np.asarray(both[0].steps), np.concatenate([np.asarray(h[0].steps) for h in halves]))
        for a, b in zip(jax.tree.leaves(both[0]), zip(*(jax.tree.leaves(h[0]) for h in halves))):
            if jax.dtypes.issubdtype(a.dtype, jax.dtypes.prng_key):
                a, b = jax.random.key_data(a), tuple(jax.random.key_data(x) for x in b)
            assert np.allclose(np.asarray(a), np.concatenate([np.asarray(x) for x in b]), rtol=0, atol=1e-6)
        assert np.allclose(np.asarray(both[2]), [float(h[2][0]) for h in halves], rtol=1e-6)
    print("ok")
""")


def test_a_batch_split_over_two_devices_runs_each_half_as_one_device_would():
    """Two CPU devices in a fresh interpreter: each device's half of the batch ends where the one-device rollout of
    that half with the same key ends (steps exactly, floats within float32's last bits), both workloads."""
    out = subprocess.run([sys.executable, "-c", SPLIT], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-3000:]


def test_bad_splits_and_late_device_changes_are_refused():
    env = FootstepJaxEnv("door", tier="train")
    with pytest.raises(ValueError, match="do not split over 3 device"):
        speed.rollout_fn(env, 8, 2, "walk", devices=3)
    with pytest.raises(ValueError, match="workload must be one of"):
        speed.rollout_fn(env, 8, 2, "run")
    jax.numpy.zeros(1).block_until_ready()  # JAX has started in this process
    with pytest.raises(RuntimeError, match="before backends are initialized"):
        speed.use_cpu_devices(2)
    with pytest.raises(ValueError, match="count must be >= 1"):
        speed.use_cpu_devices(0)


def test_the_sync_vector_env_beside_it_runs_both_workloads():
    """The SyncVectorEnv figure printed beside the batched one: reference envs stepped through Gymnasium's own
    vector env on the same workloads."""
    for workload in ("walk", "random"):
        assert speed.sync_vector_rate(3, workload, {"tier": "train"}, 2) > 0.0
    with pytest.raises(ValueError, match="workload must be one of"):
        speed.sync_vector_rate(3, "jog", {"tier": "train"}, 2)


def test_the_jittery_walker_and_the_make_vec_figure():
    """The ``jitter`` workload stays in the action box around the walk and varies; ``vector_rate`` steps the
    Gymnasium vector env (numpy in and out) on it; the observing rollout adds the observations to its sum."""
    import gymnasium as gym
    import numpy as np

    space = gym.spaces.Box(np.array([-0.04, 0.07, -0.4, 0.1, 0.1], np.float32),
                           np.array([0.1, 0.12, 0.4, 0.6, 0.3], np.float32))
    batch = gym.vector.utils.batch_space(space, 64)
    acts = speed.host_actions("jitter", batch, np.random.default_rng(0))
    assert acts.shape == (64, 5) and acts.dtype == np.float32 and acts in batch
    assert 0.0 < np.abs(acts - np.asarray(speed.WALK, np.float32)).max() < 0.5 and len(np.unique(acts[:, 0])) > 32
    rate = speed.vector_rate("FootstepDoor-v0", 4, 3, 1, "jitter", {"tier": "train"})
    assert rate.n == 4 and rate.steps_per_s > 0.0 and len(rate.repeats) == 1
    env = FootstepJaxEnv("door", tier="train")
    state, _ = jax.jit(jax.vmap(lambda k: env.reset(k, env.default_params)))(jax.random.split(jax.random.key(1), 4))
    keys = jax.random.split(jax.random.key(2), 1)
    plain = speed.rollout_fn(env, 4, 2, "jitter", chunk=2)(state, keys)[2]
    seen = speed.rollout_fn(env, 4, 2, "jitter", chunk=2, observe=True)(state, keys)[2]
    assert float(seen[0]) != float(plain[0])


def test_the_orca_figure_times_reference_crowds_and_their_array_twins():
    """baselines/orca_speed.py's engine: the reference env's ORCA crowds of a cell, timed in pyrvo and in JAX."""
    crowds = speed.orca_crowds("closing_in", 2)
    assert len(crowds) == 2 and len(crowds[0].radii) == 6 and crowds[0].positions != crowds[1].positions
    ref, rate = speed.orca_rates(crowds, 4, 2, 1)
    assert ref > 0.0 and rate.n == 4 and rate.steps_per_s > 0.0
    with pytest.raises(ValueError, match="is not an ORCA crowd"):
        speed.orca_crowds("dense", 1)
