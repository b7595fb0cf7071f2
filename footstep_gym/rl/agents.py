"""Trained stable-baselines3 agents (rl_zoo3's saved layout) as footstep policies, and where they are.

rl_zoo3 saves a run as ``<algo>/<EnvId>_<k>/``: the model ``<EnvId>.zip`` and a folder
``<EnvId>/`` with ``config.yml`` (the hyperparameters, the env wrapper and the env options
included), ``args.yml`` (the command line), ``command.txt`` and ``vecnormalize.pkl``
(observation statistics). :class:`ZooAgent` loads such a run (or a bare ``.zip``) and acts
in the env's own units: it normalises the observation as ``VecNormalize`` did in training,
predicts deterministically, and maps the action from the agent's box ([-1, 1] under
``RescaleAction``) to the footstep command with Gymnasium's own rescaling function. A run
trained with ``fixed_period`` (action ``[S, L, θ]``) plays in the ordinary five-field env:
the period is appended at the robot's nominal one (:class:`ZooAgent`).

The shipped agents are registered in :mod:`.registry` (:data:`~.registry.AGENTS`, where their
runs are: :func:`~.registry.agent_runs`).

torch and stable-baselines3 (sbx and JAX for the sbx algorithms) are imported only when an agent is loaded.
"""

from __future__ import annotations

import os
import pickle
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from footstep_gym.policy import Policy
from footstep_gym.robot import Robot
from footstep_gym.rl.training import zoo_yaml

#: rl_zoo3 algorithm names this loader knows, and the class of each: stable-baselines3's, or for the names
#: in :data:`ALGORITHM_PACKAGES` that package's (sbx: the JAX implementations, trained through
#: :mod:`footstep_gym.rl.zoo_sbx`).
ALGORITHMS = {"ppo": "PPO", "sac": "SAC", "td3": "TD3", "a2c": "A2C", "ddpg": "DDPG",
              "sac_sbx": "SAC", "td3_sbx": "TD3", "ppo_lstm": "RecurrentPPO", "ppo_jax": "BraxPPO",
              "ppo_jax_rnn": "RecurrentPPOJax"}
#: The package of an algorithm's class when it is not ``stable_baselines3`` (``ppo_jax``: Brax's PPO trained on the
#: JAX env, :class:`footstep_gym.rl.ppo_jax.BraxPPO`, loaded and predicting as SB3's models do; ``ppo_jax_rnn``: its
#: recurrent twin, :class:`footstep_gym.rl.ppo_jax_rnn.RecurrentPPOJax`, predicting with its state as RecurrentPPO).
ALGORITHM_PACKAGES = {"sac_sbx": "sbx", "td3_sbx": "sbx", "ppo_lstm": "sb3_contrib",
                      "ppo_jax": "footstep_gym.rl.ppo_jax", "ppo_jax_rnn": "footstep_gym.rl.ppo_jax_rnn"}


def algorithm_class(algo: str) -> Any:
    """The model class of rl_zoo3 algorithm ``algo`` (:data:`ALGORITHMS`), its package imported now.

    sbx (``sac_sbx``, ``td3_sbx``) is imported only here, with JAX held to one thread
    (:func:`footstep_gym.rl.zoo_sbx.import_sbx`); ``ImportError`` saying how to install it if it is missing.
    """
    if algo not in ALGORITHMS:
        raise ValueError(f"algorithm {algo!r} not supported; one of {sorted(ALGORITHMS)}")
    package = ALGORITHM_PACKAGES.get(algo, "stable_baselines3")
    if package == "sbx":
        from footstep_gym.rl.zoo_sbx import import_sbx

        module = import_sbx()
    else:
        import importlib

        module = importlib.import_module(package)
    return getattr(module, ALGORITHMS[algo])


# ---------------------------------------------------------------- a zoo run's files
def _rescale_bounds(config: dict[str, Any]) -> tuple[float, float] | None:
    """(min_action, max_action) of a ``RescaleAction`` in the zoo's ``env_wrapper``, or None."""
    wrappers = config.get("env_wrapper") or []
    if isinstance(wrappers, (str, dict)):
        wrappers = [wrappers]
    for w in wrappers:
        if isinstance(w, dict):
            for name, kwargs in w.items():
                if name.endswith("RescaleAction"):
                    return float(kwargs["min_action"]), float(kwargs["max_action"])
    return None


def resolve_run(path: str | Path) -> tuple[Path, Path, Path | None]:
    """``(model zip, folder of config.yml/vecnormalize.pkl, args.yml or None)`` of a zoo run folder or a ``.zip``."""
    path = Path(path)
    if path.is_dir():
        zips = sorted(z for z in path.glob("*.zip") if not z.name.startswith(("best_model", "rl_model", ".")))
        if len(zips) != 1:
            raise FileNotFoundError(f"{path}: expected one <EnvId>.zip (the zoo's final model), found "
                                    f"{[z.name for z in zips] or 'none'}")
        model = zips[0]
    elif path.suffix == ".zip" and path.is_file():
        model = path
    else:
        raise FileNotFoundError(f"agent {str(path)!r}: not a zoo run folder nor a .zip file")
    folder = model.parent / model.stem  # <EnvId>/ beside <EnvId>.zip
    if not folder.is_dir():
        folder = model.parent
    args = folder / "args.yml"
    return model, folder, args if args.is_file() else None


def check_run(path: str | Path, algo: str | None = None,
              vecnormalize: str | Path | None = None) -> tuple[Path, Path, str]:
    """``(model zip, folder of config.yml/vecnormalize.pkl, algorithm)`` of a zoo run folder or ``.zip``.

    Everything :class:`ZooAgent` checks before it loads the model (no torch): the files are
    there (``vecnormalize``: a ``VecNormalize`` file given apart from the run) and the algorithm
    (``algo``, else the run's ``args.yml``) is one this loader knows.
    Raises ``FileNotFoundError`` or ``ValueError`` naming the agent.
    """
    model_path, folder, args_path = resolve_run(path)
    if algo is None and args_path is not None:
        algo = zoo_yaml(args_path).get("algo")
    if algo is None:
        raise ValueError(f"agent {str(path)!r}: no args.yml beside the model to name its algorithm; "
                         f"give its algorithm (--algo, algo=) one of {sorted(ALGORITHMS)}")
    if vecnormalize is not None and not Path(vecnormalize).is_file():
        raise FileNotFoundError(f"agent {str(path)!r}: VecNormalize file {str(vecnormalize)!r} not found")
    if algo not in ALGORITHMS:
        raise ValueError(f"agent {str(path)!r}: algorithm {algo!r} not supported; one of {sorted(ALGORITHMS)}")
    return model_path, folder, algo


def run_config(path: str | Path) -> dict[str, Any]:
    """The zoo's ``config.yml`` of a run folder or ``.zip`` as a dict ({} if there is none)."""
    _, folder, _ = resolve_run(path)
    config_path = folder / "config.yml"
    return zoo_yaml(config_path) if config_path.is_file() else {}


def training_env(path: str | Path) -> Any:
    """The env a zoo run was trained on, as the zoo made it: ``gym.make(EnvId, **env_kwargs)`` of its
    ``config.yml`` and its ``RescaleAction``. What ``<Algo>.load(zip, env=...)`` checks the spaces against,
    e.g. to resume training (``VecNormalize`` left out: it keeps the spaces)."""
    import gymnasium as gym

    import footstep_gym  # noqa: F401  (registers the envs)

    model, _, _ = resolve_run(path)
    config = run_config(path)
    env = gym.make(model.stem, **dict(config.get("env_kwargs") or {}))
    bounds = _rescale_bounds(config)
    if bounds is not None:
        box = env.action_space
        env = gym.wrappers.RescaleAction(env, np.full(box.shape, bounds[0], box.dtype),
                                         np.full(box.shape, bounds[1], box.dtype))
    return env


def resave_with_env_spaces(path: str | Path) -> Path:
    """Re-save a run's model and ``vecnormalize.pkl`` with the observation space of the env as it is now
    (:func:`training_env`).

    A model stores the observation space it was trained with, and ``<Algo>.load(zip, env=...)``
    refuses an env whose space differs ("Observation spaces do not match"), e.g. after the
    env's bounds were made finite; ``VecNormalize`` keeps its own copy, which the zoo's resumed
    training (``--trained-agent``) hands to the model as the env's. The weights, the optimizer
    state and the normalisation statistics are kept (check with ``model.policy.state_dict()``);
    the bounds do not enter an MLP policy. Returns the model's path.
    """

    model_path, folder, algo = check_run(path)
    env = training_env(path)
    space = env.observation_space
    env.close()
    model = algorithm_class(algo).load(model_path, device="cpu", custom_objects={"observation_space": space})
    partial = model_path.with_name(f".{model_path.stem}.partial.zip")
    norm_path = folder / "vecnormalize.pkl"
    norm_partial = folder / ".vecnormalize.partial.pkl"
    try:
        model.save(partial)
        if norm_path.is_file():
            with open(norm_path, "rb") as fh:
                normalizer = pickle.load(fh)
            normalizer.observation_space = space
            # Pickled as saved (no venv): VecNormalize.__getstate__ drops these, which only set_venv makes.
            normalizer.class_attributes, normalizer.returns = {}, None
            with open(norm_partial, "wb") as fh:
                pickle.dump(normalizer, fh)
            os.replace(norm_partial, norm_path)
        os.replace(partial, model_path)
    finally:
        partial.unlink(missing_ok=True)
        norm_partial.unlink(missing_ok=True)
    return model_path


def _pinned_limits(robot: Robot, n_fields: int) -> list[dict[float, float]]:
    """Per command field, ``{limit rounded to float32: limit}`` over the values a field can be pinned at (the
    box's bounds; for θ also the turn limits); of limits that round alike, the lowest. The env's reading of a
    float32 action (``FootstepEnv``'s "Action Space"): a float32 field equal to a rounded limit is that limit."""
    turns = (-robot.turn_outer, -robot.turn_inner, robot.turn_inner, robot.turn_outer)
    tables = []
    for i in range(n_fields):
        limits = np.array(sorted({float(robot.command_low[i]), float(robot.command_high[i]),
                                  *(turns if i == 2 else ())}))
        table: dict[float, float] = {}
        for rounded, exact in zip(limits.astype(np.float32).astype(np.float64).tolist(), limits.tolist()):
            table.setdefault(rounded, exact)
        tables.append(table)
    return tables


# ---------------------------------------------------------------- loading, once per process
#: Loaded runs kept per process (:func:`load_run`): an evaluation makes a fresh policy per episode, and
#: loading (for sbx, compiling the JAX policy) costs far more than an episode's acts.
LOADED_RUNS_KEPT = 8


@dataclass(frozen=True)
class LoadedRun:
    """A run's model, its ``VecNormalize`` (None without one, in evaluation mode) and ``config.yml``, shared by every
    :class:`ZooAgent` of the run in a process. Read only: an agent's own state (an LSTM's) lives in the agent."""

    model: Any
    normalizer: Any
    config: dict[str, Any]


def load_run(model_path: Path, folder: Path, algo: str, vecnormalize: str | Path | None = None) -> LoadedRun:
    """The run whose model is ``model_path`` (its zoo folder ``folder``; its ``VecNormalize`` file ``vecnormalize``,
    default the folder's ``vecnormalize.pkl``), loaded once per process and kept while it is among the
    :data:`LOADED_RUNS_KEPT` most recent; a file rewritten since (another size or modification time) is loaded anew."""
    norm = Path(vecnormalize) if vecnormalize is not None else folder / "vecnormalize.pkl"
    files = [model_path, norm, folder / "config.yml"]
    stamps = tuple((st.st_mtime_ns, st.st_size) if (st := _stat(f)) is not None else None for f in files)
    return _load_run(str(model_path), str(folder), str(norm), algo, stamps)


def _stat(path: Path) -> os.stat_result | None:
    try:
        return path.stat()
    except FileNotFoundError:
        return None


@lru_cache(maxsize=LOADED_RUNS_KEPT)
def _load_run(model_path: str, folder: str, norm_path: str, algo: str, stamps: tuple[Any, ...]) -> LoadedRun:
    model = algorithm_class(algo).load(model_path, device="cpu")
    if ALGORITHM_PACKAGES.get(algo) == "sbx":  # JAX compiles the policy at its first call: here, not in act's time
        model.predict(np.zeros((1, *model.observation_space.shape), np.float32), deterministic=True)
    normalizer = None
    if stamps[1] is not None:
        with open(norm_path, "rb") as fh:
            normalizer = pickle.load(fh)
        normalizer.training = False
    config = zoo_yaml(Path(folder) / "config.yml") if stamps[2] is not None else {}
    return LoadedRun(model, normalizer, config)


# ---------------------------------------------------------------- the policy
class ZooAgent(Policy):
    """A trained agent as a footstep policy: ``reset(seed)``, ``act(obs, snapshot) -> command``.

    Args:
        path: a zoo run folder (``.../ppo/FootstepDoor-v0_1``) or a model ``.zip``.
        robot: the robot whose command box the env uses (the agent's action is mapped into it).
        algo: the algorithm (``ppo``, ``sac``, ...); read from the run's ``args.yml`` if None.
        name: the policy's name (``last_info["policy"]``); default ``agent:<run folder>``.
        vecnormalize: the run's ``VecNormalize`` file, if it is not the zoo's (``vecnormalize.pkl`` in the run's
            ``<EnvId>/`` folder, or beside a ``.zip``).

    A plain ``.zip`` (no zoo ``config.yml``) acts in the env's command box; one whose action space is
    ``[-1, 1]`` per field was trained under ``RescaleAction(-1, 1)`` and is mapped back as the zoo's are.

    A run trained with the env option ``fixed_period`` (its ``config.yml``'s ``env_kwargs``;
    action ``[S, L, θ]``, the period at nominal) plays in the ordinary five-field env, so it is
    compared with the other policies on the same env: ``act`` maps its three fields through the
    rescaling as in training and returns float64 ``[S, L, θ, T_SS, T_DS]`` with the robot's
    nominal ``T_SS, T_DS`` exactly and each float32 field equal to a float32-rounded limit
    replaced by that limit, as the fixed-period env reads it. The command the env applies is
    then the one the fixed-period env would have applied, bit for bit (a test replays both).
    """

    def __init__(self, path: str | Path, robot: Robot, algo: str | None = None, name: str | None = None,
                 vecnormalize: str | Path | None = None) -> None:
        super().__init__()
        import torch

        torch.set_num_threads(1)  # one core per evaluation worker (PLATFORM: more threads are slower)
        model_path, folder, algo = check_run(path, algo, vecnormalize)

        self.algo = algo
        self.path = model_path
        self._state: Any = None  # a recurrent policy's (LSTM) state, carried from act to act within an episode
        self._episode_start = np.ones((1,), dtype=bool)
        run_folder = folder.parent if folder != model_path.parent else None  # <EnvId>_<k>/ of a zoo run
        self.name = name or f"agent:{run_folder.name if run_folder is not None else model_path.stem}"
        loaded = load_run(model_path, folder, algo, vecnormalize)
        self.model, self.normalizer, config = loaded.model, loaded.normalizer, loaded.config
        #: The env options the agent was trained with (``config.yml``'s ``env_kwargs``).
        self.env_kwargs: dict[str, Any] = dict(config.get("env_kwargs") or {})
        #: Trained with the period held at nominal: the model's action is ``[S, L, θ]``.
        self.fixed_period = bool(self.env_kwargs.get("fixed_period", False))
        n_act = 3 if self.fixed_period else 5
        env_box = spaces.Box(robot.command_low[:n_act].astype(np.float32),
                             robot.command_high[:n_act].astype(np.float32), dtype=np.float32)
        bounds = _rescale_bounds(config)
        box = self.model.action_space
        if bounds is None and not config and box.shape == env_box.shape and np.all(box.low == -1) and np.all(
                box.high == 1):
            bounds = (-1.0, 1.0)  # a plain model trained under RescaleAction(-1, 1)
        self._to_command = None
        if bounds is not None:
            from gymnasium.wrappers.utils import rescale_box

            # The agent's bounds in the box's own dtype (Python floats would be float64, which
            # Gymnasium's Box warns about casting); -1 and 1 are exact in float32 either way.
            lo, hi = (np.full(env_box.shape, b, dtype=env_box.dtype) for b in bounds)
            agent_box, _, self._to_command = rescale_box(env_box, lo, hi)
        else:
            agent_box = env_box
        if self.model.action_space.shape != agent_box.shape or not (
                np.allclose(self.model.action_space.low, agent_box.low)
                and np.allclose(self.model.action_space.high, agent_box.high)):
            raise ValueError(f"agent {str(path)!r}: its action space {self.model.action_space} is not the "
                             f"env's {agent_box}" + (" (fixed_period: [S, L, theta])" if self.fixed_period else ""))
        if self.fixed_period:
            self._pinned = _pinned_limits(robot, 3)
            self._nominal_period = [float(v) for v in robot.nominal_command[3:]]  # T_SS, T_DS: float64, exact

    def reset(self, seed: int | None = None) -> None:
        """A new episode: a recurrent agent's state starts afresh (the others act on the observation alone);
        the agent acts deterministically, so ``seed`` changes nothing."""
        self.last_info = {}
        self._state = None
        self._episode_start = np.ones((1,), dtype=bool)

    def act(self, obs: np.ndarray, snapshot: Any = None) -> np.ndarray:
        """The footstep command ``(5,)`` for observation ``obs``: float32 in the env's box, or for a
        fixed-period agent float64 with the nominal period (see the class doc)."""
        x = np.asarray(obs, dtype=np.float32).reshape(1, -1)
        if self.normalizer is not None:
            x = self.normalizer.normalize_obs(x)
        action, self._state = self.model.predict(x, state=self._state, episode_start=self._episode_start,
                                                 deterministic=True)
        self._episode_start = np.zeros((1,), dtype=bool)
        action = np.asarray(action, dtype=np.float32).reshape(-1)
        command = self._to_command(action) if self._to_command is not None else action
        if self.fixed_period:
            values = [table.get(v, v) for table, v in zip(self._pinned, command.tolist())]
            command = np.array(values + self._nominal_period, dtype=np.float64)
        self.last_info = {"policy": self.name, "command": command}
        return command
