"""One registry of policies for the evaluation: the reference planners and the shipped agents.

A policy is anything with ``reset(seed=...)`` and ``act(obs, snapshot) -> command``. The
planners come from :data:`footstep_gym.planners.POLICIES`; an agent is an entry of
:data:`AGENTS`, resolved per env to the training runs shipped under the agents folder in
rl_zoo3's layout (``<agents>/<algo>/<EnvId>_<seed>/``). Adding a policy is one entry in
either registry. A user's own agent is evaluated by path (``agent:<name>`` with ``run``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from footstep_gym.robot import Robot

_AGENTS_ENV_VAR = "FOOTSTEP_GYM_AGENTS_DIR"
USER_AGENT_PREFIX = "agent:"


@dataclass(frozen=True)
class AgentEntry:
    """A shipped agent: its algorithm (the zoo's folder) and the env it was trained on."""

    algo: str
    description: str
    trained_on: str | None = None  # env id of the training env; None: the env being evaluated


AGENTS: dict[str, AgentEntry] = {
    "ppo": AgentEntry("ppo", "PPO (stable-baselines3, rl_zoo3) trained on the env evaluated; one row per "
                             "training seed, summarised over seeds"),
    "ppo-all": AgentEntry("ppo", "one PPO trained across the three scenes (FootstepMix-v0)",
                          trained_on="FootstepMix-v0"),
    "sac": AgentEntry("sac", "SAC (stable-baselines3, rl_zoo3) trained on the env evaluated"),
}

PLANNER_DESCRIPTIONS = {
    "period-aware": "the paper's planner: binary search for the period, modified RRT, PSO (with our additions)",
    "fixed-period": "the same planner with the period held at the nominal T_n",
    "pso-only": "PSO alone over the whole command box",
    "paper-period-aware": "the paper's planner as written: Algorithms 1-2, PSO when infeasible, none of our additions",
    "paper-fixed-period": "the paper's planner as written, the period held at T_n",
}


def planner_names() -> tuple[str, ...]:
    from footstep_gym.planners import POLICIES

    return tuple(POLICIES)


def policy_names() -> tuple[str, ...]:
    """Every registered policy: planners first, then agents (planner variants not listed: see :func:`is_policy`)."""
    return planner_names() + tuple(AGENTS)


def is_policy(name: str) -> bool:
    """A registered name, or a planner variant ``<planner>-no-<switch>`` (the ablation's)."""
    if name in AGENTS or name in planner_names():
        return True
    from footstep_gym.planners.reference import policy_spec

    try:
        policy_spec(name)
    except ValueError:
        return False
    return True


def describe(name: str) -> str:
    """One line on what policy ``name`` is (for ``--help``)."""
    if name in AGENTS:
        return AGENTS[name].description
    return PLANNER_DESCRIPTIONS.get(name, "reference planner (footstep_gym.planners)")


def default_agents_dir() -> Path:
    """``$FOOTSTEP_GYM_AGENTS_DIR``, else the repository's ``baselines/agents`` (a source checkout)."""
    env = os.environ.get(_AGENTS_ENV_VAR)
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / "baselines" / "agents"


def agent_runs(name: str, env_id: str, agents_dir: str | Path | None = None) -> list[Path]:
    """The shipped training runs of agent ``name`` for evaluation on ``env_id`` (sorted by seed; [] if none)."""
    entry = AGENTS[name]
    root = Path(agents_dir) if agents_dir is not None else default_agents_dir()
    trained_on = entry.trained_on or env_id
    folder = root / entry.algo
    runs = [p for p in folder.glob(f"{trained_on}_*") if p.is_dir() and (p / f"{trained_on}.zip").is_file()]

    def seed_of(p: Path) -> tuple[int, str]:
        tail = p.name.rsplit("_", 1)[-1]
        return (int(tail), p.name) if tail.isdigit() else (1 << 30, p.name)

    return sorted(runs, key=seed_of)


def make_policy(name: str, robot: Robot | None = None, seed: int | None = None, run: str | Path | None = None,
                **overrides: Any) -> Any:
    """A policy by registry name. Agents need ``run`` (a zoo run folder or ``.zip``, from :func:`agent_runs`
    or a user's path); planner ``overrides`` are planner config keys."""
    from footstep_gym.robot import load_robot

    robot = robot if robot is not None else load_robot()
    if name in AGENTS or name.startswith(USER_AGENT_PREFIX):
        if run is None:
            raise ValueError(f"policy {name!r} is a trained agent: pass run= its zoo folder or .zip")
        if overrides:
            raise ValueError(f"policy {name!r} is a trained agent; planner overrides {sorted(overrides)} do not apply")
        from footstep_gym.evaluation.agents import ZooAgent

        policy = ZooAgent(run, robot, algo=AGENTS[name].algo if name in AGENTS else None)
        policy.reset(seed=seed)
        return policy
    from footstep_gym.planners import make_policy as make_planner

    if not is_policy(name):
        raise ValueError(f"unknown policy {name!r}; known: {', '.join(policy_names())}, planner variants "
                         f"<planner>-no-<switch> (or {USER_AGENT_PREFIX}NAME with run=PATH)")
    return make_planner(name, robot, seed=seed, **overrides)
