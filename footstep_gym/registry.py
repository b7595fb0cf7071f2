"""Every policy by name: :func:`resolve` turns a name into one :class:`PolicyEntry`, :func:`make_policy` builds it.

A policy is a :class:`footstep_gym.policy.Policy` (``reset(seed)``, ``act(obs, snapshot)``,
``last_info``). A name is one of

* a planner, an entry of :data:`footstep_gym.planners.POLICIES` (a
  :class:`~footstep_gym.planners.PolicySpec`), or a variant of one: ``<planner>-no-<switch>``,
  ``<planner>-with-<switch>`` and ``paper-period-aware-t0-<s>``;
* a shipped agent, an entry of :data:`footstep_gym.rl.registry.AGENTS` (an
  :class:`~footstep_gym.rl.registry.AgentEntry`), made from one training run (``run=``;
  :func:`footstep_gym.rl.agent_runs` lists the shipped ones);
* ``agent:<label>`` with ``run=``: a user's own zoo run folder or stable-baselines3 / sbx ``.zip``
  (``algo=`` names the algorithm of a ``.zip`` without the zoo's ``args.yml``);
* ``module:attr``: a policy of one's own, imported (:class:`ImportedPolicy`): a ``Policy``
  subclass constructed as ``attr(robot, seed)`` or a factory ``attr(robot, seed) -> Policy``.
  The module is looked up on ``sys.path``, then in the working directory, in this process and
  in every evaluation worker alike.

:func:`resolve` reads those tables once per name and returns everything a caller asks about it
(its kind, description, whether it reads the truth, its builder); callers pass the entry on.
One policy is no baseline: ``oracle`` reads the true future of the obstacles (an upper bound,
:mod:`footstep_gym.planners.oracle`): its entry's ``reads_truth`` is true, the evaluation binds it
to the env and marks it "(upper bound)" (:attr:`PolicyEntry.label`), and it runs only when named.

Importing this module imports neither the planners' kernels, nor :mod:`footstep_gym.rl`, nor torch.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import sys
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping

from footstep_gym.errors import FootstepGymError

if TYPE_CHECKING:
    from footstep_gym.planners.params import PlannerConfig
    from footstep_gym.policy import Policy
    from footstep_gym.robot import Robot

#: ``agent:<label>`` names a user's agent, made from ``run=`` its zoo folder or ``.zip``.
USER_AGENT_PREFIX = "agent:"

#: The kinds of :attr:`PolicyEntry.kind`.
KINDS = ("planner", "agent", "user-agent", "import", "callable")

__all__ = ["KINDS", "USER_AGENT_PREFIX", "ImportedPolicy", "PolicyEntry", "PolicyLoadError", "make_policy",
           "planner_names", "policy_names", "resolve"]


class PolicyLoadError(FootstepGymError, ValueError):
    """A policy given by import path cannot be imported, is not a policy or builds no policy (one line)."""


# ---------------------------------------------------------------- a policy given by import path
def is_import_path(name: str) -> bool:
    """``module:attr`` (dotted names on both sides), the form of a policy of one's own."""
    module, sep, attr = name.partition(":")
    return (bool(sep) and not name.startswith(USER_AGENT_PREFIX)
            and all(p.isidentifier() for p in module.split(".")) and all(p.isidentifier() for p in attr.split(".")))


@dataclass(frozen=True)
class ImportedPolicy:
    """A policy of one's own, ``module:attr``: the import path, the module's file and its SHA-256.

    ``attr`` is a :class:`~footstep_gym.policy.Policy` subclass, constructed as ``attr(robot, seed)``,
    or a factory called as ``attr(robot, seed)`` that returns a ``Policy``; ``robot`` is the env's
    :class:`~footstep_gym.robot.Robot` (its command box, its nominal command), ``seed`` the episode's.
    """

    path: str  # module:attr
    file: str | None  # the module's source file
    sha256: str | None  # of that file's bytes

    @property
    def module(self) -> str:
        return self.path.partition(":")[0]

    def target(self) -> Any:
        """The class or factory ``attr`` names (imported now; :class:`PolicyLoadError` if it cannot be, or if
        it is neither a ``Policy`` subclass nor callable)."""
        return _policy_target(self.path)

    def __call__(self, robot: Robot, seed: int | None) -> Policy:
        """The policy for ``robot``, seeded with ``seed``; :class:`PolicyLoadError` naming the path if what
        ``attr`` makes is not a ``Policy``."""
        from footstep_gym.policy import Policy

        target = self.target()
        what = "class" if isinstance(target, type) else "factory"
        try:
            policy = target(robot, seed)
        except Exception as exc:
            raise PolicyLoadError(f"--policy {self.path}: the {what} failed when called as {self.path}(robot, seed): "
                                  f"{type(exc).__name__}: {exc}") from exc
        if not isinstance(policy, Policy):
            raise PolicyLoadError(f"--policy {self.path}: the factory returned a {type(policy).__name__}, not a "
                                  f"footstep_gym.policy.Policy")
        if not getattr(policy, "name", ""):
            policy.name = self.path
        return policy


def _import_attr(path: str) -> Any:
    """``attr`` of ``module`` for ``module:attr``, the module looked up on ``sys.path``, then in the working
    directory (as ``python -m`` would); one-line :class:`PolicyLoadError` otherwise."""
    module_name, _, attr = path.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        cwd = os.getcwd()
        if exc.name != module_name.split(".")[0] or cwd in sys.path:
            raise _import_error(path, exc) from None
        sys.path.append(cwd)
        try:
            module = importlib.import_module(module_name)
        except Exception as again:
            raise _import_error(path, again) from None
    except Exception as exc:
        raise _import_error(path, exc) from None
    target: Any = module
    for part in attr.split("."):
        try:
            target = getattr(target, part)
        except AttributeError:
            raise PolicyLoadError(f"--policy {path}: module {module_name} ({getattr(module, '__file__', '?')}) has "
                                  f"no attribute {attr!r}") from None
    return target


def _import_error(path: str, exc: Exception) -> PolicyLoadError:
    module_name = path.partition(":")[0]
    if isinstance(exc, ModuleNotFoundError) and exc.name and module_name.startswith(exc.name):
        return PolicyLoadError(f"--policy {path}: no module named {exc.name!r} on sys.path or in the working "
                               f"directory {os.getcwd()}")
    return PolicyLoadError(f"--policy {path}: importing {module_name} failed: {type(exc).__name__}: {exc}")


def _policy_target(path: str) -> Any:
    """The object ``module:attr`` names, checked to be a ``Policy`` subclass or a callable."""
    from footstep_gym.policy import Policy

    target = _import_attr(path)
    if isinstance(target, type) and not issubclass(target, Policy):
        raise PolicyLoadError(f"--policy {path}: {target.__module__}.{target.__qualname__} is not a "
                              f"footstep_gym.policy.Policy subclass (nor a factory returning one)")
    if not callable(target):
        raise PolicyLoadError(f"--policy {path}: a {type(target).__name__}, not a Policy subclass or a factory "
                              f"returning one")
    return target


def imported_policy(path: str) -> ImportedPolicy:
    """The :class:`ImportedPolicy` of ``module:attr``, its module imported now (the file hashed); a
    :class:`PolicyLoadError` if ``attr`` is neither a ``Policy`` subclass nor callable."""
    _policy_target(path)
    module = sys.modules[path.partition(":")[0]]
    file = getattr(module, "__file__", None)
    digest = hashlib.sha256(Path(file).read_bytes()).hexdigest() if file and Path(file).is_file() else None
    return ImportedPolicy(path, file, digest)


# ---------------------------------------------------------------- the entry
@dataclass(frozen=True)
class PolicyEntry:
    """What a policy name is, resolved once (:func:`resolve`).

    ``kind``: one of :data:`KINDS` (``callable``: a function given to :func:`footstep_gym.benchmark.evaluate`);
    ``description``: one line (``--help``, ``benchmark.json``);
    ``reads_truth``: the policy reads the true future through ``bind_truth`` (an upper bound, never a
    baseline); ``build(robot, seed, run, config, overrides, agent_options) -> Policy``: the builder
    (:meth:`make` checks the options first). ``spec``: a planner's
    :class:`~footstep_gym.planners.PolicySpec`; ``agent``: a shipped agent's
    :class:`~footstep_gym.rl.registry.AgentEntry`; ``source``: a policy given by import path.
    """

    name: str
    kind: str
    description: str
    build: Callable[..., Policy] = field(repr=False, compare=False)
    reads_truth: bool = False
    spec: Any = None
    agent: Any = None
    source: ImportedPolicy | None = None

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """An entry goes to a worker process by its name, which the worker's registry resolves to the same entry
        (as a function pickles by its qualified name: a planner's builder may be a class made at import); a
        callable's (:func:`footstep_gym.benchmark.evaluate`, no name to look up) goes by value."""
        if self.kind == "callable":
            return (PolicyEntry, (self.name, self.kind, self.description, self.build, self.reads_truth))
        return (resolve, (self.name,))

    @property
    def is_agent(self) -> bool:
        """A trained agent (a shipped one or ``agent:<label>``): made from a training run (``run=``)."""
        return self.kind in ("agent", "user-agent")

    @property
    def label(self) -> str:
        """The name in a table: ``oracle (upper bound)`` for a policy that reads the truth, else the name."""
        return f"{self.name} (upper bound)" if self.reads_truth else self.name

    def make(self, robot: Robot | str | Mapping[str, Any] | None = None, seed: int | None = None, *,
             run: str | Path | None = None, config: PlannerConfig | None = None, algo: str | None = None,
             vecnormalize: str | Path | None = None, **overrides: Any) -> Policy:
        """This policy for ``robot``, seeded with ``seed`` (:func:`make_policy`'s arguments)."""
        from footstep_gym.robot import Robot, load_robot

        if not isinstance(robot, Robot):
            robot = load_robot(robot)
        agent_options = {k: v for k, v in (("algo", algo), ("vecnormalize", vecnormalize)) if v is not None}
        if self.is_agent:
            if run is None:
                hint = (f"; the shipped ones: footstep_gym.rl.agent_runs({self.name!r}, env_id)"
                        if self.kind == "agent" else "")
                raise ValueError(f"policy {self.name!r} is a trained agent: pass run= its zoo run folder or .zip{hint}")
            if overrides or config is not None:
                given = sorted(overrides) + (["config"] if config is not None else [])
                raise ValueError(f"policy {self.name!r} is a trained agent; planner options {given} do not apply")
        else:
            if run is not None:
                raise ValueError(f"policy {self.name!r} is {'a planner' if self.kind == 'planner' else 'no agent'}; "
                                 "run= is for trained agents")
            if agent_options:
                raise ValueError(f"policy {self.name!r} is not a trained agent; {sorted(agent_options)} do not apply")
            if self.kind == "import" and (overrides or config is not None):
                raise ValueError(f"policy {self.name!r} is imported; planner options do not apply")
        return self.build(robot, seed, run=run, config=config, overrides=overrides, agent_options=agent_options)


def _build_planner(spec: Any, name: str, robot: Robot, seed: int | None, *, config: Any, overrides: dict,
                   **_: Any) -> Policy:
    return spec.build(name, robot, seed, config=config, **overrides)


def _build_agent(algo: str | None, name: str, robot: Robot, seed: int | None, *, run: str | Path,
                 agent_options: dict, **_: Any) -> Policy:
    from footstep_gym.rl.agents import ZooAgent

    policy = ZooAgent(run, robot, algo=agent_options.get("algo", algo), name=name,
                      vecnormalize=agent_options.get("vecnormalize"))
    policy.reset(seed=seed)
    return policy


def _build_imported(source: ImportedPolicy, robot: Robot, seed: int | None, **_: Any) -> Policy:
    return source(robot, seed)


def planner_names() -> tuple[str, ...]:
    """The registered planners (their variants not listed: see :func:`resolve`)."""
    from footstep_gym.planners.registry import POLICIES

    return tuple(POLICIES)


def policy_names() -> tuple[str, ...]:
    """Every registered policy: planners first, then agents (variants, ``agent:<label>`` and ``module:attr`` are
    resolved by :func:`resolve` but not listed)."""
    from footstep_gym.rl.registry import AGENTS

    return planner_names() + tuple(AGENTS)


@lru_cache(maxsize=256)
def resolve(name: str) -> PolicyEntry:
    """The :class:`PolicyEntry` of ``name`` (see the module's doc for the forms of a name).

    Raises ``ValueError`` for an unknown name (listing the known ones) and :class:`PolicyLoadError`
    (a ``ValueError``) for a ``module:attr`` that cannot be imported.
    """
    from functools import partial

    if name.startswith(USER_AGENT_PREFIX):
        return PolicyEntry(name, "user-agent", "a user's trained agent (run=PATH)", partial(_build_agent, None, name))
    if is_import_path(name):
        source = imported_policy(name)
        where = f" ({source.file})" if source.file else ""
        return PolicyEntry(name, "import", f"a policy imported from {name}{where}", partial(_build_imported, source),
                           source=source)
    from footstep_gym.rl.registry import AGENTS

    if name in AGENTS:
        entry = AGENTS[name]
        return PolicyEntry(name, "agent", entry.description, partial(_build_agent, entry.algo, name), agent=entry)
    from footstep_gym.planners.registry import policy_spec

    try:
        spec = policy_spec(name)
    except ValueError as exc:
        raise ValueError(f"{exc}; trained agents (with run=): {', '.join(AGENTS)}, or {USER_AGENT_PREFIX}NAME "
                         f"with run=PATH; or a policy of your own as module:attr") from None
    return PolicyEntry(name, "planner", spec.description, partial(_build_planner, spec, name),
                       reads_truth=getattr(spec.planner, "reads_truth", False) is True, spec=spec)


def make_policy(name: str, robot: Robot | str | Mapping[str, Any] | None = None, seed: int | None = None, *,
                run: str | Path | None = None, config: PlannerConfig | None = None, algo: str | None = None,
                vecnormalize: str | Path | None = None, **overrides: Any) -> Policy:
    """The policy named ``name``, seeded with ``seed``: the one factory of planners, agents and imported policies.

    Args:
        name: a planner of :data:`footstep_gym.planners.POLICIES` (``period-aware``, ``fixed-period``,
            ``pso-only``, ``paper-period-aware``, ``paper-fixed-period``, ``oracle``, ...), a variant
            ``<planner>-no-<switch>``, ``<planner>-with-<switch>`` or ``paper-period-aware-t0-<s>``, a
            shipped agent of :data:`footstep_gym.rl.registry.AGENTS` (:func:`policy_names` lists them
            all), ``agent:<label>`` (a user's trained agent) or ``module:attr`` (a policy of one's own).
        robot: a :class:`~footstep_gym.robot.Robot` (e.g. ``env.unwrapped.robot``), or what
            ``gym.make(..., robot=...)`` takes: a profile name (``"darwin-op"``), a mapping of
            ``configs/robot.yaml`` overrides, or both (``{"profile": "darwin-op", ...}``);
            ``None``: ``configs/robot.yaml``.
        seed: the policy's own generator (the planners' RRT and PSO; agents act deterministically).
        run: an agent's training run: a zoo run folder or a model ``.zip`` (required for agents;
            :func:`footstep_gym.rl.agent_runs` gives the shipped ones).
        config: a planner's ready :class:`~footstep_gym.planners.PlannerConfig`, used as given.
        algo: an agent's algorithm (``ppo``, ``sac``, ``sac_sbx``, ...), for a ``.zip`` without the zoo's
            ``args.yml``; ``vecnormalize``: its ``VecNormalize`` file, if not beside the model.
        overrides: planner config keys, per section (``rrt={"iterations": 200}``) or flat
            (``rrt_iterations=200``), on top of ``configs/planner.yaml`` and the planner's own
            switches; exclusive with ``config``.

    Raises ``ValueError`` for an unknown name (listing the known ones), an agent without ``run`` or
    with planner options; ``FileNotFoundError`` for a ``run`` that is not a zoo run or a ``.zip``.
    """
    return resolve(name).make(robot, seed, run=run, config=config, algo=algo, vecnormalize=vecnormalize,
                              **overrides)
