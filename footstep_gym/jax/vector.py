"""``FootstepVectorEnv``: the batched JAX backend behind Gymnasium's ``VectorEnv`` (numpy in and out).

``gymnasium.make_vec("FootstepDoor-v0", num_envs=N, vectorization_mode="vector_entry_point", **env_kwargs)``
(or ``FootstepCrossing-v0``, ``FootstepCrowd-v0``) makes one (and so does ``make_vec`` without a mode, Gymnasium's rule for an id with a vector entry point;
``vectorization_mode="sync"`` gives N reference envs instead). Everything that is not Gymnasium's (the
settings, the observation, rewards and endings) is :class:`footstep_gym.jax.env.FootstepJaxEnv`'s.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from footstep_gym.errors import ActionError, ConfigError
from footstep_gym.jax import autoreset, shapes, speed
from footstep_gym.jax.env import REWARD_TERMS, TERMINATION_CODES, FootstepJaxEnv, termination_name

#: ``info`` keys returned per step (arrays of ``num_envs``), each with Gymnasium's ``_key`` mask.
INFO_KEYS = ("is_success", "termination", "feasible", "collision", "clipped", "time", "period", "steps",
             "zmp_margin", "clearance")

#: ``info["termination"]``'s names indexed by the JAX env's termination code (an object array: a batch of codes
#: becomes a batch of names by one numpy indexing).
TERMINATION_NAMES = np.array([termination_name(c) for c in range(max(TERMINATION_CODES.values()) + 1)], dtype=object)


def _keys_of(seeds: list[int]) -> jax.Array:
    """One JAX key per seed (any non-negative integer: its ``SeedSequence`` state, so distinct seeds differ)."""
    data = np.stack([np.random.SeedSequence(int(s)).generate_state(2) for s in seeds]).astype(np.uint32)
    return jax.random.wrap_key_data(jnp.asarray(data), impl="threefry2x32")


class FootstepVectorEnv(VectorEnv):
    """``num_envs`` footstep envs stepped at once by :class:`~footstep_gym.jax.env.FootstepJaxEnv`.

    Args:
        num_envs: envs in the batch.
        scenario: the scene (``make_vec`` passes the id's).
        autoreset_mode: Gymnasium's ``AutoresetMode`` (or its value): ``NEXT_STEP`` (Gymnasium's default: the
            step after an episode ends resets that env and returns its first observation, reward 0),
            ``SAME_STEP`` (the ending step returns the next episode's first observation; the last one is in
            ``info["final_obs"]``, its info in ``info["final_info"]``) or ``DISABLED`` (call
            ``reset(options={"reset_mask": mask})``).
        dtype: ``"float32"`` (default) or ``"float64"`` (JAX's 64-bit mode on).
        block, chunk: collision checks per sweep iteration and envs per ``vmap`` chunk (speed only; the answers
            do not depend on them).
        devices: JAX devices the batch is split over, evenly (``num_envs`` must divide by it); on a CPU, split it
            into one device per core first (:func:`footstep_gym.jax.speed.use_cpu_devices`, before JAX starts).
            Speed only: each env's episode is the same on any number of devices.
        env_kwargs: ``gymnasium.make``'s keywords (scenario keys, ``tier``, ``tier_cell``, env.yaml keys).

    Seeding: ``reset(seed=s)`` seeds env ``i`` with ``s + i`` (a list: one seed each), as Gymnasium's vector
    envs do; an env's later episodes draw from its own key. Actions: ``(num_envs, 5)`` floats; a wrong shape
    or a non-finite value raises :class:`~footstep_gym.errors.ActionError` naming the env and field, before
    any env changes. ``info`` holds :data:`INFO_KEYS` (``termination``: ``"goal"``, ``"collision"``,
    ``"fall"`` or ``None``), ``sensed_obstacles`` with a sensing option on, ``tier_cell`` (the episode's cell)
    and ``rewards`` (the terms), each with Gymnasium's ``_key`` mask.
    """

    def __init__(self, num_envs: int = 1, scenario: str = "door", *,
                 autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, dtype: Any = "float32",
                 block: int = shapes.DEFAULT_BLOCK, chunk: int = 64, devices: int = 1, **env_kwargs: Any) -> None:
        if not (isinstance(num_envs, (int, np.integer)) and num_envs >= 1):
            raise ConfigError(f"FootstepVectorEnv: num_envs must be an integer >= 1, got {num_envs!r}")
        if not (isinstance(devices, (int, np.integer)) and 1 <= devices <= len(jax.devices())
                and num_envs % devices == 0):
            raise ConfigError(f"FootstepVectorEnv: devices must be a whole number from 1 to {len(jax.devices())} (the "
                              f"JAX devices here) that divides num_envs={num_envs}, got {devices!r}")
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ConfigError(f"FootstepVectorEnv: autoreset_mode must be one of "
                              f"{[m.value for m in AutoresetMode]}, got {autoreset_mode!r}") from None
        try:
            self.jax_env = env = FootstepJaxEnv(scenario, dtype=dtype, block=block, **env_kwargs)
        except ConfigError as exc:
            raise ConfigError(f"{exc} (gymnasium.make_vec(..., vectorization_mode='sync') gives reference envs)"
                              ) from None
        self.num_envs = int(num_envs)
        if not (isinstance(chunk, int) and chunk >= 1):
            raise ConfigError(f"FootstepVectorEnv: chunk must be an integer >= 1, got {chunk!r}")
        self.chunk = chunk
        self.autoreset_mode = mode
        self.metadata = {"autoreset_mode": mode, "render_modes": []}
        self.render_mode = None
        self.single_action_space = env.action_space
        self.single_observation_space = env.observation_space
        self.action_space = batch_space(env.action_space, self.num_envs)
        self.observation_space = batch_space(env.observation_space, self.num_envs)
        self._state = None
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        #: The episodes' settings (:class:`~footstep_gym.jax.env.EnvParams`), one for every env, compiled in.
        self.params = env.default_params
        self.devices = int(devices)
        self._reset_fn = jax.jit(speed.on_devices(self._reset_batch, self.devices))
        self._step_fn = jax.jit(speed.on_devices(self._step_batch, self.devices), static_argnames=("same_step",))
        self._cell_names = np.empty(len(env.cells), dtype=object)
        self._cell_names[:] = env.cells

    def _put(self, x: Any) -> Any:
        """``x`` (leading with the batch) laid out over the devices."""
        return speed.split_over(x, self.devices)

    # ------------------------------------------------------------------ jitted batch functions
    def _reset_batch(self, keys: jax.Array, state: Any, mask: jax.Array) -> tuple[Any, jax.Array]:
        new, obs = jax.vmap(self.jax_env.reset, in_axes=(0, None))(keys, self.params)
        if state is None:
            return new, obs
        return autoreset.where(mask, new, state), obs

    def _step_batch(self, state: Any, actions: jax.Array, reset_mask: jax.Array, same_step: bool) -> tuple:
        env = self.jax_env

        out = autoreset.step_autoreset(env, state, actions, self.chunk, self.params,
                                       reset=None if same_step else reset_mask)
        info = self._host_info(out.info)  # the rest is not computed
        if same_step:
            return out.state, out.obs, out.step_obs, out.reward, out.terminated, out.truncated, info
        mask = reset_mask  # NEXT_STEP: these envs ended at the step before; this step only resets them
        # (no last observation: NEXT_STEP returns none, so it is not computed)
        return (out.state, out.obs, None, jnp.where(mask, 0.0, out.reward), out.terminated & ~mask,
                out.truncated & ~mask, info)

    # ------------------------------------------------------------------ Gymnasium API
    def reset(self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every env (or, with ``options={"reset_mask": mask}``, those where ``mask``)."""
        n = self.num_envs
        if seed is None:
            seeds = np.random.SeedSequence().generate_state(n).tolist()
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = [int(s) for s in seed]
            if len(seeds) != n:
                raise ValueError(f"FootstepVectorEnv.reset: {len(seeds)} seeds for {n} envs")
        mask = np.ones(n, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
            if mask.shape != (n,):
                raise ValueError(f"FootstepVectorEnv.reset: reset_mask shape={mask.shape}, expected ({n},)")
            if self._state is None and not mask.all():
                raise gym.error.ResetNeeded("FootstepVectorEnv: the first reset must reset every env")
        state = None if mask.all() else self._state
        self._state, obs = self._reset_fn(self._put(_keys_of(seeds)), state, self._put(jnp.asarray(mask)))
        self._autoreset = np.where(mask, False, self._autoreset)
        return np.asarray(obs), {}

    def _check_actions(self, actions: Any) -> np.ndarray:
        a = np.asarray(actions)
        shape = (self.num_envs, 5)
        if a.shape != shape:
            raise ActionError(f"FootstepVectorEnv: actions shape={a.shape} but expected {shape} = "
                              f"(num_envs, [S, L, theta, T_SS, T_DS])")
        if a.dtype.kind not in "fiu":
            raise ActionError(f"FootstepVectorEnv: actions must be numbers, got dtype {a.dtype}")
        a = a if a.dtype in (np.float32, np.float64) else a.astype(np.float64)
        bad = ~np.isfinite(a)
        if bad.any():
            env_i, field = np.argwhere(bad)[0]
            names = ("S", "L", "theta", "T_SS", "T_DS")
            raise ActionError(f"FootstepVectorEnv: action of env {env_i} has a non-finite {names[field]}="
                              f"{a[env_i, field]} ({int(bad.any(axis=1).sum())} env(s) with non-finite actions)")
        return a

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if self._state is None:
            raise gym.error.ResetNeeded("FootstepVectorEnv: call reset() before step()")
        a = self._check_actions(actions)
        same = self.autoreset_mode == AutoresetMode.SAME_STEP
        mask = self._autoreset if self.autoreset_mode == AutoresetMode.NEXT_STEP else np.zeros(self.num_envs, bool)
        if self.autoreset_mode == AutoresetMode.DISABLED and self._autoreset.any():
            raise gym.error.ResetNeeded(f"FootstepVectorEnv: envs {np.flatnonzero(self._autoreset).tolist()} ended; "
                                        "reset them with reset(options={'reset_mask': mask}) (autoreset_mode=DISABLED)")
        out = self._step_fn(self._state, self._put(a), self._put(mask), same_step=same)
        self._state, obs, last_obs, reward, terminated, truncated, info = out
        # One transfer of everything the step returns to numpy (the shards of every array copied at once).
        obs, reward, terminated, truncated, info = jax.device_get((obs, reward, terminated, truncated, info))
        reward = reward.astype(np.float64)
        stepped = ~mask
        infos = self._infos(info, stepped)
        done = terminated | truncated
        if same and done.any():
            last = np.asarray(last_obs)
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(done):
                final_obs[i] = last[i]
            infos["final_obs"], infos["_final_obs"] = final_obs, done
            infos["final_info"], infos["_final_info"] = self._infos(info, done), done
        self._autoreset = done
        return obs, reward, terminated, truncated, infos

    @staticmethod
    def _host_info(info: dict[str, Any]) -> dict[str, Any]:
        """The part of the batched step's ``info`` that :meth:`_infos` reads (what is copied to numpy)."""
        keys = INFO_KEYS + (("sensed_obstacles",) if "sensed_obstacles" in info else ()) + ("cell", "rewards")
        return {k: info[k] for k in keys}

    def _infos(self, info: dict[str, Any], where: np.ndarray) -> dict[str, Any]:
        """Gymnasium's vector ``info`` from the batch's (numpy arrays): each key with its ``_key`` mask ``where``;
        the names (``termination``, ``tier_cell``) by indexing object arrays with the codes, no loop over envs."""
        out: dict[str, Any] = {}
        for key in INFO_KEYS + (("sensed_obstacles",) if "sensed_obstacles" in info else ()):
            value = np.asarray(info[key])
            if key == "termination":
                value = TERMINATION_NAMES[value]
            out[key], out[f"_{key}"] = value, where.copy()
        out["tier_cell"] = self._cell_names[np.asarray(info["cell"])]
        out["_tier_cell"] = where.copy()
        out["rewards"] = {k: np.asarray(info["rewards"][k], dtype=np.float64) for k in REWARD_TERMS}
        out["_rewards"] = where.copy()
        return out

    def close_extras(self, **kwargs: Any) -> None:
        self._state = None
