"""The mixed-scene env ``FootstepMix-v0`` (footstep_gym/mix.py).

Its errors name the mix and the scene of the episode. (The mix also runs through the vector-env tests of
test_env_api.py, its spaces in test_spaces.py and its configuration in test_config.py.)
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym
from env_helpers import FREE, NOMINAL


# ------------------------------------------------------------------ stepping after the end
def test_mix_env_after_the_end_raises_naming_the_mix_and_the_scene():
    env = gym.make("FootstepMix-v0", scenes=["crossing", "door"], crossing=dict(max_steps=2, **FREE),
                   door=dict(max_steps=2))
    with pytest.raises(gym.error.ResetNeeded, match="reset"):
        env.step(NOMINAL)
    with pytest.raises(gym.error.ResetNeeded, match=r"FootstepMixEnv \(scene 'crossing'\): call reset\(\) before step"):
        env.unwrapped.step(NOMINAL)
    for seed in range(4):
        _, info = env.reset(seed=seed)
        scene = info["scene"]
        env.step(NOMINAL)
        _, _, terminated, truncated, _ = env.step(NOMINAL)
        assert truncated and not terminated
        with pytest.raises(gym.error.ResetNeeded) as exc:
            env.step(NOMINAL)
        assert str(exc.value).startswith(f"FootstepMix-v0 (scene '{scene}'): episode ended (truncated: max_steps=2 reached) at step 2")
    bad = NOMINAL.copy()
    bad[3] = np.nan
    env.reset(seed=0)
    with pytest.raises(footstep_gym.ActionError, match=r"FootstepMix-v0 \(scene '\w+'\): .*t_ss=nan"):
        env.step(bad)
