"""Walls built once per scene and kept across resets (footstep_gym/env.py, ``Scenario.static_keys``).

A used env replays a fresh one bit for bit, also when ``randomize`` draws keys the walls do not read;
every key the walls read is named in ``static_keys``, and a randomized geometry key rebuilds the walls.
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

from env_helpers import ENV_IDS, NOMINAL
from footstep_gym import config
from footstep_gym.errors import ConfigError
from footstep_gym.scenarios import SCENARIOS


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reset_after_another_episode_replays_a_fresh_env(env_id):
    """The walls kept across resets change nothing: a used env replays a fresh one bit for bit."""
    def rollout(env, seed):
        obs, _ = env.reset(seed=seed)
        out = [obs]
        env.action_space.seed(seed)
        for _ in range(6):
            obs, reward, terminated, truncated, info = env.step(env.unwrapped.robot.nominal_command)
            out.append(np.append(obs, [reward, info["time"]]))
            if terminated or truncated:
                break
        return out

    fresh = gym.make(env_id)
    used = gym.make(env_id)
    rollout(used, 11)
    for a, b in zip(rollout(fresh, 3), rollout(used, 3), strict=True):
        np.testing.assert_array_equal(a, b)
    assert sorted(o.name for o in fresh.unwrapped.world.obstacles) == sorted(o.name for o in used.unwrapped.world.obstacles)


def test_walls_kept_across_randomized_speeds_replay_fresh_envs():
    """With ``randomize`` on a key the walls do not read, each episode of a used env is a fresh env's."""
    kwargs = {"randomize": {"door_speed": [5.0, 20.0], "door_angle_jitter": [0.0, 20.0]}}
    used = gym.make("FootstepDoor-v0", **kwargs)
    used.reset(seed=5)
    world = used.unwrapped.world
    for seed in (3, 4):
        fresh = gym.make("FootstepDoor-v0", **kwargs)
        for env in (fresh, used):
            env.reset(seed=seed)
        assert used.unwrapped.world is world  # walls kept
        assert fresh.unwrapped.episode_config == used.unwrapped.episode_config
        for _ in range(8):
            a, b = fresh.step(NOMINAL), used.step(NOMINAL)
            np.testing.assert_array_equal(a[0], b[0])
            assert a[1:4] == b[1:4] and a[4]["time"] == b[4]["time"] and a[4]["clearance"] == b[4]["clearance"]
            if a[2] or a[3]:
                break


@pytest.mark.parametrize("scene", sorted(SCENARIOS))
def test_static_keys_name_every_key_the_walls_read(scene):
    """Changing any key outside ``Scenario.static_keys`` leaves ``build_static``'s walls as they were."""
    from footstep_gym.world import World

    cls = SCENARIOS[scene]
    base = cls.load_config()

    def walls(cfg):
        world = World(0.1, 0.001, 0.02, 0.25, 2000)
        cls(cfg, np.random.default_rng(0)).build_static(world)
        return [(o.name, o.local_a, o.local_b, o.radius) for o in world.obstacles]

    if cls.static_keys is None:
        pytest.skip(f"{scene}: every key counts")
    changed = 0
    for f in dataclasses.fields(base):
        if f.name in cls.static_keys:
            continue
        value = getattr(base, f.name)
        if isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, float) for v in value):
            options = [tuple(v * 1.05 + 0.01 for v in value)]
        elif isinstance(value, float):
            options = [value * 0.9 + 0.01]
        else:
            options = []
        for new in options:
            try:
                cfg = config.replace(base, **{f.name: new})
            except ConfigError:
                continue
            assert walls(cfg) == walls(base), f.name
            changed += 1
    assert changed >= 5
    for key in cls.static_keys:  # and each static key does change them
        value = getattr(base, key)
        new = (tuple(v * 1.02 + 0.01 for v in value) if isinstance(value, tuple) else
               value + 1 if isinstance(value, int) else value * 1.02)
        assert walls(config.replace(base, **{key: new})) != walls(base), key


def test_randomized_geometry_rebuilds_the_walls():
    env = gym.make("FootstepDoor-v0", randomize={"door_radius": [0.45, 0.5]})
    env.reset(seed=0)
    ends = {o.name: tuple(o.shape.a) for o in env.unwrapped.world.obstacles if o.name == "wall_top_right"}
    env.reset(seed=1)
    again = {o.name: tuple(o.shape.a) for o in env.unwrapped.world.obstacles if o.name == "wall_top_right"}
    assert ends != again  # the upper wall's end follows the drawn door radius
    assert len([o for o in env.unwrapped.world.obstacles if o.name == "wall_top_right"]) == 1
