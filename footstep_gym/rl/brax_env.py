""":class:`FootstepJaxEnv` behind Brax's env interface, for Brax's PPO trainer (:mod:`footstep_gym.rl.ppo_jax`).

:class:`FootstepBraxEnv` is one env as Brax sees it (``brax.envs.base.Env``): ``reset(rng) -> State``,
``step(State, action) -> State``, the footstep state in ``State.pipeline_state``. Its action is the agent's,
in ``[-1, 1]`` per field, mapped into the command box exactly as the reference env under Gymnasium's
``RescaleAction(-1, 1)`` maps it (the SB3 agents' wrapper, :func:`action_to_command`): clipped to ``[-1, 1]``
in float32 (as SB3 clips a Box action), rescaled in float32, then read by the env as a float32 action.
``done`` is ``terminated or truncated``; ``info["truncation"]`` marks a truncation (a time or step limit),
which Brax's PPO does not treat as a terminal state; ``info["episode_metrics"]`` (return and length so far) and
``info["episode_done"]`` are what Brax's trainer logs, as its ``EpisodeWrapper`` keeps them.

:func:`wrap_for_training` is the ``wrap_env_fn`` Brax's trainer takes: a batch of envs stepped in chunks
(:func:`footstep_gym.jax.env.chunked_vmap`), each episode that ends replaced in the same step by a fresh one
drawn from the env's own key by the JAX env's one autoreset (:func:`footstep_gym.jax.autoreset.step_autoreset`;
not Brax's ``AutoResetWrapper``, which restarts every env from the one start it drew first).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from gymnasium import spaces
from gymnasium.wrappers.utils import rescale_box

from footstep_gym.jax.autoreset import step_autoreset
from footstep_gym.jax.env import FootstepJaxEnv
from footstep_gym.rl import brax_import  # noqa: F401  (Brax, imported before the next line)
from brax.envs.base import Env, State, Wrapper  # noqa: E402,I001

#: The agent's action bounds (Gymnasium's ``RescaleAction(min_action, max_action)``, the SB3 agents' too).
AGENT_BOUNDS = (-1.0, 1.0)


def rescaling(box: spaces.Box) -> tuple[np.ndarray, np.ndarray]:
    """``(gradient, intercept)`` (the box's dtype) of Gymnasium's ``rescale_box(box, -1, 1)``: its backward map,
    agent action -> command, is ``(a - intercept) / gradient``. Read from Gymnasium's own function so the
    arithmetic is the reference wrapper's, bit for bit."""
    lo, hi = (np.full(box.shape, b, dtype=box.dtype) for b in AGENT_BOUNDS)
    _, _, backward = rescale_box(box, lo, hi)
    cells = dict(zip(backward.__code__.co_freevars, (c.cell_contents for c in backward.__closure__ or ())))
    return np.asarray(cells["gradient"]), np.asarray(cells["intercept"])


def action_to_command(action: Any, gradient: Any, intercept: Any, xp: Any = jnp) -> Any:
    """The float32 command an agent's action stands for: clipped to ``[-1, 1]`` (SB3's clipping of a Box action),
    then Gymnasium's ``RescaleAction`` backward map, in float32 (``xp``: ``jax.numpy`` or ``numpy``)."""
    a = xp.clip(xp.asarray(action, dtype=xp.float32), np.float32(AGENT_BOUNDS[0]), np.float32(AGENT_BOUNDS[1]))
    g = xp.asarray(gradient, dtype=xp.float32)
    if xp is jnp:  # XLA turns a division by a broadcast divisor into a product with its rounded reciprocal
        g = jax.lax.optimization_barrier(jnp.broadcast_to(g, a.shape))
    return (a - xp.asarray(intercept, dtype=xp.float32)) / g


class FootstepBraxEnv(Env):
    """One footstep env (a :class:`FootstepJaxEnv`) as a Brax env; see the module doc.

    ``info``: ``truncation`` (1.0 on a truncation), ``is_success`` (1.0 on reaching the goal), ``termination``
    (0 none, 1 goal, 2 collision, 3 fall), ``episode_done`` and ``episode_metrics`` (``sum_reward``, ``length``: the
    episode's so far).
    """

    def __init__(self, env: FootstepJaxEnv) -> None:
        self.env = env
        #: The episodes' settings (:attr:`FootstepJaxEnv.default_params`).
        self.params = env.default_params
        self.gradient, self.intercept = rescaling(env.action_space)

    @property
    def observation_size(self) -> int:
        return int(self.env.obs_size)

    @property
    def action_size(self) -> int:
        return int(self.env.action_space.shape[0])

    @property
    def backend(self) -> str:
        return "jax"

    def reset(self, rng: jax.Array) -> State:
        """A new episode drawn from ``rng`` (:meth:`FootstepJaxEnv.reset`)."""
        state, obs = self.env.reset(rng, self.params)
        zero = jnp.zeros((), jnp.float32)
        info = {"truncation": zero, "is_success": zero, "termination": jnp.zeros((), jnp.int32),
                "episode_done": zero, "episode_metrics": {"sum_reward": zero, "length": zero}}
        return State(pipeline_state=state, obs=obs, reward=zero, done=zero, metrics={}, info=info)

    def command(self, action: jax.Array) -> jax.Array:
        """The float32 command of an agent's action (:func:`action_to_command`)."""
        return action_to_command(action, self.gradient, self.intercept)

    @staticmethod
    def stepped(state: State, pipeline_state: Any, obs: jax.Array, reward: jax.Array, terminated: jax.Array,
                 truncated: jax.Array, info: dict[str, Any]) -> State:
        """The Brax state after a footstep from ``state`` (the footstep env's step's outputs; one env, or a batch
        whose leaves lead with the env axis)."""
        reward, done = reward.astype(jnp.float32), (terminated | truncated).astype(jnp.float32)
        keep = 1.0 - state.info["episode_done"]  # a new episode's sums start afresh
        totals = state.info["episode_metrics"]
        out = {"truncation": truncated.astype(jnp.float32), "is_success": info["is_success"].astype(jnp.float32),
               "termination": info["termination"], "episode_done": done,
               "episode_metrics": {"sum_reward": totals["sum_reward"] * keep + reward,
                                   "length": totals["length"] * keep + 1.0}}
        return state.replace(pipeline_state=pipeline_state, obs=obs, reward=reward, done=done, info=out)

    def step(self, state: State, action: jax.Array) -> State:
        """One footstep of the agent's action (in ``[-1, 1]``); ``done`` on a termination or truncation."""
        # The step's randomness from the episode's stream, split as the autoreset splits it (its third: a fresh one's).
        key, k_step, _ = jax.random.split(state.pipeline_state.key, 3)
        return self.stepped(state, *self.env.step(k_step, state.pipeline_state._replace(key=key), self.command(action),
                                                  self.params))


class BatchedAutoReset(Wrapper):
    """A batch of :class:`FootstepBraxEnv` (leaves lead with the env axis), stepped ``chunk`` envs at a time, each
    episode that ends replaced in the same step by a fresh one drawn from the footstep state's own key (the JAX
    env's autoreset, :func:`footstep_gym.jax.autoreset.step_autoreset`): the reward, ``done`` and ``info`` of the
    step that ended it are kept, ``obs`` is the fresh episode's. What :func:`wrap_for_training` returns."""

    def __init__(self, env: FootstepBraxEnv, chunk: int = 64) -> None:
        super().__init__(env)
        if not (isinstance(chunk, int) and chunk >= 1):
            raise ValueError(f"BatchedAutoReset: chunk must be an integer >= 1, got {chunk!r}")
        self.chunk = chunk

    def reset(self, rng: jax.Array) -> State:
        """``rng``: one key per env ``(N, ...)``."""
        return jax.vmap(self.env.reset)(rng)

    def step(self, state: State, action: jax.Array) -> State:
        out = step_autoreset(self.env.env, state.pipeline_state, self.env.command(action), self.chunk, self.env.params)
        return self.env.stepped(state, out.state, out.obs, out.reward, out.terminated, out.truncated, out.info)


def wrap_for_training(env: FootstepBraxEnv, episode_length: int | None = None, action_repeat: int = 1,
                      randomization_fn: Any = None, chunk: int = 64) -> BatchedAutoReset:
    """Brax's ``wrap_env_fn``: :class:`BatchedAutoReset` (the env's own limits end its episodes, so Brax's
    ``episode_length`` is not used; ``action_repeat`` must be 1 and ``randomization_fn`` None: a footstep is
    one decision and the tier's cells are drawn by the env)."""
    del episode_length
    if action_repeat != 1:
        raise ValueError(f"FootstepBraxEnv: action_repeat must be 1 (one footstep per action), got {action_repeat}")
    if randomization_fn is not None:
        raise ValueError("FootstepBraxEnv: randomization_fn is not supported (the env draws its tier's cells)")
    return BatchedAutoReset(env, chunk)
