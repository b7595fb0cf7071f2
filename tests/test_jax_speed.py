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
    state, _ = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(4), n))
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
