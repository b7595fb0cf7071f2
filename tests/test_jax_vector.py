"""The batched backend behind Gymnasium's VectorEnv: make_vec, seeding, autoreset as Gymnasium defines it,
bad actions refused before anything changes, unsupported settings in one line."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import footstep_gym  # noqa: F401
from footstep_gym.errors import ActionError, ConfigError
from footstep_gym.jax.env import SUPPORTED_SCENES
from footstep_gym.jax.vector import FootstepVectorEnv
from footstep_gym.scenarios import SCENARIOS

N = 4
WALK = np.array([0.05, 0.08, 0.0, 0.6, 0.2], dtype=np.float32)
#: From stepping in place straight to the shortest period and longest stride: a fall (docs/model.md §3.3).
FALL = np.array([0.1, 0.12, 0.0, 0.1, 0.1], dtype=np.float32)


def _make(mode: AutoresetMode) -> FootstepVectorEnv:
    return gym.make_vec("FootstepDoor-v0", num_envs=N, vectorization_mode="vector_entry_point", tier="train",
                        autoreset_mode=mode)


@pytest.fixture(scope="module")
def next_step():
    envs = _make(AutoresetMode.NEXT_STEP)
    yield envs
    envs.close()


@pytest.fixture(scope="module")
def same_step():
    envs = _make(AutoresetMode.SAME_STEP)
    yield envs
    envs.close()


def test_make_vec_gives_the_batched_backend(next_step):
    assert isinstance(next_step, FootstepVectorEnv)
    assert next_step.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    obs, info = next_step.reset(seed=10)
    assert obs.shape == (N, 42) and obs.dtype == np.float32 and obs in next_step.observation_space
    assert len({o.tobytes() for o in obs}) == N  # seeds 10..13: four episodes
    again, _ = next_step.reset(seed=10)
    assert np.array_equal(obs, again)
    shifted, _ = next_step.reset(seed=11)
    assert np.array_equal(shifted[:-1], obs[1:])  # env i is seeded with seed + i
    listed, _ = next_step.reset(seed=[13, 12, 11, 10])
    assert np.array_equal(listed, obs[::-1])


def test_next_step_autoreset(next_step):
    obs0, _ = next_step.reset(seed=0)
    actions = np.stack([FALL, WALK, WALK, FALL])
    obs, reward, terminated, truncated, info = next_step.step(actions)
    assert terminated.tolist() == [True, False, False, True] and not truncated.any()
    assert info["termination"][0] == "fall" and reward[0] == pytest.approx(-10.05)
    assert info["_termination"].all()
    # The next step resets the ended envs (reward 0, not done, a first observation) and steps the others.
    obs2, reward2, terminated2, truncated2, info2 = next_step.step(np.stack([WALK] * N))
    assert reward2[0] == 0.0 and reward2[3] == 0.0 and not terminated2[[0, 3]].any()
    assert info2["_termination"].tolist() == [False, True, True, False]
    assert obs2[0, 7:12].tolist() == obs0[0, 7:12].tolist()  # the nominal command again, as after reset
    assert not np.array_equal(obs2[0], obs0[0])  # the env's next episode: its own key's draws


def test_same_step_autoreset(same_step):
    obs_start, _ = same_step.reset(seed=0)
    obs, reward, terminated, truncated, info = same_step.step(np.stack([FALL, WALK, WALK, WALK]))
    assert terminated.tolist() == [True, False, False, False]
    assert info["_final_obs"].tolist() == [True, False, False, False]
    final = info["final_obs"][0]
    assert final.shape == (42,) and not np.array_equal(final, obs[0])
    assert info["final_info"]["termination"][0] == "fall"
    assert np.allclose(final[7:12], [1, 1, 0, -1, -1], atol=1e-6)  # the fall's command in the last observation
    assert np.allclose(obs[0, 7:12], obs_start[0, 7:12])  # the nominal one in the next episode's first
    # The returned observation is the next episode's first: stepping in place is feasible from it.
    obs2, reward2, terminated2, *_ = same_step.step(np.stack([np.array([0, 0.08, 0, 0.6, 0.2], np.float32)] * N))
    assert not terminated2[0]


@pytest.mark.parametrize("bad, named", [
    (np.full((N, 5), np.nan, np.float32), "non-finite S"),
    (np.zeros((N, 4), np.float32), "shape=(4, 4)"),
    (np.zeros(5, np.float32), "shape=(5,)"),
])
def test_bad_actions_raise_before_any_change(next_step, bad, named):
    next_step.reset(seed=5)
    with pytest.raises(ActionError, match=named.replace("(", r"\(").replace(")", r"\)")):
        next_step.step(bad)
    after, *_ = next_step.step(np.stack([WALK] * N))
    next_step.reset(seed=5)
    fresh, *_ = next_step.step(np.stack([WALK] * N))
    assert np.array_equal(after, fresh)


def test_nan_in_one_env_names_it(next_step):
    next_step.reset(seed=5)
    actions = np.stack([WALK] * N)
    actions[2, 3] = np.inf
    with pytest.raises(ActionError, match="env 2 has a non-finite T_SS"):
        next_step.step(actions)


def test_unsupported_settings_are_one_clear_line():
    with pytest.raises(ConfigError) as err:
        gym.make_vec("FootstepCrowd-v0", num_envs=2, vectorization_mode="vector_entry_point", crowd_model="orca")
    text = str(err.value)
    assert "crowd_model='orca'" in text and "vectorization_mode='sync'" in text and "\n" not in text
    with pytest.raises(gym.error.Error, match="FootstepMix-v0"):
        gym.make_vec("FootstepMix-v0", num_envs=2, vectorization_mode="vector_entry_point")


def test_vector_entry_points_are_the_supported_scenes():
    assert {name for name, cls in SCENARIOS.items() if cls.vector_entry_point} == set(SUPPORTED_SCENES)


@pytest.mark.parametrize("env_id, scenario, tier", [("FootstepCrossing-v0", "crossing", "train"),
                                                    ("FootstepCrowd-v0", "crowd", "structure")])
def test_make_vec_gives_the_batched_crossing_and_crowd(env_id, scenario, tier):
    """The crossing's train tier and the crowd's structure tier (ORCA pedestrians and rings) through make_vec."""
    envs = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", tier=tier)
    try:
        assert isinstance(envs, FootstepVectorEnv) and envs.jax_env.scenario == scenario
        obs, _ = envs.reset(seed=3)
        assert obs.shape == (3, 42) and obs in envs.observation_space
        walk = np.tile(np.array([0.05, 0.08, 0.0, 0.6, 0.2], np.float32), (3, 1))
        for _ in range(3):
            obs, reward, *_ = envs.step(walk)
        assert obs in envs.observation_space and np.all(np.isfinite(reward))
    finally:
        envs.close()


VECTOR_SPLIT = textwrap.dedent("""
    import numpy as np, gymnasium as gym
    from footstep_gym.jax import speed
    assert speed.use_cpu_devices(2) == 2
    runs = {}
    for devices in (1, 2):
        for mode in ("NextStep", "SameStep"):
            envs = gym.make_vec("FootstepDoor-v0", num_envs=8, vectorization_mode="vector_entry_point",
                                tier="structure", devices=devices, autoreset_mode=mode)
            obs, _ = envs.reset(seed=3)
            rng = np.random.default_rng(0)
            out = [obs]
            for i in range(30):
                box = envs.single_action_space
                a = rng.uniform(box.low, box.high, (8, 5)).astype(np.float32)
                if i % 2:
                    a[:] = np.array([0.05, 0.08, 0.0, 0.6, 0.2], np.float32)
                o, r, te, tr, info = envs.step(a)
                out += [o, r, te, tr, info["termination"], info["tier_cell"]]
            if devices == 2:
                assert len(envs._state.feet.sharding.device_set) == 2
            envs.close()
            runs[(devices, mode)] = out
    ended = 0
    for mode in ("NextStep", "SameStep"):
        for x, y in zip(runs[(1, mode)], runs[(2, mode)]):
            if x.dtype.kind in "bO":
                assert np.array_equal(x, y), (mode, x, y)
                ended += int(x.dtype.kind == "b" and x.sum())
            else:
                assert np.allclose(x, y, rtol=0, atol=1e-5), mode
    assert ended > 0
    print("ok")
""")


def test_a_batch_on_two_devices_plays_the_same_episodes():
    """A fresh interpreter with two CPU devices: the structure tier (one door and two, walls per cell) on 8 envs,
    both autoreset modes: every ending, cell and termination the same as on one device, floats within 1e-5."""
    out = subprocess.run([sys.executable, "-c", VECTOR_SPLIT], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-3000:]


def test_devices_that_do_not_divide_the_batch_are_refused():
    with pytest.raises(ConfigError, match="devices must be a whole number from 1 to"):
        FootstepVectorEnv(6, "door", tier="train", devices=4)
