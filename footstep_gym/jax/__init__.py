"""The batched JAX backend: footstep scenes as pure, jittable, vmappable functions, and their vector env.

* :class:`footstep_gym.jax.env.FootstepJaxEnv`: ``reset(key, params)`` / ``step(key, state, action, params)`` over a
  state pytree (gymnax / Brax style), for JAX users;
* ``gymnasium.make_vec("FootstepDoor-v0", num_envs=N, vectorization_mode="vector_entry_point")`` (the crossing's
  and the crowd's ids too): the same behind Gymnasium's ``VectorEnv`` (numpy in and out),
  :class:`footstep_gym.jax.vector.FootstepVectorEnv`;
* :mod:`footstep_gym.jax.replay`: episodes of the reference env replayed here (the equivalence check).

Importing this package imports JAX; ``import footstep_gym`` does not.
"""

try:
    import jax  # noqa: F401
except ImportError as exc:  # one line saying what to install, or how to do without
    raise ImportError(f"footstep_gym.jax (the batched JAX backend, gymnasium.make_vec's default for the door, the "
                      f"crossing and the crowd) needs JAX ({exc}): pip install 'footstep_gym[jax]', or "
                      f"gymnasium.make_vec(..., vectorization_mode=\"sync\") for reference envs") from None
