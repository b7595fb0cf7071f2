"""Null baselines: trivial policies that sense nothing, the floor every benchmark cell must stand above.

A benchmark cell that one of these solves measures nothing (a blind walker that repeats one
command is no planner), so the protocol asks of every cell outside the ``paper`` tier that the
best null baseline succeed in at most 10 % of its validation episodes (docs/benchmark.md,
``tests/test_tiers.py``). They are policies like any other: made by name with
:func:`footstep_gym.make_policy` and run in the benchmark (``--policy null-stand``).

* :class:`ConstantWalker` (``null-walk-<S>cm-<T>s``): the same command every footstep, a
  straight stride ``S`` at period ``T`` (the robot's nominal double support, the rest single
  support), the nominal side stride and no turn; :data:`WALKER_STRIDES` x :data:`WALKER_PERIODS`
  span the robot's speeds from a slow shuffle to its quickest straight walk.
* :class:`RandomCommand` (``null-random``): a command drawn uniformly from the action box every
  footstep, from the policy's own seeded generator.
* :class:`Standing` (``null-stand``): steps in place at the nominal period (the robot cannot
  stand still: every command is a step).

None of them reads the observation or the sensing snapshot: ``act`` ignores both.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from footstep_gym.policy import SeededPolicy
from footstep_gym.robot import Robot

#: Constant walkers' forward strides S [m] and periods T = T_SS + T_DS [s]: 3 x 3 walkers, 1 cm/s to 0.25 m/s.
WALKER_STRIDES = (0.02, 0.05, 0.10)
WALKER_PERIODS = (0.4, 0.6, 0.8)
#: The name prefix every null baseline shares (tables and the null rule find them by it).
NULL_PREFIX = "null-"


def walker_name(stride: float, period: float) -> str:
    """``null-walk-<S>cm-<T>s`` of a constant walker with stride ``stride`` [m] at period ``period`` [s]."""
    return f"{NULL_PREFIX}walk-{100 * stride:g}cm-{period:g}s"


def is_null(name: str) -> bool:
    """Whether policy ``name`` is a null baseline."""
    return name.startswith(NULL_PREFIX)


class NullPolicy(SeededPolicy):
    """Shared by the null baselines: the registry's constructor ``(robot, config, seed, name)``, no sensing.

    ``config`` (the planners' :class:`~footstep_gym.planners.PlannerConfig`) is accepted and unused.
    """

    description = ""

    def __init__(self, robot: Robot, config: Any = None, seed: int | None = None, name: str | None = None) -> None:
        super().__init__(robot, seed, name)

    def act(self, observation: Any, snapshot: Any) -> np.ndarray:
        command = self._command()
        self.last_info = {"policy": self.name, "command": command}
        return command

    def _command(self) -> np.ndarray:
        raise NotImplementedError


class ConstantWalker(NullPolicy):
    """The command ``[stride, L_nominal, 0, period - T_DS_nominal, T_DS_nominal]`` every footstep.

    Class attributes ``stride`` [m] and ``period`` [s] are set per registered walker (:func:`walker`).
    """

    stride: float = 0.0
    period: float = 0.0

    def __init__(self, robot: Robot, config: Any = None, seed: int | None = None, name: str | None = None) -> None:
        super().__init__(robot, config, seed, name)
        t_ds = robot.nominal_t_ds
        command = np.array([self.stride, robot.nominal_side_stride, 0.0, self.period - t_ds, t_ds])
        low, high = robot.command_low, robot.command_high
        if np.any(command < low - 1e-12) or np.any(command > high + 1e-12):
            raise ValueError(f"{self.name or 'constant walker'}: command {command.tolist()} (stride {self.stride:g} m, "
                             f"period {self.period:g} s) leaves the robot's command box {low.tolist()} .. "
                             f"{high.tolist()}")
        self.command = command

    def _command(self) -> np.ndarray:
        return self.command.copy()


def walker(stride: float, period: float) -> type[ConstantWalker]:
    """A :class:`ConstantWalker` class walking ``stride`` [m] every ``period`` [s] (what the registry lists)."""
    return type(f"ConstantWalker_{100 * stride:g}cm_{period:g}s".replace(".", "_"), (ConstantWalker,),
                {"stride": float(stride), "period": float(period), "__module__": __name__,
                 "description": f"null baseline: blind, the same straight {100 * stride:g} cm stride every "
                                f"{period:g} s"})


class RandomCommand(NullPolicy):
    """A command drawn uniformly from the robot's action box every footstep (the policy's seeded generator)."""

    description = "null baseline: blind, a command drawn uniformly from the action box every footstep"

    def _command(self) -> np.ndarray:
        return self.rng.uniform(self.robot.command_low, self.robot.command_high)


class Standing(NullPolicy):
    """Steps in place at the nominal period, for ever (the robot's nominal command)."""

    description = "null baseline: steps in place at the nominal period"

    def _command(self) -> np.ndarray:
        return self.robot.nominal_command.copy()


#: Every null baseline by name: the constant walkers, then random, then standing.
NULL_POLICIES: dict[str, type[NullPolicy]] = {
    **{walker_name(s, t): walker(s, t) for s in WALKER_STRIDES for t in WALKER_PERIODS},
    f"{NULL_PREFIX}random": RandomCommand,
    f"{NULL_PREFIX}stand": Standing,
}
