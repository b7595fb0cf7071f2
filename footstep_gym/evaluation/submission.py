"""What a user submits to an evaluation: their agents' files (``--agent [SCENE=]PATH``) and policies as callables.

* :class:`AgentArg` and :func:`parse_agents`: ``--agent`` values, each a zoo run folder or a
  stable-baselines3 / sbx ``.zip``, for every scene or, as ``SCENE=PATH``, for that scene only
  (a zoo run of one scene's env, ``.../FootstepDoor-v0_1``, is that scene's without saying so);
  ``--algo`` names the algorithm of a ``.zip`` without the zoo's ``args.yml`` and ``--vecnormalize``
  its observation statistics, one per ``--agent`` in order;
* :func:`runs_by_env`: the agents each env is scored with; an agent of one scene is never scored
  on another, and a scene with no agent is an error;
* :class:`CallableFactory`: a user's ``make_policy_fn(scene, seed)`` returning a
  :class:`~footstep_gym.policy.Policy` or any callable ``observation -> action`` (or
  ``(observation, snapshot) -> action``), pickled with cloudpickle so that every worker process
  and every Ray task makes the same policy (:func:`footstep_gym.evaluation.benchmark.evaluate`).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from footstep_gym.policy import Policy


class SubmissionError(ValueError):
    """A bad ``--agent`` / ``--algo`` / ``--vecnormalize`` combination: one line saying why."""


@dataclass(frozen=True)
class AgentArg:
    """One ``--agent``: ``path`` (absolute), the scene it is for (None: every scene), its algorithm and
    ``VecNormalize`` file where the run does not name them."""

    path: str
    scene: str | None = None
    algo: str | None = None
    vecnormalize: str | None = None

    @property
    def label(self) -> str:
        """The run's name: the zoo run folder's, or the ``.zip``'s stem."""
        p = Path(self.path)
        return p.stem if p.suffix == ".zip" else p.name


def _scene_of_model(path: Path) -> str | None:
    """The scene whose env a zoo run or model was trained on, read from its name (``FootstepDoor-v0.zip``, a run
    folder holding one), or None (another env, e.g. the mix, or a name that is no env id)."""
    from footstep_gym.scenarios import SCENARIOS

    stems = [path.stem] if path.suffix == ".zip" else [z.stem for z in path.glob("*.zip")]
    scenes = {name for name, cls in SCENARIOS.items() if cls.env_id in stems}
    return scenes.pop() if len(scenes) == 1 else None


def parse_agents(values: Sequence[str], algo: str | None = None,
                 vecnormalize: Sequence[str] | None = None) -> list[AgentArg]:
    """The ``--agent`` values (``PATH`` or ``SCENE=PATH``), checked: the files exist, a scene is known, no
    path is given twice, ``--vecnormalize`` is one file per agent. :class:`SubmissionError` (one line)."""
    from footstep_gym.rl.agents import ALGORITHMS
    from footstep_gym.scenarios import SCENARIOS

    if algo is not None and algo not in ALGORITHMS:
        raise SubmissionError(f"--algo {algo}: one of {', '.join(sorted(ALGORITHMS))}")
    norms = list(vecnormalize or [])
    if norms and len(norms) != len(values):
        raise SubmissionError(f"--vecnormalize: one file per --agent, in their order ({len(norms)} for "
                              f"{len(values)} agents)")
    out: list[AgentArg] = []
    seen: dict[str, str] = {}
    for k, value in enumerate(values):
        scene, sep, path_text = value.partition("=")
        if not sep:
            scene, path_text = "", value
        elif scene not in SCENARIOS:
            raise SubmissionError(f"--agent {value}: unknown scene {scene!r}; one of {', '.join(SCENARIOS)} "
                                  "(SCENE=PATH)")
        path = Path(path_text).expanduser()
        if not path.exists():
            raise SubmissionError(f"--agent {path_text}: no such file or folder")
        resolved = str(path.resolve())
        if resolved in seen:
            raise SubmissionError(f"--agent {path_text}: given twice ({seen[resolved]} and {value})")
        seen[resolved] = value
        norm = None
        if norms:
            if not Path(norms[k]).is_file():
                raise SubmissionError(f"--vecnormalize {norms[k]}: no such file")
            norm = str(Path(norms[k]).resolve())
        out.append(AgentArg(resolved, scene or _scene_of_model(path), algo, norm))
    return out


def runs_by_env(agents: Sequence[AgentArg], env_ids: Sequence[str]) -> dict[str, tuple[AgentArg, ...]]:
    """``{env id: the agents scored on it}``: an agent of one scene on that scene's env only, an agent of every
    scene on each. :class:`SubmissionError` if agents name scenes and one of ``env_ids`` has none."""
    from footstep_gym.scenarios import scene_of

    out = {env_id: tuple(a for a in agents if a.scene in (None, scene_of(env_id))) for env_id in env_ids}
    missing = [scene_of(env_id) for env_id, found in out.items() if not found]
    if missing:
        given = sorted({a.scene for a in agents if a.scene})
        raise SubmissionError(f"--agent: no agent for the {', '.join(missing)} scene(s) (agents given for "
                              f"{', '.join(given)}); give SCENE=PATH for each scene run, or restrict the run with "
                              "--env")
    return out


# ---------------------------------------------------------------- a policy as any callable
class CallablePolicy(Policy):
    """A callable ``observation -> action`` (``snapshot``: ``(observation, snapshot) -> action``) as a
    :class:`~footstep_gym.policy.Policy`. The action is read as 5 float64 numbers ``[S, L, θ, T_SS, T_DS]``
    in the env's units (a torch tensor or a JAX array alike)."""

    def __init__(self, fn: Callable[..., Any], name: str, snapshot: bool = False) -> None:
        super().__init__()
        self.fn, self.name, self.snapshot = fn, name, snapshot

    def reset(self, seed: int | None = None) -> None:
        self.last_info = {}
        reset = getattr(self.fn, "reset", None)  # a stateful callable (a recurrent policy) may start afresh
        if callable(reset):
            reset()

    def act(self, observation: Any, snapshot: Any = None) -> np.ndarray:
        action = self.fn(observation, snapshot) if self.snapshot else self.fn(observation)
        command = np.asarray(action, dtype=np.float64)  # its shape is the env's to check (ActionError)
        self.last_info = {"policy": self.name, "command": command}
        return command


#: Callables unpickled in this process, by their pickle's hash (a worker unpickles each once).
_loaded: dict[str, Callable[..., Any]] = {}


class CallableFactory:
    """The runner's policy factory for a user's ``make_policy_fn(scene, seed)``: picklable (the function goes as
    cloudpickle's bytes, its own module by value unless it is installed), so that every worker process and Ray
    task makes the policy the same way. ``make_policy_fn`` returns a ``Policy`` or a callable, wrapped in
    :class:`CallablePolicy`."""

    def __init__(self, make_policy_fn: Callable[..., Any], name: str, snapshot: bool = False) -> None:
        import sys

        import cloudpickle

        module = sys.modules.get(getattr(make_policy_fn, "__module__", "") or "")
        by_value = module is not None and _is_users(module)
        if by_value:
            cloudpickle.register_pickle_by_value(module)
        try:
            self.payload = cloudpickle.dumps(make_policy_fn)
        finally:
            if by_value:
                cloudpickle.unregister_pickle_by_value(module)
        self.key = hashlib.sha256(self.payload).hexdigest()
        self.name, self.snapshot = name, snapshot

    def __call__(self, cell: Any, robot: Any, seed: int) -> Policy:
        import pickle

        fn = _loaded.get(self.key)
        if fn is None:
            fn = _loaded[self.key] = pickle.loads(self.payload)
        made = fn(cell.scenario, seed)
        if isinstance(made, Policy):
            made.name = made.name or self.name
            return made
        if not callable(made):
            raise TypeError(f"make_policy_fn returned a {type(made).__name__}: a Policy or a callable "
                            "observation -> action was expected")
        return CallablePolicy(made, self.name, self.snapshot)


def _is_users(module: Any) -> bool:
    """A module of the user's own (a script, a notebook, a test file): not this package, not an installed one."""
    name = module.__name__
    if name == "__main__" or name.split(".")[0] == "footstep_gym":
        return False  # __main__ goes by value anyway; the package is installed in every worker
    file = getattr(module, "__file__", None) or ""
    return bool(file) and "site-packages" not in file and "dist-packages" not in file
