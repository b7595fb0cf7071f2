"""Memory stays flat in ONE long-lived env instance: thousands of resets and steps after a warm-up.

A leak tied to the env instance (pymunk keeping every shape removed at reset until the space's next
``Space.step``, which the compiled sweep never calls, say) is invisible to a run that makes fresh envs,
so each env here is made once, then reset and stepped a few thousand times (fresh seeds; half the actions outside the
box). Each env runs in a fresh Python process: other tests' allocations would blur the figures,
and memory freed by an env that is done would absorb the next one's growth. The current RSS
comes from ``/proc/self/statm`` (not the peak).

Bound (:data:`MAX_GROWTH`, 1 MiB over the measured 2,000 resets + 4,000 steps): a leak of more than 525
bytes per reset (1 MiB / 2,000) exceeds it, whatever the steps keep.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
ENV_IDS = ("FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0", "FootstepMix-v0")
#: One block of work: this many resets in a row, then this many steps (reset at every episode's end).
BLOCK_RESETS, BLOCK_STEPS = 1000, 2000
#: Blocks before the first RSS reading (the allocators settle), then blocks measured. Every block ends with
#: ``gc.collect()``: pymunk's shapes and bodies are reference cycles, freed by the cyclic collector, whose full
#: collections come at irregular times; collecting at the same points of the work makes the readings compare
#: what is *kept* (without it a leak-free env's RSS still creeps up over the first blocks, as the uncollected
#: garbage reaches its high-water mark, then stays put).
WARMUP_BLOCKS, MEASURED_BLOCKS = 2, 2
#: Largest RSS growth [bytes] allowed over the measured blocks, per env.
MAX_GROWTH = 1 << 20

CHILD = r"""
import gc, json, os, sys
import numpy as np
import gymnasium as gym
import footstep_gym

PAGE = os.sysconf("SC_PAGE_SIZE")
BLOCK_RESETS, BLOCK_STEPS, WARMUP_BLOCKS, MEASURED_BLOCKS = (int(v) for v in sys.argv[1:5])


def rss():
    with open("/proc/self/statm", encoding="ascii") as f:
        return int(f.read().split()[1]) * PAGE


def work(env, rng, seeds, resets, steps):
    low, high = env.action_space.low, env.action_space.high
    span = high - low
    for _ in range(resets):
        env.reset(seed=next(seeds))
    env.reset(seed=next(seeds))
    for i in range(steps):
        a = rng.uniform(low, high)
        if i % 2:  # half the actions up to 50 % of the box outside it (clipped)
            a = a + rng.uniform(-0.5, 0.5, 5) * span
        _, _, terminated, truncated, _ = env.step(a.astype(np.float32))
        if terminated or truncated:
            env.reset(seed=next(seeds))


env = gym.make(sys.argv[5])  # ONE instance for the whole run
rng = np.random.default_rng(0)
seeds = iter(range(10**9))  # fresh seeds: a new episode every reset
for _ in range(WARMUP_BLOCKS):
    work(env, rng, seeds, BLOCK_RESETS, BLOCK_STEPS)
    gc.collect()
start = rss()
for _ in range(MEASURED_BLOCKS):
    work(env, rng, seeds, BLOCK_RESETS, BLOCK_STEPS)
    gc.collect()
print(json.dumps({"package": footstep_gym.__file__, "start": start, "end": rss()}))
"""


def measure(env_id: str, root: Path = ROOT) -> dict:
    """Run the child for ``env_id`` in a fresh interpreter importing ``footstep_gym`` from ``root``.

    One process per env: memory freed by an env that is done (its whole pymunk space) would be
    reused by the next one's growth and hide it.
    """
    env = {**os.environ, "PYTHONPATH": str(root)}
    proc = subprocess.run([sys.executable, "-c", CHILD, str(BLOCK_RESETS), str(BLOCK_STEPS), str(WARMUP_BLOCKS),
                           str(MEASURED_BLOCKS), env_id], cwd=str(root), env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not Path("/proc/self/statm").exists(), reason="needs /proc/self/statm (Linux)")
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rss_flat_over_resets_and_steps_in_one_instance(env_id):
    r = measure(env_id)
    assert Path(r["package"]).resolve().parent.parent == ROOT  # the checkout under test, not another copy
    grown = r["end"] - r["start"]
    assert grown <= MAX_GROWTH, (
        f"{env_id}: RSS grew {grown / 2**20:+.2f} MiB ({r['start'] / 2**20:.1f} -> {r['end'] / 2**20:.1f} MiB) "
        f"over {MEASURED_BLOCKS * BLOCK_RESETS} resets + {MEASURED_BLOCKS * BLOCK_STEPS} steps after warm-up in one "
        f"env instance; the bound is "
        f"{MAX_GROWTH / 2**20:g} MiB")


if __name__ == "__main__":  # python tests/test_memory.py [ROOT]: the figures for that checkout
    root = Path(sys.argv[1]).resolve() if len(sys.argv) > 1 else ROOT
    for env_id in ENV_IDS:
        r = measure(env_id, root)
        print(f"{env_id:22s} {r['start'] / 2**20:7.2f} -> {r['end'] / 2**20:7.2f} MiB "
              f"({(r['end'] - r['start']) / 2**20:+.3f} MiB)  [{r['package']}]")


def test_world_frees_the_shapes_it_removes():
    """The root of the leak, without RSS: a shape removed by ``clear_moving`` must not outlive it.

    Pymunk keeps removed shapes until the space's next ``step``, which the compiled sweep never
    calls; ``World.clear_moving`` must release them.
    """
    import gc
    import weakref

    from footstep_gym.world import World

    world = World(0.1, 0.001, 0.02, 0.25, 2000)
    world.add_wall("wall", (-1.0, -1.0), (1.0, -1.0), 0.02)
    refs = []
    for k in range(50):
        for j in range(4):
            o = world.add_circle(f"c{j}", (float(j), 0.5), 0.1, velocity=(0.1, 0.0))
            refs.append((weakref.ref(o.shape), weakref.ref(o.body)))
        world.add_rod("rod", (0.0, 2.0), (-0.5, 0.0), (0.5, 0.0), 0.02, angular_velocity=1.0)
        world.clear_moving()
    del o
    gc.collect()
    alive = sum(shape() is not None or body() is not None for shape, body in refs)
    assert alive == 0, f"{alive} of {len(refs)} removed obstacles are still alive"
    assert [o.name for o in world.obstacles] == ["wall"] and len(world.space.shapes) == 2  # the wall, the robot
