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
:func:`footstep_gym.make_policy` builds either by name (:mod:`footstep_gym.registry`).

A policy of one's own needs no registration: a :class:`Policy` subclass whose constructor takes
``(robot, seed)`` (the env's :class:`~footstep_gym.robot.Robot` and the episode's seed), or a
factory ``(robot, seed) -> Policy``, in a module ``mymodule`` runs as
``eval_planner.py --benchmark --policy mymodule:MyPolicy``, and any callable
``observation -> action`` through :func:`footstep_gym.benchmark.evaluate`::

    class Walker(Policy):
        def __init__(self, robot, seed=None):
            super().__init__()
            self.command = robot.nominal_command.copy()
            self.command[0] = 0.04  # a 4 cm stride, blind: a null baseline

        def reset(self, seed=None):
            self.last_info = {}

        def act(self, observation, snapshot):
            return self.command
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

    How a policy is constructed is its maker's business: the registered planners are built as
    ``cls(robot, config, seed, name)`` (:class:`footstep_gym.planners.PolicySpec`), a policy of
    one's own given as ``module:attr`` as ``attr(robot, seed)`` (:mod:`footstep_gym.registry`).
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


class SeededPolicy(Policy):
    """A policy of the registry's constructor ``(robot, ..., seed, name)`` with its own generator ``rng``:
    seeded when built, re-seeded by ``reset(seed)`` (``None`` keeps it), ``last_info`` cleared per episode."""

    def __init__(self, robot: Any, seed: int | None = None, name: str | None = None) -> None:
        super().__init__()
        if name is not None:
            self.name = name  # a configured variant of the class (e.g. "paper-period-aware")
        self.robot = robot
        self.rng = np.random.default_rng(seed)

    def reset(self, seed: int | None = None) -> None:
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self.last_info = {}
