"""The policy interface: what the evaluation drives, scripted planner or trained agent alike.

::

    from footstep_gym import make_policy

    policy = make_policy("period-aware", env.unwrapped.robot, seed=0)
    policy.reset(seed=0)
    obs, info = env.reset(seed=0)
    while True:
        action = policy.act(obs, env.unwrapped.sensing())   # [S, L, θ, T_SS, T_DS], SI units
        obs, reward, terminated, truncated, info = env.step(action)
        ...  policy.last_info  # what the policy did this step (planning time, pre-PSO command, ...)

The planners (:mod:`footstep_gym.planners`) read only the sensing snapshot; a trained agent
(:class:`footstep_gym.rl.ZooAgent`) reads only the observation. Both subclass :class:`Policy`;
:func:`footstep_gym.make_policy` builds either by name (:mod:`footstep_gym.policies`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from footstep_gym.sensing import Snapshot


class Policy(ABC):
    """What the evaluation drives: ``reset`` per episode, ``act`` per footstep.

    ``act`` returns the footstep command ``[S, L, θ, T_SS, T_DS]`` (float, SI units, shape
    ``(5,)``; the env reads it in its own dtype, see ``FootstepEnv``'s "Action Space") and
    leaves a dict ``last_info`` describing the step. ``name`` is the registry name the
    policy was made under (:func:`footstep_gym.make_policy`).
    """

    name: str = ""

    def __init__(self) -> None:
        self.last_info: dict[str, Any] = {}

    @abstractmethod
    def reset(self, seed: int | None = None) -> None:
        """Start an episode; ``seed`` re-seeds the policy's own generator (``None``: keep it)."""

    @abstractmethod
    def act(self, observation: Any, snapshot: Snapshot | None) -> np.ndarray:
        """The next footstep command ``(5,)`` from the env's observation and/or sensing snapshot."""
