"""The JAX crossing (footstep_gym.jax.scenes.CrossingScene) against the reference env: replays of reference
episodes (the paper's timed car, the train tier's car stream with its gap, the wide cars), the traffic's
schedule against ``CrossingTraffic``'s through a car's re-entry, seeding, unsupported settings (make_vec:
tests/test_jax_vector.py).

JAX compiles each distinct function once per process: the episodes here are few and short.
"""

from __future__ import annotations


import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import footstep_gym  # noqa: F401
from jax_helpers import check_replays
from footstep_gym.errors import ConfigError
from footstep_gym.jax import replay as R
from footstep_gym.jax.env import FootstepJaxEnv
from footstep_gym.scenes import crossing as crossing_scene

CROSSING = "FootstepCrossing-v0"
TRAIN = {"tier": "train"}
PAPER = {"tier": "paper"}
WIDE = {"tier": "structure", "tier_cell": "wide_cars"}


@pytest.mark.parametrize("kwargs", [TRAIN, PAPER, WIDE], ids=["train", "paper", "wide_cars"])
def test_replayed_episodes_end_alike(x64, kwargs):
    """Reference episodes (open-loop walks, fuzzed float32 actions, the period-aware planner on the train tier;
    train-split seeds) replayed in float64: the same ending at the same step, observations, rewards and the
    sweep's clearances within the stated tolerances."""
    jenv = FootstepJaxEnv("crossing", dtype="float64", **kwargs)
    outcomes: set[str] = set()
    walks = R.record_many(CROSSING, range(300, 304), "walk", kwargs, max_steps=30)
    fuzz = R.record_many(CROSSING, range(300, 302), "fuzz", kwargs, max_steps=30)
    check_replays(R.compare(walks + fuzz, R.replay(jenv, walks + fuzz, pad_to=30)), outcomes)
    assert {"collision", "fall"} & outcomes
    if kwargs is TRAIN:
        planned = R.record_many(CROSSING, [300], "planner", kwargs, max_steps=30)
        check_replays(R.compare(planned, R.replay(jenv, planned, pad_to=30)), outcomes)


def test_traffic_schedule_is_the_references(x64):
    """``CrossingScene.positions`` against ``CrossingTraffic.positions`` on a reference episode's draws, before
    and after cars re-enter their lane; ``before_step`` puts the cars there and keeps their velocities."""
    env = gym.make(CROSSING, tier="train")
    env.reset(seed=11)
    u = env.unwrapped
    jenv = FootstepJaxEnv("crossing", dtype="float64", **TRAIN)
    rods, scene = R.episode_start(jenv, u.episode_config, jenv.scene.reference_start(u))
    loop_time = float(scene.loop) / float(scene.speed)
    for t in (0.0, 1.3, 0.5 * loop_time, loop_time + 0.7, 2.3 * loop_time):
        got = np.asarray(crossing_scene.positions(jnp, scene, jnp.asarray(t)))
        assert np.allclose(got, u.scenario.positions(t), rtol=0, atol=1e-12)
    t = 0.6 * loop_time
    moved, _ = jenv.scene.before_step(scene, rods, jnp.asarray(t), jnp.asarray(0.8))
    u.scenario.before_step(u.world, t, 0.8)
    bodies = [m.body for m in u.scenario.members]
    assert np.allclose(np.asarray(moved.position), [tuple(b.position) for b in bodies], rtol=0, atol=1e-12)
    assert np.array_equal(np.asarray(moved.velocity), [tuple(b.velocity) for b in bodies])
    env.close()


def test_reset_draws_the_tiers_cars():
    env = FootstepJaxEnv("crossing", **TRAIN)
    keys = jax.random.split(jax.random.key(2), 5)
    reset = jax.jit(jax.vmap(lambda k: env.reset(k, env.default_params)))
    state, obs = reset(keys)
    again, obs_again = reset(keys)
    assert np.array_equal(np.asarray(obs), np.asarray(obs_again))
    assert np.array_equal(np.asarray(state.rods.position), np.asarray(again.rods.position))
    speeds = np.abs(np.asarray(state.rods.velocity[:, :, 1]))
    assert np.all((speeds >= 0.2 - 1e-6) & (speeds <= 0.3 + 1e-6))  # the train tier's traffic_speed
    assert len({float(s) for s in speeds[:, 0]}) == 5
    loops = np.asarray(state.scene.loop)
    assert np.all((loops >= 11 * 0.9 + 1.5 - 1e-5) & (loops <= 11 * 0.9 + 1.7 + 1e-5))  # 12 cars, one gap
    paper = FootstepJaxEnv("crossing", **PAPER)
    s, _ = paper.reset(jax.random.key(0), paper.default_params)
    assert s.rods.position.shape == (1, 2) and not bool(s.scene.traffic)
    assert float(s.rods.velocity[0, 1]) == pytest.approx(0.25)


@pytest.mark.parametrize("kwargs, named", [
    ({"randomize": {"obstacle_length": [0.4, 0.6]}}, "randomize of obstacle_length"),
    ({"fixed_period": True}, "fixed_period"),
])
def test_unsupported_crossing_settings_raise_one_line(kwargs, named):
    with pytest.raises(ConfigError) as err:
        FootstepJaxEnv("crossing", **kwargs)
    assert named in str(err.value) and "\n" not in str(err.value)
