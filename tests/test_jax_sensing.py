"""Sensing in the JAX backend (footstep_gym.jax.sensing): noise, range and field of view against the reference.

The reference's :func:`footstep_gym.sensing.sense` is the oracle of the sensed poses and of which obstacles are
kept, given the same standard normals; reference episodes with a range and a field of view (deterministic) replay
in float64 observation for observation; with noise (drawn from the JAX key, not the reference's generator) the
episodes end alike with the same rewards, and the observation's noise has the configured spread.
"""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import footstep_gym  # noqa: F401
from jax_helpers import OBS_TOL_64, REWARD_TOL_64
from footstep_gym.errors import ConfigError
from footstep_gym.jax import replay as R
from footstep_gym.jax.env import FootstepJaxEnv
from footstep_gym.jax.sensing import Sensing, noisy_rods, sensed
from footstep_gym.jax.shapes import Rods
from footstep_gym.observation import HEAD
from footstep_gym.robot import load_robot
from footstep_gym.sensing import ObstacleView, sense

NOISE = dict(sensing_noise_position=0.05, sensing_noise_velocity=0.1, sensing_noise_angle=0.03,
             sensing_noise_angular_velocity=0.04)
LIMITED = dict(sensing_max_range=1.2, sensing_fov=120.0)
SIGMA = (0.05, 0.1, 0.03, 0.04)


def _random_scene(rng: np.random.Generator, m: int) -> tuple[Rods, list[ObstacleView]]:
    """``m`` moving obstacles (every other one a circle on its body's origin, the rest rods) as JAX rods and as
    the reference's views."""
    circle = np.arange(m) % 2 == 0
    pos = rng.uniform(-2.0, 2.0, (m, 2))
    angle = rng.uniform(-math.pi, math.pi, m)
    vel = rng.normal(0.0, 0.3, (m, 2))
    omega = np.where(circle, 0.0, rng.normal(0.0, 0.5, m))
    half = np.where(circle, 0.0, rng.uniform(0.1, 0.6, m))
    a = np.stack([-half, np.zeros(m)], -1)
    b = np.stack([half, np.zeros(m)], -1)
    r = rng.uniform(0.02, 0.2, m)
    rods = Rods(*(jnp.asarray(x) for x in (pos, angle, vel, omega, a, b, r)))
    views = [ObstacleView(f"o{i}", "circle" if circle[i] else "segment", False, tuple(pos[i]), float(angle[i]),
                          tuple(vel[i]), float(omega[i]), float(r[i]), tuple(a[i]), tuple(b[i])) for i in range(m)]
    return rods, views


@pytest.mark.parametrize("max_range, fov", [(math.inf, 360.0), (1.0, 360.0), (math.inf, 90.0), (1.5, 150.0)])
def test_sensed_obstacles_are_the_references(x64, max_range, fov):
    """200 random scenes of 8 obstacles (circles and rods), random robots, the same normals: the JAX sense keeps the
    obstacles the reference's ``sense`` keeps, with the same noisy poses and velocities (a circle's angle and turn
    rate untouched)."""
    rng = np.random.default_rng(7)
    kept_some = dropped_some = 0
    for _ in range(200):
        rods, views = _random_scene(rng, 8)
        z = rng.standard_normal((8, 6))
        point, heading = rng.uniform(-1.0, 1.0, 2), rng.uniform(-math.pi, math.pi)
        want = sense(tuple(views), tuple(point), heading, max_range, fov, z.tolist(), SIGMA)
        noisy = noisy_rods(rods, jnp.asarray(z), SIGMA)
        mask = np.asarray(sensed(noisy, point[0], point[1], heading, max_range, fov))
        assert [v.name for v in want] == [f"o{i}" for i in np.flatnonzero(mask)]
        for v in want:
            i = int(v.name[1:])
            assert np.allclose(np.asarray(noisy.position[i]), v.position, rtol=0, atol=1e-15)
            assert np.allclose(np.asarray(noisy.velocity[i]), v.velocity, rtol=0, atol=1e-15)
            assert float(noisy.angle[i]) == pytest.approx(v.angle, abs=1e-15)
            assert float(noisy.angular_velocity[i]) == pytest.approx(v.angular_velocity, abs=1e-15)
        kept_some += mask.sum()
        dropped_some += (~mask).sum()
    assert kept_some > 0
    if max_range < math.inf or fov < 360.0:
        assert dropped_some > 0  # the limits left some out: the comparison covered both answers


@pytest.mark.parametrize("env_id, scenario", [("FootstepCrowd-v0", "crowd"), ("FootstepDoor-v0", "door")])
def test_range_and_field_of_view_replay(x64, env_id, scenario):
    """Reference episodes (train tier: circles, and the door's turning rod) with a sensing range and a field of view
    replayed in float64: the same endings at the same steps, observations and rewards within the replay tolerances;
    and the limits changed the observations (the same episodes without them observe otherwise)."""
    limited = dict(tier="train", **LIMITED)
    episodes = R.record_many(env_id, range(300, 303), "walk", limited, max_steps=25)
    jenv = FootstepJaxEnv(scenario, dtype="float64", **limited)
    for a in R.compare(episodes, R.replay(jenv, episodes, pad_to=25)):
        assert a.same, a
        assert a.obs_error <= OBS_TOL_64 and a.reward_error <= REWARD_TOL_64, a
    blind = R.record_many(env_id, range(300, 303), "walk", {"tier": "train"}, max_steps=25)
    assert any(len(b.obs) != len(e.obs) or not np.allclose(b.obs, e.obs, atol=1e-3) for b, e in zip(blind, episodes))


def test_sensed_count_is_the_references(x64):
    """``info["sensed_obstacles"]`` step by step beside the reference env's, on a crowd episode with a range and a
    field of view (the robot walks into the ring, so the count changes)."""
    env = gym.make("FootstepCrowd-v0", tier="train", **LIMITED)
    env.reset(seed=301)
    jenv = FootstepJaxEnv("crowd", dtype="float64", tier="train", **LIMITED)
    episode = R.record("FootstepCrowd-v0", 301, "walk", dict(tier="train", **LIMITED), max_steps=25)
    rods, scene = R.episode_start(jenv, episode.config, episode.start)
    params = R.episode_params(jenv, [episode])
    state, _ = jenv.start_state(jax.random.key(0), jnp.asarray(episode.feet), rods, scene, params,
                                jnp.zeros((), jnp.int32))
    step = jax.jit(lambda s, a: jenv.step(jax.random.key(1), s, a, params))
    counts = set()
    for action in episode.actions:
        _, _, terminated, truncated, info = env.step(action)
        state, _, _, _, _, jinfo = step(state, jnp.asarray(action))
        assert int(jinfo["sensed_obstacles"]) == info["sensed_obstacles"]
        counts.add(info["sensed_obstacles"])
        if terminated or truncated:
            break
    assert len(counts) > 1
    env.close()


def test_noise_changes_only_the_sensed_slots(x64):
    """Crossing episodes (the car stream's capsules) replayed with the noise on: the same endings and rewards as the
    reference's (noise reaches the observation only), the robot's own slots equal, the obstacle slots not."""
    noisy = dict(tier="train", **NOISE)
    episodes = R.record_many("FootstepCrossing-v0", range(310, 313), "walk", noisy, max_steps=25)
    got = R.replay(FootstepJaxEnv("crossing", dtype="float64", **noisy), episodes, pad_to=25)
    for i, a in enumerate(R.compare(episodes, got)):
        assert a.same and a.reward_error <= REWARD_TOL_64, a
        n = len(episodes[i].obs)
        assert np.allclose(got.obs[i, :n, :HEAD], episodes[i].obs[:, :HEAD], rtol=0, atol=OBS_TOL_64)
        assert not np.allclose(got.obs[i, :n, HEAD:], episodes[i].obs[:, HEAD:], atol=1e-3)


def test_noise_has_the_configured_spread(x64):
    """The crowd's members are circles that do not turn: a slot's velocity is the sensed body velocity, so over 4,000
    keys its spread is the velocity noise's std over the velocity scale (and its mean the truth's); the same key
    gives the same observation, a step from the same state with the same key the same one, another key another."""
    env = FootstepJaxEnv("crowd", dtype="float64", tier="train", **NOISE)
    blind = FootstepJaxEnv("crowd", dtype="float64", tier="train")
    state, _ = env.reset(jax.random.key(3), env.default_params)
    p = env.default_params
    truth = np.asarray(blind.observation(state, blind.default_params))
    keys = jax.random.split(jax.random.key(4), 4000)
    obs = np.asarray(jax.jit(jax.vmap(env.observation, in_axes=(None, None, 0)))(state, p, keys))
    scale = env.config.observation_velocity_scale
    vel = obs[:, HEAD + 2:HEAD + 4]  # the first slot's velocity (the nearest member, every draw here)
    assert truth[HEAD + 4] == 1.0 and np.all(obs[:, HEAD + 4] == 1.0)
    assert np.allclose(vel.std(axis=0), SIGMA[1] / scale, rtol=0.05)
    assert np.allclose(vel.mean(axis=0), truth[HEAD + 2:HEAD + 4], atol=4 * SIGMA[1] / scale / math.sqrt(4000))
    assert np.allclose(np.asarray(env.observation(state, p, keys[0])), obs[0], rtol=0, atol=OBS_TOL_64)  # jit: ulps
    nominal = jnp.asarray(env.robot.nominal_command)
    s1, o1, *_ = env.step(keys[0], state, nominal, p)
    again, o1_again, *_ = env.step(keys[0], state, nominal, p)
    other, o1_other, *_ = env.step(keys[1], state, nominal, p)
    assert np.array_equal(np.asarray(o1), np.asarray(o1_again))  # the step's key draws the noise: replayable
    assert not np.array_equal(np.asarray(o1), np.asarray(o1_other))
    assert np.array_equal(np.asarray(o1[:HEAD]), np.asarray(o1_other[:HEAD]))  # the robot's own slots are not noisy
    with pytest.raises(ValueError, match="needs a key"):
        env.observation(state, p)


def test_noise_tier_cells_in_make_vec():
    """The crossing's noise tier (its two cells) runs batched in float32, ``sensed_obstacles`` in ``info``; the
    crowd's is built with the profile's options; the door's (one door and two: each cell its own walls) steps too."""
    envs = gym.make_vec("FootstepCrossing-v0", num_envs=4, vectorization_mode="vector_entry_point", tier="noise")
    obs, _ = envs.reset(seed=5)
    obs, _, _, _, info = envs.step(np.tile(np.asarray(load_robot().nominal_command, np.float32), (4, 1)))
    assert obs.shape == (4, envs.single_observation_space.shape[0]) and np.all(np.isfinite(obs))
    assert info["sensed_obstacles"].shape == (4,) and np.all(info["sensed_obstacles"] >= 1)
    envs.close()
    assert FootstepJaxEnv("crowd", tier="noise").sensing.sigma == (0.02, 0.05, 0.01, 0.01)
    door = FootstepJaxEnv("door", tier="noise")
    assert door.cells == ["train", "two_doors"] and door.per_cell_walls and door.scene.size == 2
    envs = gym.make_vec("FootstepDoor-v0", num_envs=4, vectorization_mode="vector_entry_point", tier="noise")
    envs.reset(seed=5)
    obs, _, _, _, info = envs.step(np.tile(np.asarray(load_robot().nominal_command, np.float32), (4, 1)))
    assert np.all(np.isfinite(obs)) and set(info["tier_cell"]) <= {"train", "two_doors"}
    envs.close()
    assert FootstepJaxEnv("door", tier="noise", tier_cell="train").sensing == Sensing(
        (0.02, 0.05, 0.01, 0.01), math.inf, 360.0)



def test_cells_with_different_sensing_are_one_line(monkeypatch):
    """The sensing options are static in the compiled step: a tier whose cells sense differently (no shipped tier
    does; here the crossing's noise tier with its last cell's field of view narrowed) is one line naming it."""
    import footstep_gym.jax.env as jax_env

    def narrow_last_cell(*args, **kwargs):
        robot, configs = real(*args, **kwargs)
        last = list(configs)[-1]
        cfg, ecfg = configs[last]
        return robot, {**configs, last: (cfg, dataclasses.replace(ecfg, sensing_fov=90.0))}

    real = jax_env.cell_configs
    monkeypatch.setattr(jax_env, "cell_configs", narrow_last_cell)
    with pytest.raises(ConfigError) as err:
        FootstepJaxEnv("crossing", tier="noise")
    assert "tier 'noise': cells with different sensing options" in str(err.value) and "\n" not in str(err.value)
