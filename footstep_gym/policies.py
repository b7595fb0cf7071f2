"""Every policy by name: the one factory, :func:`make_policy`, and the names it knows.

A policy is a :class:`footstep_gym.policy.Policy` (``reset(seed)``, ``act(obs, snapshot)``,
``last_info``). Its name is one of

* a reference planner, an entry of :data:`footstep_gym.planners.POLICIES` (a
  :class:`~footstep_gym.planners.PolicySpec`: class, config overrides, description), or a
  variant of one: ``<planner>-no-<switch>`` (one of our additions off, the ablation's) and
  ``paper-period-aware-t0-<s>`` (the paper's planner with T0 fixed at ``<s>`` seconds);
* a shipped agent, an entry of :data:`footstep_gym.rl.AGENTS` (an
  :class:`~footstep_gym.rl.AgentEntry`: algorithm, description, where its runs are), made from
  one training run (``run=``; :func:`footstep_gym.rl.agent_runs` lists the shipped ones);
* ``agent:<label>`` with ``run=``: a user's own zoo run folder or ``.zip``.

One planner is no baseline: ``oracle`` reads the true future of the obstacles (an upper bound,
:mod:`footstep_gym.planners.oracle`); :func:`reads_truth` names it, the evaluation binds it to
the env and marks it "(upper bound)", and it runs only when asked for by name.

Each name is listed once, with its description, in those two tables; :func:`policy_names`,
:func:`is_policy` and :func:`describe` read them. Nothing here imports the planners' kernels
or torch until a policy is made.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

# The agents' registry, re-exported for the evaluation script (one module for every name it resolves).
from footstep_gym.rl.agents import (  # noqa: F401
    AGENTS,
    AGENTS_DIR_ENV_VAR,
    agent_runs,
    default_agents_dir,
    missing_agents_note,
)

if TYPE_CHECKING:
    from footstep_gym.planners.params import PlannerConfig
    from footstep_gym.policy import Policy
    from footstep_gym.robot import Robot

#: ``agent:<label>`` names a user's agent, made from ``run=`` its zoo folder or ``.zip``.
USER_AGENT_PREFIX = "agent:"

__all__ = ["AGENTS", "AGENTS_DIR_ENV_VAR", "USER_AGENT_PREFIX", "agent_runs", "default_agents_dir", "describe",
           "is_agent", "is_policy", "make_policy", "missing_agents_note", "planner_names", "policy_names",
           "reads_truth"]


def planner_names() -> tuple[str, ...]:
    """The registered planners (their variants not listed: see :func:`is_policy`)."""
    from footstep_gym.planners.registry import POLICIES

    return tuple(POLICIES)


def policy_names() -> tuple[str, ...]:
    """Every registered policy: planners first, then agents (planner variants not listed: see :func:`is_policy`)."""
    return planner_names() + tuple(AGENTS)


def is_agent(name: str) -> bool:
    """A trained agent's name: a registered agent or ``agent:<label>``."""
    return name in AGENTS or name.startswith(USER_AGENT_PREFIX)


def is_policy(name: str) -> bool:
    """A registered name, or a planner variant ``<planner>-no-<switch>`` / ``paper-period-aware-t0-<s>``."""
    if name in AGENTS:
        return True
    from footstep_gym.planners.registry import policy_spec

    try:
        policy_spec(name)
    except ValueError:
        return False
    return True


def reads_truth(name: str) -> bool:
    """Whether policy ``name`` reads the true future through ``bind_truth`` (``oracle``): an upper bound, never a
    baseline; the evaluation marks it "(upper bound)" and runs it only when named. Agents never do."""
    if is_agent(name):
        return False
    return getattr(_planner_spec(name).planner, "reads_truth", False) is True


def describe(name: str) -> str:
    """One line on what policy ``name`` is (for ``--help``); ``ValueError`` for an unknown name."""
    if name in AGENTS:
        return AGENTS[name].description
    if name.startswith(USER_AGENT_PREFIX):
        return "a user's trained agent (run=PATH)"
    return _planner_spec(name).description


def _planner_spec(name: str) -> Any:
    """The planner's :class:`~footstep_gym.planners.PolicySpec`; an unknown name's error lists every kind of name."""
    from footstep_gym.planners.registry import policy_spec

    try:
        return policy_spec(name)
    except ValueError as exc:
        raise ValueError(f"{exc}; trained agents (with run=): {', '.join(AGENTS)}, or {USER_AGENT_PREFIX}NAME "
                         f"with run=PATH") from None


def make_policy(name: str, robot: Robot | str | Mapping[str, Any] | None = None, seed: int | None = None, *,
                run: str | Path | None = None, config: PlannerConfig | None = None, **overrides: Any) -> Policy:
    """The policy named ``name``, seeded with ``seed``: the one factory of planners and agents.

    Args:
        name: a planner (``period-aware``, ``fixed-period``, ``pso-only``, ``paper-period-aware``,
            ``paper-fixed-period``), a variant ``<planner>-no-<switch>`` or
            ``paper-period-aware-t0-<s>``, a shipped agent (``ppo``, ``ppo-all``, ``sac``,
            ``ppo-fixed-period``) or ``agent:<label>``; :func:`policy_names` lists them.
        robot: a :class:`~footstep_gym.robot.Robot` (e.g. ``env.unwrapped.robot``), or what
            ``gym.make(..., robot=...)`` takes: a profile name (``"darwin-op"``), a mapping of
            ``configs/robot.yaml`` overrides, or both (``{"profile": "darwin-op", ...}``);
            ``None``: ``configs/robot.yaml``.
        seed: the policy's own generator (the planners' RRT and PSO; agents act deterministically).
        run: an agent's training run: a zoo run folder or its ``.zip`` (required for agents;
            :func:`footstep_gym.rl.agent_runs` gives the shipped ones).
        config: a planner's ready :class:`~footstep_gym.planners.PlannerConfig`, used as given.
        overrides: planner config keys, per section (``rrt={"iterations": 200}``) or flat
            (``rrt_iterations=200``), on top of ``configs/planner.yaml`` and the planner's own
            switches; exclusive with ``config``.

    Raises ``ValueError`` for an unknown name (listing the known ones), an agent without
    ``run`` or with planner options; ``FileNotFoundError`` for a ``run`` that is not a zoo run.
    """
    from footstep_gym.robot import Robot, load_robot

    if not isinstance(robot, Robot):
        robot = load_robot(robot)
    if is_agent(name):
        if run is None:
            hint = (f"; the shipped ones: footstep_gym.rl.agent_runs({name!r}, env_id)" if name in AGENTS else "")
            raise ValueError(f"policy {name!r} is a trained agent: pass run= its zoo run folder or .zip{hint}")
        if overrides or config is not None:
            given = sorted(overrides) + (["config"] if config is not None else [])
            raise ValueError(f"policy {name!r} is a trained agent; planner options {given} do not apply")
        from footstep_gym.rl.agents import ZooAgent

        policy = ZooAgent(run, robot, algo=AGENTS[name].algo if name in AGENTS else None, name=name)
        policy.reset(seed=seed)
        return policy
    if run is not None:
        raise ValueError(f"policy {name!r} is a planner; run= is for trained agents")
    return _planner_spec(name).build(name, robot, seed, config=config, **overrides)
