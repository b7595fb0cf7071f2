"""``ppo-jax-gru``: PPO with a recurrent (GRU or LSTM) policy, end to end in JAX on the batched footstep envs.

Brax's PPO trainer (:mod:`footstep_gym.rl.ppo_jax`) has no recurrent policy, so this module trains one itself, on
the same batched env (:func:`footstep_gym.rl.ppo_jax.make_env`, :func:`footstep_gym.rl.brax_env.wrap_for_training`)
and with the same update as Brax's: each PPO update collects ``batch_size * num_minibatches`` segments of
``unroll_length`` consecutive steps (``num_envs`` envs, each stepping ``batch_size * num_minibatches / num_envs``
segments in a row), updates the running observation normaliser (Welford, Brax's ``running_statistics``) with them,
then makes ``num_updates_per_batch`` passes over the segments in ``num_minibatches`` shuffled minibatches. The loss is
Brax's (:func:`ppo_loss`): Brax's ``compute_gae`` on values recomputed with the current parameters (value targets:
the lambda-returns; advantages: reward + gamma x next target - value; a truncated step masked out, a termination not
bootstrapped), advantages normalised per minibatch, the clipped surrogate, half the squared value error times
``0.5``, the entropy bonus.

The network (:class:`ActorCritic`): the normalised observation into one recurrent cell (``rnn_cell`` of width
``rnn_hidden_size``), whose output feeds a policy MLP (the Gaussian's mean; a state-independent log std) and a value
MLP. Its state is carried from step to step and set to zero where an episode starts (the step's ``start`` flag, the
previous step's ``done``), in the rollout and in the truncated backpropagation through time over each segment, which
starts from the state the rollout had at the segment's start.

The configs are ``ppo-jax``'s (:class:`RecurrentConfig`: ``configs/rl/ppo-jax.yml``'s keys plus ``rnn_cell`` and
``rnn_hidden_size``; ``configs/rl/ppo-jax-gru.yml``); the run folder, validation curve and shipping are
``ppo-jax``'s (:func:`footstep_gym.rl.ppo_jax.write_run`, :func:`~footstep_gym.rl.ppo_jax.ship`), the algorithm
named :data:`ALGO`. :class:`RecurrentPPOJax` plays a saved agent with SB3's recurrent interface,
``predict(obs, state, episode_start) -> (action, state)``, as :class:`footstep_gym.rl.agents.ZooAgent` calls it.
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from footstep_gym.config import config_dir
from footstep_gym.errors import ConfigError
from footstep_gym.rl import ppo_jax as ppo

#: The algorithm's name in a run's ``args.yml`` and the agents' manifests (:data:`footstep_gym.rl.agents.ALGORITHMS`).
ALGO = "ppo_jax_rnn"
#: Recurrent cells a config may name (``flax.linen``'s ``GRUCell`` and ``OptimizedLSTMCell``).
CELLS = ("gru", "lstm")


def default_config_path() -> Path:
    """``configs/rl/ppo-jax-gru.yml``."""
    return config_dir() / "rl" / "ppo-jax-gru.yml"


@dataclass(frozen=True)
class RecurrentConfig(ppo.PPOJaxConfig):
    """``ppo-jax``'s hyperparameters (:class:`~footstep_gym.rl.ppo_jax.PPOJaxConfig`) and the recurrent cell's:
    ``rnn_cell`` (one of :data:`CELLS`) and ``rnn_hidden_size`` (its width). ``policy_hidden_layer_sizes`` and
    ``value_hidden_layer_sizes`` are the MLP heads on the cell's output."""

    rnn_cell: str
    rnn_hidden_size: int


def parse_config(entry: Any, env_id: str, where: str = "ppo-jax-gru config") -> RecurrentConfig:
    """A :class:`RecurrentConfig` from one env's mapping; :class:`ConfigError` naming the first bad key."""
    if not isinstance(entry, dict):
        raise ConfigError(f"{where}: {env_id} must be a mapping of hyperparameters, got {type(entry).__name__}")
    rest = dict(entry)
    for name in ("rnn_cell", "rnn_hidden_size"):
        if name not in rest:
            raise ConfigError(f"{where}: {env_id}: missing key(s) {name}")
    cell, width = rest.pop("rnn_cell"), rest.pop("rnn_hidden_size")
    if cell not in CELLS:
        raise ConfigError(f"{where}: {env_id}.rnn_cell must be one of {', '.join(CELLS)}, got {cell!r}")
    if isinstance(width, bool) or not isinstance(width, int) or width < 1:
        raise ConfigError(f"{where}: {env_id}.rnn_hidden_size must be a whole number >= 1, got {width!r}")
    base = ppo.parse_config(rest, env_id, where)
    return RecurrentConfig(**asdict(base), rnn_cell=cell, rnn_hidden_size=width)


def load_config(env_id: str = "FootstepDoor-v0", path: str | Path | None = None) -> RecurrentConfig:
    """``env_id``'s entry of the hyperparameter file (default :func:`default_config_path`), validated."""
    return ppo.load_config(env_id, path if path is not None else default_config_path(), parse=parse_config)


# ---------------------------------------------------------------- the network
def network_of(cfg: RecurrentConfig, observation_size: int, action_size: int) -> dict[str, Any]:
    """The network's description stored with its parameters (what :class:`RecurrentPPOJax` rebuilds it from)."""
    return {**ppo.network_of(cfg, observation_size, action_size), "rnn_cell": cfg.rnn_cell,
            "rnn_hidden_size": cfg.rnn_hidden_size}


def carry_size(network: dict[str, Any]) -> int:
    """The width of the recurrent state as one array: the GRU's ``h``; the LSTM's ``c`` and ``h`` side by side."""
    return int(network["rnn_hidden_size"]) * (2 if network["rnn_cell"] == "lstm" else 1)


def _module(network: dict[str, Any]) -> Any:
    """The flax module of ``network`` (:func:`network_of`): ``apply(params, carry, obs, start)`` over a sequence."""
    import flax.linen as nn

    width, cell_name = int(network["rnn_hidden_size"]), network["rnn_cell"]
    act = getattr(nn, network["activation"])

    class Core(nn.Module):
        """One step of the cell: the state zeroed where ``start``, then the cell; ``(state, output)``."""

        @nn.compact
        def __call__(self, carry: jax.Array, inputs: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
            x, start = inputs
            carry = jnp.where(start[:, None], jnp.zeros_like(carry), carry)
            if cell_name == "gru":
                carry, y = nn.GRUCell(features=width)(carry, x)
                return carry, y
            (c, h), y = nn.OptimizedLSTMCell(features=width)((carry[:, :width], carry[:, width:]), x)
            return jnp.concatenate([c, h], axis=-1), y

    class ActorCritic(nn.Module):
        """``(carry (B, C), obs (T, B, O), start (T, B)) -> (carry, mean (T, B, A), log_std (A,), value (T, B))``;
        ``obs`` already normalised."""

        @nn.compact
        def __call__(self, carry: jax.Array, obs: jax.Array, start: jax.Array) -> tuple[Any, ...]:
            scan = nn.scan(Core, variable_broadcast="params", split_rngs={"params": False}, in_axes=0, out_axes=0)
            carry, y = scan()(carry, (obs, start))
            pi = y
            for w in network["policy_hidden_layer_sizes"]:
                pi = act(nn.Dense(w)(pi))
            mean = nn.Dense(int(network["action_size"]), kernel_init=nn.initializers.lecun_uniform())(pi)
            v = y
            for w in network["value_hidden_layer_sizes"]:
                v = act(nn.Dense(w)(v))
            value = nn.Dense(1)(v)[..., 0]
            log_std = self.param("log_std", nn.initializers.constant(math.log(float(network["init_noise_std"]))),
                                 (int(network["action_size"]),))
            return carry, mean, log_std, value

    return ActorCritic()


def _normalize(norm: Any, obs: jax.Array, network: dict[str, Any]) -> jax.Array:
    from brax.training.acme import running_statistics

    return running_statistics.normalize(obs, norm) if network["normalize_observations"] else obs


def _log_prob(mean: jax.Array, log_std: jax.Array, action: jax.Array) -> jax.Array:
    """The diagonal Gaussian's log density of ``action``, summed over the action's fields."""
    z = (action - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * z * z - log_std - 0.5 * math.log(2 * math.pi), axis=-1)


def _entropy(log_std: jax.Array) -> jax.Array:
    return jnp.sum(log_std + 0.5 * math.log(2 * math.pi * math.e))


class RecurrentPPOJax(ppo.BraxPPO):
    """A trained recurrent ``ppo-jax`` policy with SB3's recurrent model interface as
    :class:`~footstep_gym.rl.agents.ZooAgent` and :func:`~footstep_gym.rl.callbacks.play` use it: :meth:`load`
    (:class:`~footstep_gym.rl.ppo_jax.BraxPPO`'s), :meth:`predict` with the recurrent state, ``action_space``.

    ``params``: ``(normaliser, network)``; the deterministic action is the Gaussian's mean, clipped to ``[-1, 1]``.
    """

    algo = ALGO
    policy_description = "recurrent (GRU / LSTM) actor-critic, normal, log std"
    library = "footstep_gym.rl.ppo_jax_rnn (recurrent PPO in JAX, flax and optax) on footstep_gym.jax (FootstepJaxEnv)"

    def __init__(self, params: Any, network: dict[str, Any]) -> None:
        from gymnasium import spaces

        self.network = dict(network)
        self.action_space = spaces.Box(-1.0, 1.0, (int(network["action_size"]),), np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, (int(network["observation_size"]),), np.float32)
        self.params = params
        self.carry_size = carry_size(network)
        module = _module(network)

        def act(p: Any, carry: jax.Array, obs: jax.Array, start: jax.Array) -> tuple[jax.Array, jax.Array]:
            norm, net = p
            carry, mean, _, _ = module.apply(net, carry, _normalize(norm, obs, network)[None], start[None])
            return jnp.clip(mean[0], -1.0, 1.0).astype(jnp.float32), carry

        self._act = jax.jit(act)

    @classmethod
    def template(cls, network: dict[str, Any]) -> Any:
        """Parameters of the right structure (freshly initialised): what a saved file is restored into."""
        return init_params(network, jax.random.PRNGKey(0))

    def initial_state(self, n: int = 1) -> np.ndarray:
        """The recurrent state at an episode's start, ``(n, C)`` zeros."""
        return np.zeros((n, self.carry_size), np.float32)

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """``(action, state)``: the mean action ``(n, 5)`` float32 in ``[-1, 1]`` for observations ``(n, obs)`` and the
        recurrent state after it; ``state`` None is the initial state, and an env whose ``episode_start`` is true
        starts from it (SB3's convention; ``episode_start`` None: none starts)."""
        if not deterministic:
            raise ValueError("RecurrentPPOJax.predict: only the deterministic policy (the mean action) is played")
        x = np.asarray(observation, dtype=np.float32)
        single = x.ndim == 1
        x = x[None] if single else x
        carry = self.initial_state(len(x)) if state is None else np.asarray(state, np.float32)
        start = (np.zeros(len(x), bool) if episode_start is None
                 else np.broadcast_to(np.asarray(episode_start, bool).reshape(-1), (len(x),)))
        action, carry = self._act(self.params, jnp.asarray(carry), jnp.asarray(x), jnp.asarray(start))
        action = np.asarray(action)
        return (action[0] if single else action), np.asarray(carry)


def init_params(network: dict[str, Any], key: jax.Array) -> tuple[Any, Any]:
    """``(normaliser, network parameters)`` freshly initialised from ``key``."""
    from brax.training.acme import running_statistics, specs

    n_obs = int(network["observation_size"])
    norm = running_statistics.init_state(specs.Array((n_obs,), jnp.dtype("float32")))
    net = _module(network).init(key, jnp.zeros((1, carry_size(network))), jnp.zeros((1, 1, n_obs)),
                                jnp.ones((1, 1), bool))
    return norm, net


# ---------------------------------------------------------------- the loss
class Segments(NamedTuple):
    """Rollout segments, time first: ``obs`` ``(T+1, B, O)`` (the last: the observation after the segment), ``start``
    ``(T+1, B)`` (an episode starts at that observation), ``action`` ``(T, B, A)`` (as sampled, unclipped),
    ``log_prob``, ``reward``, ``termination``, ``truncation`` ``(T, B)``; ``carry`` ``(B, C)``: the recurrent state
    before the segment's first step."""

    obs: jax.Array
    start: jax.Array
    action: jax.Array
    log_prob: jax.Array
    reward: jax.Array
    termination: jax.Array
    truncation: jax.Array
    carry: jax.Array


def ppo_loss(net: Any, norm: Any, data: Segments, apply: Callable[..., Any], network: dict[str, Any],
             cfg: RecurrentConfig) -> tuple[jax.Array, dict[str, jax.Array]]:
    """Brax's PPO loss (module doc) on ``data``, the network run over each segment from its stored state."""
    from brax.training.agents.ppo.losses import compute_gae

    _, mean, log_std, values = apply(net, data.carry, _normalize(norm, data.obs, network), data.start)
    baseline, bootstrap = values[:-1], values[-1]
    vs, advantages = compute_gae(truncation=data.truncation, termination=data.termination,
                                 rewards=data.reward * cfg.reward_scaling, values=baseline, bootstrap_value=bootstrap,
                                 lambda_=cfg.gae_lambda, discount=cfg.discounting)
    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
    ratio = jnp.exp(_log_prob(mean[:-1], log_std, data.action) - data.log_prob)
    clipped = jnp.clip(ratio, 1 - cfg.clipping_epsilon, 1 + cfg.clipping_epsilon)
    policy_loss = -jnp.mean(jnp.minimum(ratio * advantages, clipped * advantages))
    v_loss = jnp.mean((vs - baseline) ** 2) * 0.5 * cfg.vf_loss_coefficient  # Brax's form (0.5 by default)
    entropy_loss = -cfg.entropy_cost * _entropy(log_std)
    return policy_loss + v_loss + entropy_loss, {"policy_loss": policy_loss, "v_loss": v_loss,
                                                 "entropy_loss": entropy_loss}


# ---------------------------------------------------------------- training
class _State(NamedTuple):
    net: Any
    opt: Any
    norm: Any
    env: Any
    carry: jax.Array
    start: jax.Array
    key: jax.Array


def _trainer(cfg: RecurrentConfig, env: Any, network: dict[str, Any]) -> tuple[Callable, Callable]:
    """``(init(key) -> state, run(state, n) -> state)``: the training state and ``n`` PPO updates, jitted."""
    import optax
    from brax.training.acme import running_statistics

    from footstep_gym.rl.brax_env import wrap_for_training

    apply = _module(network).apply
    benv = wrap_for_training(env, chunk=cfg.chunk)
    optimizer = optax.chain(optax.clip_by_global_norm(cfg.max_grad_norm), optax.adam(cfg.learning_rate))
    n, t, c = cfg.num_envs, cfg.unroll_length, carry_size(network)
    segments_per_env = cfg.batch_size * cfg.num_minibatches // cfg.num_envs

    def init(key: jax.Array) -> _State:
        k_net, k_env, key = jax.random.split(key, 3)
        norm, net = init_params(network, k_net)
        env_state = benv.reset(jax.random.split(k_env, n))
        return _State(net, optimizer.init(net), norm, env_state, jnp.zeros((n, c)), jnp.ones((n,), bool), key)

    def env_step(s: _State, _: Any) -> tuple[_State, tuple]:
        key, k = jax.random.split(s.key)
        obs = s.env.obs
        carry, mean, log_std, _ = apply(s.net, s.carry, _normalize(s.norm, obs, network)[None], s.start[None])
        action = mean[0] + jnp.exp(log_std) * jax.random.normal(k, mean[0].shape)
        env_state = benv.step(s.env, action)
        trunc = env_state.info["truncation"]
        out = (obs, s.start, action, _log_prob(mean[0], log_std, action), env_state.reward,
               env_state.done * (1 - trunc), trunc)
        return s._replace(env=env_state, carry=carry, start=env_state.done > 0, key=key), out

    def segment(s: _State, _: Any) -> tuple[_State, Segments]:
        carry0 = s.carry
        s, (obs, start, action, logp, reward, term, trunc) = jax.lax.scan(env_step, s, None, length=t)
        obs = jnp.concatenate([obs, s.env.obs[None]])
        start = jnp.concatenate([start, s.start[None]])
        return s, Segments(obs, start, action, logp, reward, term, trunc, carry0)

    grad = jax.grad(lambda net, norm, data: ppo_loss(net, norm, data, apply, network, cfg)[0])

    def sgd(carry: tuple, data: Segments) -> tuple[tuple, None]:
        net, opt, norm = carry
        updates, opt = optimizer.update(grad(net, norm, data), opt, net)
        return (optax.apply_updates(net, updates), opt, norm), None

    def update(s: _State, _: Any) -> tuple[_State, None]:
        s, data = jax.lax.scan(segment, s, None, length=segments_per_env)  # leaves (K, T[+1], N, ...)
        # Segments on one axis (K * N), time first: (T[+1], K * N, ...); the carries (K * N, C).
        data = Segments(*(jnp.swapaxes(x, 0, 1).reshape(x.shape[1], -1, *x.shape[3:]) for x in data[:-1]),
                        data.carry.reshape(-1, c))
        norm = running_statistics.update(s.norm, data.obs[:-1].reshape(-1, data.obs.shape[-1])) \
            if network["normalize_observations"] else s.norm
        key, k_epochs = jax.random.split(s.key)

        def epoch(carry: tuple, k: jax.Array) -> tuple[tuple, None]:
            order = jax.random.permutation(k, data.carry.shape[0])

            def batches(x: jax.Array, axis: int) -> jax.Array:
                x = jnp.take(x, order, axis=axis)
                x = x.reshape(*x.shape[:axis], cfg.num_minibatches, cfg.batch_size, *x.shape[axis + 1:])
                return jnp.moveaxis(x, axis, 0)

            mb = Segments(*(batches(x, 1) for x in data[:-1]), batches(data.carry, 0))
            return jax.lax.scan(sgd, carry, mb)[0], None

        (net, opt, _), _ = jax.lax.scan(epoch, (s.net, s.opt, norm),
                                        jax.random.split(k_epochs, cfg.num_updates_per_batch))
        return s._replace(net=net, opt=opt, norm=norm, key=key), None

    def run(s: _State, updates: int) -> _State:
        return jax.lax.scan(update, s, None, length=updates)[0]

    return jax.jit(init), jax.jit(run, static_argnums=1)


def train(cfg: RecurrentConfig, seed: int, *, validation_seeds: list[int] | None = None,
          progress: Callable[[int, float, float], None] | None = None) -> ppo.TrainResult:
    """Train one seed on ``planned(cfg)`` (:func:`footstep_gym.rl.ppo_jax.planned`: whole PPO updates in
    ``num_evals - 1`` equal chunks). At each of ``num_evals`` validation points (the first at 0 steps) the
    deterministic policy plays ``validation_seeds`` (default: the validation split's first
    ``cfg.validation_episodes``) in the reference env; ``progress(steps, wall_s, success)`` is called at each.
    Timing as :func:`footstep_gym.rl.ppo_jax.train`'s (jit included, validation left out)."""
    from footstep_gym.evaluation.splits import split_seeds

    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"ppo-jax-gru: a training seed is a whole number >= 0, got {seed!r}")
    if not isinstance(cfg, RecurrentConfig):
        raise TypeError(f"ppo-jax-gru: a RecurrentConfig expected, got {type(cfg).__name__}")
    cfg = ppo.planned(cfg)
    seeds = validation_seeds if validation_seeds is not None else split_seeds("validation", cfg.validation_episodes)
    env = ppo.make_env(cfg)
    network = network_of(cfg, env.observation_size, env.action_size)
    ref_env = ppo.validation_env(cfg)
    updates = cfg.num_timesteps // cfg.steps_per_update
    chunks = max(cfg.num_evals - 1, 1)
    per_chunk = updates // chunks
    load_start = os.getloadavg()[0]
    clock = ppo.ValidationClock(progress)
    init, run = _trainer(cfg, env, network)
    state = init(jax.random.PRNGKey(seed))
    model = RecurrentPPOJax((state.norm, state.net), network)

    def validate(step: int) -> None:
        def rate() -> float:
            model.params = jax.device_get((state.norm, state.net))
            return ppo.validation_success(model, ref_env, seeds)

        clock.measure(step, rate)

    jax.block_until_ready(state)
    validate(0)
    for i in range(chunks):
        state = jax.block_until_ready(run(state, per_chunk))
        validate((i + 1) * per_chunk * cfg.steps_per_update)
    wall, cpu = clock.training_time()
    ref_env.close()
    return ppo.TrainResult(model, clock.curve, wall, clock.curve[-1][0], clock.validating, seed, cfg,
                           (load_start, os.getloadavg()[0]), cpu)

