"""The batched JAX backend as a stable-baselines3 ``VecEnv``: SB3's algorithms train on it unchanged.

::

    from stable_baselines3 import PPO
    from footstep_gym.rl.sb3_jax import FootstepSB3VecEnv

    venv = FootstepSB3VecEnv(256, "door", tier="train")   # 256 envs stepped in one JAX call
    PPO("MlpPolicy", venv, n_steps=64, batch_size=4096).learn(1_000_000)

SB3's vector-env contract, on :class:`~footstep_gym.jax.vector.FootstepVectorEnv` in Gymnasium's
``SAME_STEP`` autoreset mode: ``step_wait`` returns ``dones = terminated | truncated``; an env that ended
returns the next episode's first observation, the last one in its info's ``terminal_observation``, with
``TimeLimit.truncated`` (truncated and not terminated) and ``is_success``. ``seed(s)`` then ``reset()``
seeds env ``i`` with ``s + i``, as SB3's own vector envs do; without a seed each reset draws fresh ones.
Actions are ``(num_envs, 5)`` commands in SI units (wrap with ``VecNormalize`` / rescale as for the
reference env); a wrong shape or a non-finite value raises
:class:`~footstep_gym.errors.ActionError` before any env changes.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvStepReturn

from footstep_gym.jax import shapes
from footstep_gym.jax.vector import FootstepVectorEnv


class FootstepSB3VecEnv(VecEnv):
    """``num_envs`` envs of :class:`~footstep_gym.jax.env.FootstepJaxEnv` behind SB3's ``VecEnv``.

    Args:
        num_envs: envs in the batch.
        scenario: the scene (``"door"``; what the JAX backend supports, docs/jax.md).
        dtype, block, chunk, env_kwargs: as :class:`~footstep_gym.jax.vector.FootstepVectorEnv`'s (``tier``,
            scenario keys, env.yaml keys).
    """

    def __init__(self, num_envs: int, scenario: str = "door", *, dtype: Any = "float32",
                 block: int = shapes.DEFAULT_BLOCK, chunk: int = 64, **env_kwargs: Any) -> None:
        self.venv = FootstepVectorEnv(num_envs, scenario, autoreset_mode=AutoresetMode.SAME_STEP, dtype=dtype,
                                      block=block, chunk=chunk, **env_kwargs)
        self.render_mode = None
        super().__init__(self.venv.num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self._actions: np.ndarray | None = None

    def reset(self) -> np.ndarray:
        """Every env's first observation, ``(num_envs, obs_dim)`` float32; seeded by a preceding ``seed(s)``."""
        seeds = None if self._seeds[0] is None else [int(s) for s in self._seeds]
        obs, _ = self.venv.reset(seed=seeds)
        self._reset_seeds()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = self.venv._check_actions(actions)

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("FootstepSB3VecEnv.step_wait: no step_async before it")
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        self._actions = None
        dones = terminated | truncated
        success = np.asarray(info["is_success"], dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(dones):
            infos[i] = {"terminal_observation": info["final_obs"][i], "is_success": bool(success[i]),
                        "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                        "termination": info["final_info"]["termination"][i]}
        return obs, reward.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs  # the JAX backend does not render (docs/jax.md)

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """``attr_name`` of the batch's one JAX env (the same for every index), e.g. ``spec`` or ``render_mode``."""
        target = self if attr_name == "render_mode" else self.venv.jax_env
        return [getattr(target, attr_name)] * len(self._get_indices(indices))

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        raise AttributeError(f"FootstepSB3VecEnv: the batch's envs share one JAX env; {attr_name!r} cannot be set "
                             "per env")

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        method = getattr(self.venv.jax_env, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: VecEnvIndices = None) -> list[bool]:
        return [False] * len(self._get_indices(indices))
