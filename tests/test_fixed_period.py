"""The fixed-period action form (``fixed_period=True``): ``[S, L, theta]`` with T_SS, T_DS at nominal.

The oracle is the full env driven with the same strides and the nominal period: a replay of
one form against the other must give the same commands, observations, rewards and ends (the
same code path on the same machine: exact).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym.errors import ActionError

ENV_IDS = ("FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0")


def test_fixed_period_action_space_is_the_first_three_fields():
    full = gym.make("FootstepDoor-v0").unwrapped
    fixed = gym.make("FootstepDoor-v0", fixed_period=True).unwrapped
    assert fixed.action_space.shape == (3,)
    np.testing.assert_array_equal(fixed.action_space.low, full.action_space.low[:3])
    np.testing.assert_array_equal(fixed.action_space.high, full.action_space.high[:3])
    assert fixed.observation_space == full.observation_space


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_fixed_period_replays_the_full_form_at_nominal_period(env_id):
    full = gym.make(env_id)
    fixed = gym.make(env_id, fixed_period=True)
    robot = full.unwrapped.robot
    nominal = [robot.nominal_t_ss, robot.nominal_t_ds]
    rng = np.random.default_rng(3)
    for episode in range(6):
        o1, _ = full.reset(seed=episode)
        o2, _ = fixed.reset(seed=episode)
        np.testing.assert_array_equal(o1, o2)
        for _ in range(40):
            strides = rng.uniform(full.action_space.low[:3], full.action_space.high[:3]).astype(np.float64)
            r1 = full.step(np.concatenate([strides, nominal]))
            r2 = fixed.step(strides)
            assert r1[4]["command"] == r2[4]["command"]
            assert r2[4]["command"][3:] == tuple(nominal)
            np.testing.assert_array_equal(r1[0], r2[0])
            assert r1[1:4] == r2[1:4]
            if r1[2] or r1[3]:
                break


def test_fixed_period_float32_actions_read_at_the_box_edge():
    """What SB3 sends: float32 at the rounded bounds is the bound itself, and the period stays nominal."""
    env = gym.make("FootstepCrossing-v0", fixed_period=True)
    robot = env.unwrapped.robot
    env.reset(seed=0)
    action = np.array([robot.stride_front[1], robot.stride_side[0], 0.0], dtype=np.float32)
    _, _, _, _, info = env.step(action)
    assert info["command"] == (robot.stride_front[1], robot.stride_side[0], 0.0, robot.nominal_t_ss,
                               robot.nominal_t_ds)
    assert info["clipped"] is False


def test_fixed_period_rejects_a_five_field_action():
    env = gym.make("FootstepDoor-v0", fixed_period=True)
    env.reset(seed=0)
    with pytest.raises(ActionError, match=r"expected \(3,\) = \[S, L, theta\]"):
        env.step(np.zeros(5))


def test_fixed_period_passes_gymnasiums_checker():
    import warnings

    from gymnasium.utils.env_checker import check_env

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(gym.make("FootstepCrowd-v0", fixed_period=True).unwrapped, skip_render_check=True)
    # What the full form warns about too (tests/test_spaces.py): the unnormalised box, the unbounded slots.
    known = ("symmetric and normalized space", "minimum value is -infinity", "maximum value is infinity")
    unexpected = [str(w.message) for w in caught if not any(k in str(w.message) for k in known)]
    assert not unexpected, unexpected
