"""Trained stable-baselines3 agents (rl_zoo3's saved layout) as footstep policies.

rl_zoo3 saves a run as ``<algo>/<EnvId>_<k>/``: the model ``<EnvId>.zip`` and a folder
``<EnvId>/`` with ``config.yml`` (the hyperparameters, the env wrapper included),
``args.yml`` (the command line), ``command.txt`` and ``vecnormalize.pkl`` (observation
statistics). :class:`ZooAgent` loads such a run (or a bare ``.zip``) and acts in the env's
own units: it normalises the observation as ``VecNormalize`` did in training, predicts
deterministically, and maps the action from the agent's box ([-1, 1] under
``RescaleAction``) to the footstep command with Gymnasium's own rescaling function.

torch and stable-baselines3 are imported only when an agent is loaded.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from footstep_gym.robot import Robot
from footstep_gym.training import zoo_yaml

#: rl_zoo3 algorithm names this loader knows, and the stable-baselines3 class of each.
ALGORITHMS = {"ppo": "PPO", "sac": "SAC", "td3": "TD3", "a2c": "A2C", "ddpg": "DDPG"}


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
        zips = sorted(z for z in path.glob("*.zip") if not z.name.startswith(("best_model", "rl_model")))
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


def check_run(path: str | Path, algo: str | None = None) -> tuple[Path, Path, str]:
    """``(model zip, folder of config.yml/vecnormalize.pkl, algorithm)`` of a zoo run folder or ``.zip``.

    Everything :class:`ZooAgent` checks before it loads the model (no torch): the files are
    there and the algorithm (``algo``, else the run's ``args.yml``) is one this loader knows.
    Raises ``FileNotFoundError`` or ``ValueError`` naming the agent.
    """
    model_path, folder, args_path = resolve_run(path)
    if algo is None and args_path is not None:
        algo = zoo_yaml(args_path).get("algo")
    if algo is None:
        raise ValueError(f"agent {str(path)!r}: no args.yml beside the model to name its algorithm; "
                         f"pass algo= one of {sorted(ALGORITHMS)}")
    if algo not in ALGORITHMS:
        raise ValueError(f"agent {str(path)!r}: algorithm {algo!r} not supported; one of {sorted(ALGORITHMS)}")
    return model_path, folder, algo


class ZooAgent:
    """A trained agent as a footstep policy: ``reset(seed)``, ``act(obs, snapshot) -> command``.

    Args:
        path: a zoo run folder (``.../ppo/FootstepDoor-v0_1``) or a model ``.zip``.
        robot: the robot whose command box the env uses (the agent's action is mapped into it).
        algo: the algorithm (``ppo``, ``sac``, ...); read from the run's ``args.yml`` if None.
    """

    def __init__(self, path: str | Path, robot: Robot, algo: str | None = None) -> None:
        import torch

        torch.set_num_threads(1)  # one core per evaluation worker (PLATFORM: more threads are slower)
        model_path, folder, algo = check_run(path, algo)
        import stable_baselines3

        self.algo = algo
        self.path = model_path
        self.model = getattr(stable_baselines3, ALGORITHMS[algo]).load(model_path, device="cpu")
        norm_path = folder / "vecnormalize.pkl"
        self.normalizer = None
        if norm_path.is_file():
            with open(norm_path, "rb") as fh:
                self.normalizer = pickle.load(fh)
            self.normalizer.training = False
        env_box = spaces.Box(robot.command_low.astype(np.float32), robot.command_high.astype(np.float32),
                             dtype=np.float32)
        config_path = folder / "config.yml"
        bounds = _rescale_bounds(zoo_yaml(config_path) if config_path.is_file() else {})
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
                             f"env's {agent_box}")
        self.last_info: dict[str, Any] = {}

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset: the agent acts deterministically on the observation alone."""

    def act(self, obs: np.ndarray, snapshot: Any = None) -> np.ndarray:
        """The footstep command (float32, in the env's box) for observation ``obs``."""
        x = np.asarray(obs, dtype=np.float32).reshape(1, -1)
        if self.normalizer is not None:
            x = self.normalizer.normalize_obs(x)
        action, _ = self.model.predict(x, deterministic=True)
        action = np.asarray(action, dtype=np.float32).reshape(-1)
        return self._to_command(action) if self._to_command is not None else action
