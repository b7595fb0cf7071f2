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
    another. The step and the observations run ``chunk`` envs at a time
    (:meth:`~footstep_gym.jax.env.FootstepJaxEnv.step_batch`), the resets over the whole batch at once (faster on
    a CPU than inside the chunks). Each env's returned observation is computed once, from the state returned (the
    fresh episode's or the stepped one's); ``step_obs`` is computed only where a caller reads it.
    """
    params = env.default_params if params is None else params
    keys = jax.vmap(lambda k: jax.random.split(k, 3))(state.key)
    k_step = keys[:, 1]
    stepped, reward, terminated, truncated, info = env.transition_batch(state._replace(key=keys[:, 0]), actions,
                                                                         params, chunk)
    fresh, k_fresh = jax.vmap(env.reset_state, in_axes=(0, None))(keys[:, 2], params)
    mask = (terminated | truncated) if reset is None else reset
    noisy = env.sensing is not None and env.sensing.noisy
    # The stepped episodes' observation (and sensed count): what jit leaves uncomputed where a caller reads neither.
    step_obs, n_sensed = env.observe_batch(stepped, params, k_step if noisy else None, chunk)
    if n_sensed is not None:
        info = {**info, "sensed_obstacles": n_sensed}
    # The observation returned, computed once per env: the fresh episode's where reset, the stepped one's elsewhere.
    new = where(mask, fresh, stepped)
    k_obs = None
    if noisy:
        k_obs = jax.random.wrap_key_data(where(mask, jax.random.key_data(k_fresh), jax.random.key_data(k_step)))
    obs, _ = env.observe_batch(new, params, k_obs, chunk)
    return AutoresetStep(new, obs, step_obs, reward, terminated, truncated, info)
