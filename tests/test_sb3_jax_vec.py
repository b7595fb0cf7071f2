"""The JAX backend behind stable-baselines3's ``VecEnv`` (``footstep_gym.rl.sb3_jax``).

Checked against Gymnasium's vector env of the same backend (``FootstepVectorEnv``, NEXT_STEP autoreset) from the
same seeds and actions: the same observations, rewards and endings up to each env's first ending, where SB3's
contract puts the last observation in ``terminal_observation``; then SB3's PPO trains on it through
``VecNormalize`` and ``VecMonitor``, and a bad action is refused before any env changes.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("jax")

from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize  # noqa: E402

from footstep_gym.errors import ActionError  # noqa: E402
from footstep_gym.rl.sb3_jax import FootstepSB3VecEnv  # noqa: E402
from footstep_gym.jax.vector import FootstepVectorEnv  # noqa: E402

N = 4


@pytest.fixture(scope="module")
def venv() -> FootstepSB3VecEnv:
    """One batch for the module (each new one compiles its JAX functions again)."""
    return FootstepSB3VecEnv(N, "door", tier="train")


def _actions(rng: np.random.Generator, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Walking commands (a forward stride, a period inside the box) with some random spread, float32 as SB3 sends."""
    nominal = np.array([0.04, 0.08, 0.0, 0.6, 0.2])
    a = nominal + rng.normal(0.0, 0.1, size=(N, 5)) * (high - low)
    return np.clip(a, low, high).astype(np.float32)


def test_the_sb3_adapter_steps_as_gymnasiums_vector_env(venv):
    sb3, gym_vec = venv, FootstepVectorEnv(N, "door", tier="train")
    sb3.seed(7)
    obs = sb3.reset()
    ref_obs, _ = gym_vec.reset(seed=7)
    np.testing.assert_array_equal(obs, ref_obs)
    assert obs.shape == (N, *sb3.observation_space.shape) and obs.dtype == np.float32
    low, high = sb3.action_space.low, sb3.action_space.high
    rng = np.random.default_rng(0)
    ended = np.zeros(N, dtype=bool)
    endings = 0
    for _ in range(60):
        a = _actions(rng, low, high)
        obs, reward, dones, infos = sb3.step(a)
        ref_obs, ref_reward, term, trunc, ref_info = gym_vec.step(a)
        live = ~ended
        np.testing.assert_allclose(reward[live], ref_reward[live], rtol=1e-6, atol=1e-6)
        np.testing.assert_array_equal(dones[live], (term | trunc)[live])
        for i in np.flatnonzero(dones & live):
            np.testing.assert_array_equal(infos[i]["terminal_observation"], ref_obs[i])  # NEXT_STEP: the last obs
            assert infos[i]["is_success"] == bool(ref_info["is_success"][i])
            assert infos[i]["TimeLimit.truncated"] == bool(trunc[i] and not term[i])
            assert infos[i]["termination"] == ref_info["termination"][i]
            endings += 1
        for i in np.flatnonzero(~dones & live):
            np.testing.assert_array_equal(obs[i], ref_obs[i])
            assert infos[i] == {}
        ended |= dones
        if ended.all():
            break
    assert endings >= 1
    assert sb3.get_attr("render_mode") == [None] * N and sb3.env_is_wrapped(VecMonitor) == [False] * N


def test_seeding_gives_the_same_batch_and_no_seed_a_fresh_one(venv):
    venv.seed(3)
    first = venv.reset()
    venv.seed(3)
    np.testing.assert_array_equal(venv.reset(), first)
    assert not np.array_equal(venv.reset(), first)  # the seeds are used once (SB3's contract)


def test_sb3_ppo_trains_on_it(venv):
    wrapped = VecNormalize(VecMonitor(venv, info_keywords=("is_success",)), norm_reward=False)
    model = PPO("MlpPolicy", wrapped, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(256)
    assert model.num_timesteps >= 256
    assert len(model.ep_info_buffer) >= 1 and "is_success" in model.ep_info_buffer[0]


def test_a_bad_action_is_refused_before_any_env_changes(venv):
    venv.seed(1)
    venv.reset()
    before = venv.venv._state
    with pytest.raises(ActionError, match="actions shape"):
        venv.step_async(np.zeros((N, 4), dtype=np.float32))
    bad = np.tile(np.array([0.04, 0.08, 0.0, 0.6, 0.2], dtype=np.float32), (N, 1))
    bad[2, 3] = np.nan
    with pytest.raises(ActionError, match="env 2 has a non-finite T_SS"):
        venv.step_async(bad)
    assert venv.venv._state is before
    with pytest.raises(AttributeError, match="cannot be set per env"):
        venv.set_attr("render_mode", "human")
