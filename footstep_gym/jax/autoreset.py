"""The one autoreset of the JAX env: a footstep, and where an episode ends a fresh one in its place.

:func:`step_autoreset` steps a batch and serves every batched user: Gymnasium's vector env
(:class:`footstep_gym.jax.vector.FootstepVectorEnv`, its ``SAME_STEP`` and ``NEXT_STEP`` modes), the throughput
engine (:mod:`footstep_gym.jax.speed`) and Brax's trainer (:mod:`footstep_gym.rl.brax_env`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from footstep_gym.jax.env import FootstepJaxEnv


class AutoresetStep(NamedTuple):
    """What :func:`step_autoreset` returns. ``state`` and ``obs``: the fresh episode's where it was reset, the
    stepped one's elsewhere; ``step_obs``, ``reward``, ``terminated``, ``truncated``, ``info``: the step's
    (``step_obs`` is the last observation of an episode that ended)."""

    state: Any
    obs: jax.Array
    step_obs: jax.Array
    reward: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    info: dict[str, Any]


def where(mask: jax.Array, a: Any, b: Any) -> Any:
    """``a`` where ``mask`` (a scalar, or one flag per leading entry), else ``b``, leaf by leaf of two pytrees."""
    return jax.tree.map(lambda x, y: jnp.where(jnp.reshape(mask, mask.shape + (1,) * (x.ndim - mask.ndim)), x, y),
                        a, b)


def step_autoreset(env: FootstepJaxEnv, state: Any, actions: jax.Array, chunk: int = 64, params: Any = None,
                   reset: jax.Array | None = None) -> AutoresetStep:
    """One footstep of a batch of ``env`` (a :class:`~footstep_gym.jax.env.FootstepJaxEnv`; ``state``'s leaves and
    ``actions`` lead with the batch), then a fresh episode in place of the stepped one where ``reset`` (default:
    where this step ended the episode, Gymnasium's ``SAME_STEP``; a vector env in ``NEXT_STEP`` mode passes the
    envs whose episode ended at the step before).

    ``params``: the episodes' settings (:class:`~footstep_gym.jax.env.EnvParams`; default the env's
    :attr:`~footstep_gym.jax.env.FootstepJaxEnv.default_params`). Each env's key is split in three: the stepped
    episode's next key, the step's (its sensing noise draws from it) and the fresh episode's
    (:meth:`~footstep_gym.jax.env.FootstepJaxEnv.reset`), so an env's episodes come from its own key, one after
    another. The step runs ``chunk`` envs at a time
    (:meth:`~footstep_gym.jax.env.FootstepJaxEnv.step_batch`), the resets over the whole batch at once (faster on
    a CPU than inside the chunks).
    """
    params = env.default_params if params is None else params
    keys = jax.vmap(lambda k: jax.random.split(k, 3))(state.key)
    stepped, obs, reward, terminated, truncated, info = env.step_batch(keys[:, 1], state._replace(key=keys[:, 0]),
                                                                       actions, params, chunk)
    fresh, fresh_obs = jax.vmap(env.reset, in_axes=(0, None))(keys[:, 2], params)
    mask = (terminated | truncated) if reset is None else reset
    return AutoresetStep(where(mask, fresh, stepped), where(mask, fresh_obs, obs), obs, reward, terminated,
                         truncated, info)
