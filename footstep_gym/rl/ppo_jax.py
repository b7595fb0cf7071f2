"""``ppo-jax``: PPO end to end in JAX on the batched door, by Brax's PPO trainer (``brax.training.agents.ppo``).

:func:`train` trains one seed on :class:`~footstep_gym.jax.env.FootstepJaxEnv` behind Brax's env interface
(:mod:`footstep_gym.rl.brax_env`) with the hyperparameters of ``configs/rl/ppo-jax.yml`` (:func:`load_config`),
and between training chunks measures the deterministic policy's success on the validation split's seeds in the
**reference** env (``gym.make(env_id, **env_kwargs)``, pymunk): the learning curve, success against training
wall time (jit included, the validation episodes left out, as :class:`footstep_gym.rl.callbacks.ValidationCallback`
counts them).

:func:`write_run` writes a trained agent in rl_zoo3's run layout, so that it ships with
:func:`footstep_gym.rl.training.ship` and plays through :class:`footstep_gym.rl.agents.ZooAgent` like the SB3
agents: ``<EnvId>.zip`` (the network's parameters, observation normaliser included, and its shape), ``<EnvId>/``
with ``config.yml`` (``RescaleAction(-1, 1)`` and the env options: the action is mapped to the command as it was
in training), ``args.yml`` (``algo: ppo_jax``) and ``command.txt``, and ``validation.csv``. :class:`BraxPPO` loads
the ``.zip`` with the part of SB3's model interface the loader uses (``load``, ``predict``, ``action_space``).
"""

from __future__ import annotations

import io
import json
import math
import os
import time
import types
import zipfile
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import yaml
from gymnasium import spaces

from footstep_gym.config import config_dir
from footstep_gym.errors import ConfigError
from footstep_gym.rl import brax_import  # noqa: F401  (Brax, quietly: every brax import below comes after it)

#: The algorithm's name in a run's ``args.yml`` and the agents' manifests (:data:`footstep_gym.rl.agents.ALGORITHMS`).
ALGO = "ppo_jax"
#: Activations a config may name (``flax.linen``'s functions).
ACTIVATIONS = ("tanh", "relu", "swish", "elu")
#: The parameters file inside a run's ``<EnvId>.zip``, and its network description.
PARAMS_FILE, NETWORK_FILE = "params.msgpack", "network.json"


def default_config_path() -> Path:
    """``configs/rl/ppo-jax.yml``."""
    return config_dir() / "rl" / "ppo-jax.yml"


@dataclass(frozen=True)
class PPOJaxConfig:
    """One env's ``ppo-jax`` hyperparameters (``configs/rl/ppo-jax.yml`` documents each key)."""

    env_id: str
    env_kwargs: dict
    num_timesteps: int
    num_envs: int
    unroll_length: int
    batch_size: int
    num_minibatches: int
    num_updates_per_batch: int
    learning_rate: float
    entropy_cost: float
    discounting: float
    gae_lambda: float
    clipping_epsilon: float
    reward_scaling: float
    max_grad_norm: float
    normalize_observations: bool
    policy_hidden_layer_sizes: tuple
    value_hidden_layer_sizes: tuple
    activation: str
    init_noise_std: float
    num_evals: int
    validation_episodes: int
    chunk: int
    vf_loss_coefficient: float  # a config may leave it out: :data:`_OPTIONAL`

    @property
    def steps_per_update(self) -> int:
        """Env steps collected per PPO update (Brax's ``batch_size * unroll_length * num_minibatches``)."""
        return self.batch_size * self.unroll_length * self.num_minibatches


_INTS = ("num_timesteps", "num_envs", "unroll_length", "batch_size", "num_minibatches", "num_updates_per_batch",
         "num_evals", "validation_episodes", "chunk")
_FLOATS = ("learning_rate", "entropy_cost", "discounting", "gae_lambda", "clipping_epsilon", "reward_scaling",
           "max_grad_norm", "init_noise_std", "vf_loss_coefficient")
#: Keys a config may leave out, with their defaults (Brax's own): the value loss's weight, Brax multiplying the mean
#: squared error by ``0.5 * vf_loss_coefficient`` (SB3's ``vf_coef`` multiplies it by itself: 0.5 there is 1.0 here).
_OPTIONAL = {"vf_loss_coefficient": 0.5}
#: Keys that may be 0 (no entropy bonus, as SB3's ``ent_coef: 0.0``).
_MAY_BE_ZERO = ("entropy_cost",)


def parse_config(entry: Any, env_id: str, where: str = "ppo-jax config") -> PPOJaxConfig:
    """A :class:`PPOJaxConfig` from one env's mapping; :class:`ConfigError` naming the first bad key."""
    if not isinstance(entry, dict):
        raise ConfigError(f"{where}: {env_id} must be a mapping of hyperparameters, got {type(entry).__name__}")
    names = [f.name for f in fields(PPOJaxConfig) if f.name != "env_id"]
    unknown = sorted(set(entry) - set(names))
    if unknown:
        raise ConfigError(f"{where}: {env_id}: unknown key(s) {', '.join(unknown)}; known: {', '.join(names)}")
    entry = {**_OPTIONAL, **entry}
    missing = [n for n in names if n not in entry]
    if missing:
        raise ConfigError(f"{where}: {env_id}: missing key(s) {', '.join(missing)}")
    values: dict[str, Any] = {"env_id": env_id}
    for name in _INTS:
        v = entry[name]
        if isinstance(v, float) and v.is_integer() and name == "num_timesteps":
            v = int(v)  # 1e6 in YAML
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise ConfigError(f"{where}: {env_id}.{name} must be a whole number >= 1, got {v!r}")
        values[name] = v
    for name in _FLOATS:
        v = entry[name]
        low = name in _MAY_BE_ZERO
        bad = isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v)
        if bad or v < 0 or (v == 0 and not low):
            raise ConfigError(f"{where}: {env_id}.{name} must be a number {'>=' if low else '>'} 0, got {v!r}")
        values[name] = float(v)
    for name in ("discounting", "gae_lambda"):
        if values[name] > 1:
            raise ConfigError(f"{where}: {env_id}.{name} must be in (0, 1], got {values[name]!r}")
    if not isinstance(entry["normalize_observations"], bool):
        raise ConfigError(f"{where}: {env_id}.normalize_observations must be true or false, "
                          f"got {entry['normalize_observations']!r}")
    values["normalize_observations"] = entry["normalize_observations"]
    for name in ("policy_hidden_layer_sizes", "value_hidden_layer_sizes"):
        v = entry[name]
        if not (isinstance(v, list) and v and all(isinstance(x, int) and not isinstance(x, bool) and x >= 1
                                                  for x in v)):
            raise ConfigError(f"{where}: {env_id}.{name} must be a non-empty list of layer widths >= 1, got {v!r}")
        values[name] = tuple(v)
    if entry["activation"] not in ACTIVATIONS:
        raise ConfigError(f"{where}: {env_id}.activation must be one of {', '.join(ACTIVATIONS)}, "
                          f"got {entry['activation']!r}")
    values["activation"] = entry["activation"]
    kwargs = entry["env_kwargs"]
    if not isinstance(kwargs, dict):
        raise ConfigError(f"{where}: {env_id}.env_kwargs must be a mapping of env options, got {kwargs!r}")
    values["env_kwargs"] = dict(kwargs)
    cfg = PPOJaxConfig(**values)
    if (cfg.batch_size * cfg.num_minibatches) % cfg.num_envs:
        raise ConfigError(f"{where}: {env_id}: batch_size * num_minibatches ({cfg.batch_size * cfg.num_minibatches}) "
                          f"must be a multiple of num_envs ({cfg.num_envs}) (Brax's PPO)")
    if cfg.num_timesteps < cfg.steps_per_update:
        raise ConfigError(f"{where}: {env_id}.num_timesteps ({cfg.num_timesteps}) is less than one PPO update's "
                          f"env steps (batch_size * unroll_length * num_minibatches = {cfg.steps_per_update})")
    return cfg


def with_tier(cfg: PPOJaxConfig, tier_name: str) -> PPOJaxConfig:
    """``cfg`` trained on the benchmark tier ``tier_name`` (its env options' ``tier`` replaced; every cell the tier
    has for the scene, one drawn per episode as ``gym.make(..., tier=...)`` does).

    Raises:
        ConfigError: ``tier_name`` is not a tier of configs/benchmark.yaml.
    """
    from footstep_gym import tiers

    if tier_name not in tiers.tier_names():
        raise ConfigError(f"ppo-jax: unknown tier {tier_name!r}; one of {', '.join(tiers.tier_names())}")
    return replace(cfg, env_kwargs={**cfg.env_kwargs, "tier": tier_name})


def planned(cfg: PPOJaxConfig, timesteps: int | None = None) -> PPOJaxConfig:
    """``cfg`` (its ``num_timesteps`` replaced by ``timesteps`` if given) as Brax's trainer runs it.

    Brax trains whole PPO updates (:attr:`PPOJaxConfig.steps_per_update` env steps) in ``num_evals - 1`` equal
    chunks between validations, so it trains ``num_timesteps`` rounded up to a multiple of ``chunks x update``.
    Here ``num_evals`` is lowered to one validation per update when there are fewer updates than chunks (a short
    run is not rounded up to one update per chunk), and ``num_timesteps`` is the count Brax then trains: the
    number printed, recorded (``config.yml``, ``args.yml``) and trained is one. Applied twice, it changes nothing.
    """
    if timesteps is not None:
        if isinstance(timesteps, bool) or not isinstance(timesteps, int) or timesteps < 1:
            raise ConfigError(f"ppo-jax: timesteps must be a whole number >= 1, got {timesteps!r}")
        cfg = replace(cfg, num_timesteps=timesteps)
    updates = math.ceil(cfg.num_timesteps / cfg.steps_per_update)
    num_evals = min(cfg.num_evals, updates + 1)
    chunks = max(num_evals - 1, 1)
    return replace(cfg, num_evals=num_evals, num_timesteps=chunks * math.ceil(updates / chunks) * cfg.steps_per_update)


def plan_line(asked: int, cfg: PPOJaxConfig) -> str:
    """One line saying what a run of ``cfg`` (:func:`planned`) trains, ``asked`` env steps having been asked."""
    rounded = "" if asked == cfg.num_timesteps else f" ({asked:,} asked, rounded up)"
    return (f"{cfg.env_id}: {cfg.num_timesteps:,} env steps{rounded}: {cfg.num_timesteps // cfg.steps_per_update:,} "
            f"PPO updates of {cfg.steps_per_update:,} env steps, {cfg.num_evals} validation points, "
            f"{cfg.num_envs} envs")


def load_config(env_id: str = "FootstepDoor-v0", path: str | Path | None = None,
                parse: Callable[[Any, str, str], PPOJaxConfig] = parse_config) -> PPOJaxConfig:
    """``env_id``'s entry of the ``ppo-jax`` hyperparameter file (default :func:`default_config_path`), validated by
    ``parse`` (:func:`parse_config`; the recurrent one's for :mod:`footstep_gym.rl.ppo_jax_rnn`)."""
    path = Path(path) if path is not None else default_config_path()
    if not path.is_file():
        raise ConfigError(f"ppo-jax config {str(path)!r} not found")
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: a mapping of env id -> hyperparameters expected")
    if env_id not in data:
        raise ConfigError(f"{path}: no entry for {env_id!r}; entries: {', '.join(map(str, data)) or 'none'}")
    return parse(data[env_id], env_id, str(path))


# ---------------------------------------------------------------- the networks and the policy
def _network_factory(network: dict[str, Any]) -> Callable[..., Any]:
    import functools

    import flax.linen as linen
    from brax.training.agents.ppo import networks as ppo_networks

    return functools.partial(
        ppo_networks.make_ppo_networks,
        policy_hidden_layer_sizes=tuple(network["policy_hidden_layer_sizes"]),
        value_hidden_layer_sizes=tuple(network["value_hidden_layer_sizes"]),
        activation=getattr(linen, network["activation"]), distribution_type="normal", noise_std_type="log",
        init_noise_std=float(network["init_noise_std"]))


def network_of(cfg: PPOJaxConfig, observation_size: int, action_size: int) -> dict[str, Any]:
    """The network's description stored with its parameters (what :class:`BraxPPO` rebuilds it from)."""
    return {"observation_size": observation_size, "action_size": action_size,
            "normalize_observations": cfg.normalize_observations,
            "policy_hidden_layer_sizes": list(cfg.policy_hidden_layer_sizes),
            "value_hidden_layer_sizes": list(cfg.value_hidden_layer_sizes), "activation": cfg.activation,
            "init_noise_std": cfg.init_noise_std, "distribution": "normal"}


class BraxPPO:
    """A trained ``ppo-jax`` policy with the part of SB3's model interface :class:`~footstep_gym.rl.agents.ZooAgent`
    and :func:`~footstep_gym.rl.callbacks.play` use: :meth:`load`, :meth:`predict`, ``action_space`` ``[-1, 1]^5``.

    ``params``: Brax's ``(normaliser, policy, value)``; the policy normalises the observation itself (the
    running mean and std it trained with), so a run needs no ``VecNormalize``. The deterministic action is the
    Gaussian's mean, clipped to ``[-1, 1]`` as SB3 clips a Box action.
    """

    #: The run's algorithm (``args.yml``), its policy (``config.yml``) and the manifest's ``library``.
    algo = ALGO
    policy_description = "brax MLP (normal, log std)"
    library = "brax.training.agents.ppo (Brax's PPO trainer) on footstep_gym.jax (FootstepJaxEnv)"

    def __init__(self, params: Any, network: dict[str, Any]) -> None:
        from brax.training.acme import running_statistics
        from brax.training.agents.ppo import networks as ppo_networks

        self.network = dict(network)
        n_act = int(network["action_size"])
        self.action_space = spaces.Box(-1.0, 1.0, (n_act,), np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, (int(network["observation_size"]),), np.float32)
        normalize = running_statistics.normalize if network["normalize_observations"] else (lambda x, y: x)
        nets = _network_factory(network)(int(network["observation_size"]), n_act,
                                         preprocess_observations_fn=normalize)
        self.params = params
        make = ppo_networks.make_inference_fn(nets)

        def act(p: Any, obs: jax.Array) -> jax.Array:
            action, _ = make(p, deterministic=True)(obs, jax.random.PRNGKey(0))
            return jnp.clip(action, -1.0, 1.0).astype(jnp.float32)

        self._act = jax.jit(act)
        self._nets = nets

    @classmethod
    def template(cls, network: dict[str, Any]) -> Any:
        """Parameters of the right structure (freshly initialised): what a saved file is restored into."""
        from brax.training.acme import running_statistics, specs

        nets = _network_factory(network)(int(network["observation_size"]), int(network["action_size"]))
        key = jax.random.PRNGKey(0)
        norm = running_statistics.init_state(specs.Array((int(network["observation_size"]),), jnp.dtype("float32")))
        return (norm, nets.policy_network.init(key), nets.value_network.init(key))

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, None]:
        """``(action, None)``: the mean action ``(n, 5)`` float32 in ``[-1, 1]`` for observations ``(n, obs)``."""
        if not deterministic:
            raise ValueError("BraxPPO.predict: only the deterministic policy (the mean action) is played")
        x = np.asarray(observation, dtype=np.float32)
        single = x.ndim == 1
        out = np.asarray(self._act(self.params, x[None] if single else x))
        return (out[0] if single else out), None

    def save(self, path: str | Path) -> Path:
        """Write the ``.zip``: :data:`PARAMS_FILE` (flax msgpack of the parameters) and :data:`NETWORK_FILE`."""
        from flax import serialization

        path = Path(path)
        blob = serialization.msgpack_serialize(serialization.to_state_dict(jax.device_get(self.params)))
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr(PARAMS_FILE, blob)
            zf.writestr(NETWORK_FILE, json.dumps(self.network, indent=2))
        return path

    @classmethod
    def load(cls, path: str | Path, device: str = "cpu", **_: Any) -> "BraxPPO":
        """A policy saved by :meth:`save`; the policy is compiled here (not in the first act's time)."""
        from flax import serialization

        path = Path(path)
        try:
            with zipfile.ZipFile(path) as zf:
                network = json.loads(zf.read(NETWORK_FILE))
                blob = zf.read(PARAMS_FILE)
        except (KeyError, zipfile.BadZipFile) as exc:
            raise ValueError(f"{path}: not a ppo-jax agent ({exc})") from None
        params = serialization.from_state_dict(cls.template(network), serialization.msgpack_restore(blob))
        model = cls(params, network)
        model.predict(np.zeros((1, int(network["observation_size"])), np.float32))
        return model


# ---------------------------------------------------------------- validation in the reference env
def validation_env(cfg: PPOJaxConfig) -> gym.Env:
    """The reference env of ``cfg`` (pymunk), its action box mapped to ``[-1, 1]`` by ``RescaleAction``."""
    import footstep_gym  # noqa: F401  (registers the ids)

    env = gym.make(cfg.env_id, **cfg.env_kwargs)
    return gym.wrappers.RescaleAction(env, np.full(5, -1.0, np.float32), np.full(5, 1.0, np.float32))


def validation_success(model: BraxPPO, env: gym.Env, seeds: list[int]) -> float:
    """The fraction of the episodes ``reset(seed=s)`` the deterministic policy ends at the goal."""
    from footstep_gym.rl.callbacks import play

    episodes = play(model, env, seeds)
    return sum(win for win, _ in episodes) / len(episodes)


# ---------------------------------------------------------------- training
def _device_put_replicated(x: Any, devices: list[Any]) -> Any:
    """What ``jax.device_put_replicated`` did: stacked copies of ``x``'s leaves, one per device, laid out as
    ``pmap``'s own outputs (so Brax's pmapped update takes them without a second compilation)."""
    copy = jax.pmap(lambda y: y, devices=devices)
    return jax.tree.map(lambda y: copy(jnp.stack([y] * len(devices))), x)


class _JaxWithReplicated:
    """JAX's namespace (every attribute read from the ``jax`` module) plus :func:`_device_put_replicated`."""

    device_put_replicated = staticmethod(_device_put_replicated)

    def __getattr__(self, name: str) -> Any:
        return getattr(jax, name)


def brax_ppo_train() -> Callable[..., Any]:
    """Brax's PPO trainer, ``brax.training.agents.ppo.train.train``, runnable on this JAX.

    Brax 0.14.2's trainer calls ``jax.device_put_replicated`` to lay its training state out over the devices
    (on any number of them, one included), and JAX 0.10 removed that function (Brax's open issue 671). Returned
    here: the same function (its code, defaults and closure) whose global name ``jax`` is a namespace that is
    JAX's plus :func:`_device_put_replicated`. Neither JAX nor Brax's module is changed; on a JAX that still has
    the function, Brax's own trainer is returned.
    """
    from brax.training.agents.ppo import train as brax_ppo

    fn = brax_ppo.train
    if hasattr(jax, "device_put_replicated"):
        return fn
    copy = types.FunctionType(fn.__code__, dict(fn.__globals__, jax=_JaxWithReplicated()), fn.__name__,
                              fn.__defaults__, fn.__closure__)
    copy.__kwdefaults__, copy.__doc__ = fn.__kwdefaults__, fn.__doc__
    return copy


@dataclass
class TrainResult:
    """A finished training run: the policy, its curve (env steps, training wall time [s] with jit and without the
    validation episodes, validation success, the process's CPU time [s] likewise), the total training wall time
    [s], the env steps, the time spent validating [s], the machine's 1-minute load average at the start and the
    end (a shared machine's), and the total CPU time [s] (all threads; validation left out)."""

    model: BraxPPO
    curve: list[tuple[int, float, float, float]]
    wall_time_s: float
    timesteps: int
    validation_time_s: float
    seed: int
    config: PPOJaxConfig
    load_average: tuple[float, float] = (float("nan"), float("nan"))
    cpu_time_s: float = float("nan")

    def time_to(self, success: float) -> float | None:
        """Training wall time [s] at the first validation with success >= ``success`` (None if never)."""
        return next((w for _, w, s, _ in self.curve if s >= success), None)

    def cpu_time_to(self, success: float) -> float | None:
        """The process's CPU time [s] (all threads) at the first validation with success >= ``success``."""
        return next((c for _, _, s, c in self.curve if s >= success), None)


class ValidationClock:
    """A training run's clock that leaves its validations out, started when built.

    :meth:`measure` runs one validation (``rate()``, the success rate) and appends ``(env steps, training wall
    time [s], success, training CPU time [s])`` to :attr:`curve`, the times counting what was spent before it
    less the earlier validations; the validation's own wall and CPU time add to :attr:`validating` and
    :attr:`validating_cpu`. ``progress(steps, wall_s, success)`` is called after each.
    """

    def __init__(self, progress: Callable[[int, float, float], None] | None = None) -> None:
        self.curve: list[tuple[int, float, float, float]] = []
        self.validating = 0.0
        self.validating_cpu = 0.0
        self.progress = progress
        self.start, self.cpu_start = time.perf_counter(), time.process_time()

    def measure(self, step: int, rate: Callable[[], float]) -> None:
        t0, c0 = time.perf_counter(), time.process_time()
        wall, cpu = t0 - self.start - self.validating, c0 - self.cpu_start - self.validating_cpu
        success = rate()
        self.curve.append((int(step), wall, success, cpu))
        self.validating += time.perf_counter() - t0
        self.validating_cpu += time.process_time() - c0
        if self.progress is not None:
            self.progress(int(step), wall, success)

    def training_time(self) -> tuple[float, float]:
        """``(wall, CPU)`` seconds since the start, the validations left out."""
        return (time.perf_counter() - self.start - self.validating,
                time.process_time() - self.cpu_start - self.validating_cpu)


def make_env(cfg: PPOJaxConfig) -> Any:
    """:class:`~footstep_gym.rl.brax_env.FootstepBraxEnv` of ``cfg``'s env (float32)."""
    import footstep_gym
    from footstep_gym.jax.env import FootstepJaxEnv
    from footstep_gym.rl.brax_env import FootstepBraxEnv

    scenes = {v: k for k, v in footstep_gym.ENV_IDS.items()}
    if cfg.env_id not in scenes:
        raise ConfigError(f"ppo-jax: unknown env id {cfg.env_id!r}; one of {', '.join(sorted(scenes))}")
    return FootstepBraxEnv(FootstepJaxEnv(scenes[cfg.env_id], **cfg.env_kwargs))


def train(cfg: PPOJaxConfig, seed: int, *, validation_seeds: list[int] | None = None,
          progress: Callable[[int, float, float], None] | None = None) -> TrainResult:
    """Train one seed with Brax's PPO (``brax.training.agents.ppo.train.train``) on ``planned(cfg)`` (:func:`planned`:
    the steps Brax trains; the result's ``config``).

    ``cfg.num_evals`` validation points (the first at 0 steps) split the training; at each, the deterministic
    policy plays ``validation_seeds`` (default: the validation split's first ``cfg.validation_episodes``) in the
    reference env. ``progress(steps, wall_s, success)`` is called at each. Brax's own evaluation (in the JAX env)
    is not run.
    """
    import functools

    from footstep_gym.evaluation.splits import split_seeds
    from footstep_gym.rl.brax_env import wrap_for_training

    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"ppo-jax: a training seed is a whole number >= 0, got {seed!r}")
    cfg = planned(cfg)
    seeds = validation_seeds if validation_seeds is not None else split_seeds("validation", cfg.validation_episodes)
    env = make_env(cfg)
    network = network_of(cfg, env.observation_size, env.action_size)
    ref_env = validation_env(cfg)
    load_start = os.getloadavg()[0]
    clock = ValidationClock(progress)

    policy: list[BraxPPO] = []  # one compiled policy, its parameters replaced at each validation

    def on_params(step: int, make_policy: Any, params: Any) -> None:
        def rate() -> float:
            if not policy:
                policy.append(BraxPPO(params, network))
            policy[0].params = params
            return validation_success(policy[0], ref_env, seeds)

        clock.measure(step, rate)

    _, params, _ = brax_ppo_train()(
        environment=env, num_timesteps=cfg.num_timesteps,
        wrap_env_fn=functools.partial(wrap_for_training, chunk=cfg.chunk), num_envs=cfg.num_envs,
        episode_length=1, learning_rate=cfg.learning_rate, entropy_cost=cfg.entropy_cost,
        discounting=cfg.discounting, unroll_length=cfg.unroll_length, batch_size=cfg.batch_size,
        num_minibatches=cfg.num_minibatches, num_updates_per_batch=cfg.num_updates_per_batch,
        normalize_observations=cfg.normalize_observations, reward_scaling=cfg.reward_scaling,
        clipping_epsilon=cfg.clipping_epsilon, gae_lambda=cfg.gae_lambda, max_grad_norm=cfg.max_grad_norm,
        vf_loss_coefficient=cfg.vf_loss_coefficient,
        network_factory=_network_factory(network), seed=seed, num_evals=cfg.num_evals, num_eval_envs=1,
        run_evals=False, policy_params_fn=on_params)
    wall, cpu = clock.training_time()
    ref_env.close()
    steps = clock.curve[-1][0] if clock.curve else cfg.num_timesteps
    return TrainResult(BraxPPO(params, network), clock.curve, wall, steps, clock.validating, seed, cfg,
                       (load_start, os.getloadavg()[0]), cpu)


# ---------------------------------------------------------------- a run folder, as rl_zoo3 lays one out
def write_run(result: TrainResult, folder: str | Path, command: str) -> Path:
    """Write ``result`` as an rl_zoo3-style run ``<folder>/<EnvId>_<seed>/`` (module doc); returns that folder."""
    from footstep_gym.rl.callbacks import CURVE_FIELDS

    cfg = result.config
    run = Path(folder) / f"{cfg.env_id}_{result.seed}"
    (run / cfg.env_id).mkdir(parents=True, exist_ok=True)
    result.model.save(run / f"{cfg.env_id}.zip")
    hyper = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(cfg).items() if k != "env_id"}
    config = {"env_wrapper": [{"gymnasium.wrappers.RescaleAction": {"min_action": -1.0, "max_action": 1.0}}],
              "n_envs": cfg.num_envs, "n_timesteps": cfg.num_timesteps, "policy": result.model.policy_description,
              **hyper}
    (run / cfg.env_id / "config.yml").write_text(yaml.safe_dump(config, sort_keys=False), encoding="utf-8")
    args = {"algo": result.model.algo, "env": cfg.env_id, "seed": result.seed, "n_timesteps": result.timesteps,
            "num_threads": -1, "eval_episodes": cfg.validation_episodes}
    (run / cfg.env_id / "args.yml").write_text(yaml.safe_dump(args, sort_keys=False), encoding="utf-8")
    (run / cfg.env_id / "command.txt").write_text(command + "\n", encoding="utf-8")
    out = io.StringIO()
    out.write(",".join(CURVE_FIELDS + ("cpu_time_s",)) + "\n")
    for steps, wall, rate, cpu in result.curve:
        out.write(f"{steps},{wall:.1f},{rate:.4f},{cfg.validation_episodes},{cpu:.1f}\n")
    (run / "validation.csv").write_text(out.getvalue(), encoding="utf-8")
    return run


# ---------------------------------------------------------------- shipping
def versions() -> dict[str, str | None]:
    """The installed versions of the packages a ``ppo-jax`` run depends on (None: not installed)."""
    from importlib import metadata

    def version(dist: str) -> str | None:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return None

    return {d: version(d) for d in ("footstep_gym", "jax", "jaxlib", "brax", "flax", "optax", "gymnasium")}


def jax_devices() -> str:
    """The devices JAX trains on, e.g. ``"2 x cpu"``."""
    return f"{len(jax.devices())} x {jax.devices()[0].platform}"


def ship(run: str | Path, result: TrainResult, agents_dir: str | Path, agent: str = "ppo-jax",
         target: float = 0.95) -> Path:
    """Ship ``run`` to ``<agents_dir>/<agent>/`` (:func:`footstep_gym.rl.training.ship`, replacing a shipped run:
    the caller checked) with ``ppo-jax``'s figures added to its manifest: the devices, the machine
    (:func:`footstep_gym.rl.training.hardware`, this process's: the one that trained), the validation time, the
    load average, the CPU time, the wall and CPU times to ``target`` validation success, the versions."""
    import platform

    from footstep_gym.rl import training

    dest = training.ship(Path(run), Path(agents_dir), result.wall_time_s, seed=result.seed, force=True, agent=agent)
    path = dest / "manifest.json"
    manifest = json.loads(path.read_text(encoding="utf-8"))
    t, c = result.time_to(target), result.cpu_time_to(target)
    manifest.update({
        "library": result.model.library,
        "n_envs": result.config.num_envs,
        "jax_devices": jax_devices(),
        "hardware": training.hardware(),
        "torch_threads": None,
        "wall_time_includes": "start-up and JAX compilation; not the validation episodes in the reference env",
        "validation_time_s": round(result.validation_time_s, 1),
        "load_average_start_end": [round(v, 2) for v in result.load_average],
        "cpu_time_s": round(result.cpu_time_s, 1),
        f"cpu_time_to_{target}_s": None if c is None else round(c, 1),
        f"time_to_{target}_s": None if t is None else round(t, 1),
        "versions": versions(),
        "python": platform.python_version(),
        "machine": platform.machine(),
    })
    path.write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return dest
