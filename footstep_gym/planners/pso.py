"""Stage 3: particle swarm optimisation (paper eq. 5-8, Table 1), vectorised.

:func:`minimise` is a generic box-bounded PSO: the whole swarm is evaluated per
iteration by ONE call of the objective ``f(X (P, D)) -> (P,)``, so an objective built
on :func:`footstep_gym.lipm.check_steps` costs one batched LIPM evaluation per
iteration. The ``pso-only`` policy reuses it with another objective and bounds.

:func:`feasibility_objective` is eq. (7) over increments ``ΔFC = [ΔS, ΔL, Δθ, ΔT_SS, ΔT_DS]``
(eq. 6) added to the stage-2 command (eq. 8)::

    f(ΔFC) = w · ||ΔFC|| + P,   P = P_0 + k · (ZMP excess [m])  if FC + ΔFC is infeasible, else 0

with ``w = 100``. Eq. (7) prints ``P = 1``; with ``||ΔFC||`` in SI units that cannot be
meant literally, since any increment of norm above 0.01 (one centimetre of stride)
would then cost more than falling, and the optimum would be the unchanged, infeasible
command (the paper's own Table 2 row 21 changes T_DS by 0.1 s: a cost of 10). Here
``P_0`` (``infeasible_penalty``) exceeds ``w`` times the largest possible increment, so
every feasible command beats every infeasible one, and the small graded term
(``violation_weight`` times how far the ZMP offset lies outside the stable rectangle)
gives infeasible particles a slope towards feasibility instead of a plateau.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.planners.params import PSOParams
from footstep_gym.robot import Robot
from footstep_gym.sensing import Snapshot

#: ``f(X (P, D)) -> (P,)`` evaluated once per iteration for the whole swarm.
Objective = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class PSOResult:
    """Best position ``x (D,)`` and value found; ``iterations`` run; ``evaluations`` = particles x (iterations + 1)."""

    x: np.ndarray
    value: float
    iterations: int
    evaluations: int


def minimise(objective: Objective, low: Sequence[float], high: Sequence[float], rng: np.random.Generator, *,
             particles: int, iterations: int, inertia: float, c1: float, c2: float,
             patience: int | None = None, tolerance: float = 1e-9, max_velocity: float = 0.5,
             seeds: np.ndarray | None = None) -> PSOResult:
    """Minimise ``objective`` over the box ``[low, high]`` (a dimension with ``low == high`` is fixed).

    Standard global-best PSO: ``v <- inertia v + c1 r1 (pbest - x) + c2 r2 (gbest - x)``,
    ``|v|`` clamped to ``max_velocity`` times the box size per dimension, positions
    clipped to the box (the clipped component of the velocity is zeroed). Stops after
    ``iterations`` or when the best value improved by less than ``tolerance`` over
    ``patience`` iterations. ``seeds`` (``(k, D)``) replace the first ``k`` random particles
    (e.g. the zero increment).
    """
    low = np.asarray(low, dtype=float)
    high = np.asarray(high, dtype=float)
    if low.shape != high.shape or low.ndim != 1:
        raise ValueError(f"{low.shape=} and {high.shape=} must be equal 1-D shapes")
    if np.any(low > high):
        raise ValueError(f"empty box: low={low} high={high}")
    span = high - low
    vmax = max_velocity * span
    x = low + span * rng.random((particles, low.size))
    if seeds is not None:
        s = np.clip(np.atleast_2d(np.asarray(seeds, dtype=float)), low, high)[:particles]
        x[: len(s)] = s
    v = (2.0 * rng.random(x.shape) - 1.0) * vmax
    f = np.asarray(objective(x), dtype=float)
    pbest, pbest_f = x.copy(), f.copy()
    g = int(np.argmin(f))
    gbest, gbest_f = x[g].copy(), float(f[g])
    stall, it = 0, 0
    for it in range(1, iterations + 1):
        r1 = rng.random(x.shape)
        r2 = rng.random(x.shape)
        v = inertia * v + c1 * r1 * (pbest - x) + c2 * r2 * (gbest - x)
        v = np.clip(v, -vmax, vmax)
        x_new = np.clip(x + v, low, high)
        v = np.where(x_new != x + v, 0.0, v)
        x = x_new
        f = np.asarray(objective(x), dtype=float)
        better = f < pbest_f
        pbest[better], pbest_f[better] = x[better], f[better]
        g = int(np.argmin(pbest_f))
        if pbest_f[g] < gbest_f - tolerance:
            gbest, gbest_f, stall = pbest[g].copy(), float(pbest_f[g]), 0
        else:
            stall += 1
        if patience is not None and stall >= patience:
            break
    return PSOResult(gbest, gbest_f, it, particles * (it + 1))


# ---------------------------------------------------------------- eq. (7): feasibility repair
def zmp_excess(robot: Robot, result: lipm.StepResult) -> np.ndarray:
    """How far [m] each ZMP offset lies outside the stable rectangle (0 inside), ``(N,)``."""
    hx, hy = robot.zmp_half_extent
    p = np.nan_to_num(result.zmp_offset, nan=1.0, posinf=1.0, neginf=-1.0)
    return np.maximum(np.abs(p[:, 0]) - hx, 0.0) + np.maximum(np.abs(p[:, 1]) - hy, 0.0)


def infeasibility_penalty(robot: Robot, result: lipm.StepResult, penalty: float,
                          violation_weight: float) -> np.ndarray:
    """``P`` of eq. (7): ``penalty + violation_weight * zmp_excess`` where infeasible, else 0."""
    return np.where(result.feasible, 0.0, penalty + violation_weight * zmp_excess(robot, result))


def increment_bounds(robot: Robot, reference: np.ndarray, support_side: int, low: Sequence[float],
                     high: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """Table 1's box of ``ΔFC`` intersected with the robot's command limits around ``reference``.

    So that ``reference + ΔFC`` never leaves the action box or the side's turn limits.
    ``reference`` must lie inside those limits (clip it first).
    """
    cmd_lo = robot.command_low.copy()
    cmd_hi = robot.command_high.copy()
    cmd_lo[2], cmd_hi[2] = footstep.turn_bounds(support_side, robot)
    lo = np.maximum(np.asarray(low, dtype=float), cmd_lo - reference)
    hi = np.minimum(np.asarray(high, dtype=float), cmd_hi - reference)
    return np.minimum(lo, 0.0), np.maximum(hi, 0.0)


def feasibility_objective(robot: Robot, com_local: Sequence[float], vel_local: Sequence[float],
                          support_side: int, reference: np.ndarray, *, deviation_weight: float,
                          infeasible_penalty: float, violation_weight: float) -> Objective:
    """Eq. (7) for increments ``ΔFC (P, 5)`` around ``reference`` [S, L, θ, T_SS, T_DS]: one LIPM call per swarm."""
    ref = np.asarray(reference, dtype=float)

    def f(delta: np.ndarray) -> np.ndarray:
        res = lipm.check_steps(robot, com_local, vel_local, ref + delta, support_side)
        return deviation_weight * np.linalg.norm(delta, axis=1) + infeasibility_penalty(
            robot, res, infeasible_penalty, violation_weight)

    return f


def clip_command(robot: Robot, command: Sequence[float], support_side: int) -> np.ndarray:
    """``command`` clipped into the action box and the side-dependent turn limits."""
    cmd = np.clip(np.asarray(command, dtype=float), robot.command_low, robot.command_high)
    lo, hi = footstep.turn_bounds(support_side, robot)
    cmd[2] = min(max(cmd[2], lo), hi)
    return cmd


@dataclass(frozen=True)
class RepairResult:
    """A PSO repair of a command: the optimised command, whether it is feasible, the PSO's result."""

    command: np.ndarray  # (5,) FC_op = FC + ΔFC (eq. 8)
    feasible: bool
    pso: PSOResult


def repair_command(robot: Robot, com_local: Sequence[float], vel_local: Sequence[float], support_side: int,
                   reference: Sequence[float], rng: np.random.Generator, *, delta_low: Sequence[float],
                   delta_high: Sequence[float], particles: int, iterations: int, inertia: float, c1: float,
                   c2: float, patience: int | None, deviation_weight: float, infeasible_penalty: float,
                   violation_weight: float, tolerance: float = 1e-9, max_velocity: float = 0.5) -> RepairResult:
    """The feasible command closest (eq. 7) to ``reference`` within Table 1's increments."""
    ref = clip_command(robot, reference, support_side)
    lo, hi = increment_bounds(robot, ref, support_side, delta_low, delta_high)
    objective = feasibility_objective(
        robot, com_local, vel_local, support_side, ref, deviation_weight=deviation_weight,
        infeasible_penalty=infeasible_penalty, violation_weight=violation_weight)
    res = minimise(objective, lo, hi, rng, particles=particles, iterations=iterations, inertia=inertia,
                   c1=c1, c2=c2, patience=patience, tolerance=tolerance, max_velocity=max_velocity,
                   seeds=np.zeros((1, 5)))
    cmd = ref + res.x
    ok = bool(lipm.check_steps(robot, com_local, vel_local, cmd[None], support_side).feasible[0])
    return RepairResult(cmd, ok, res)


# ---------------------------------------------------------------------- stage 3
@dataclass(frozen=True)
class RepairChoice:
    """Stage 3's record: the command sent and whether the PSO was needed."""

    command: np.ndarray  # (5,) the stage-2 command if feasible, else the PSO's FC + ΔFC
    feasible_before: bool  # the stage-2 command was feasible (the PSO did not run)
    feasible: bool  # the command sent is feasible for the LIPM (as predicted from the snapshot)
    pso: PSOResult | None  # None when the PSO did not run
    rescued: bool = False  # Table 1's increments held nothing feasible: the PSO searched the whole command box

    def diagnostics(self) -> dict[str, object]:
        """The record as ``policy.last_info`` entries."""
        out: dict[str, object] = dict(feasible_pre_pso=self.feasible_before, pso_ran=self.pso is not None,
                                      predicted_feasible=self.feasible, pso_rescue=self.rescued)
        if self.pso is not None:
            out.update(pso_iterations=self.pso.iterations, pso_value=self.pso.value)
        return out


class CommandRepair:
    """Stage 3 with the parameters of ``configs/planner.yaml`` (section ``pso``).

    ``vary_period=False`` (the fixed-period planner): ``ΔT_SS = ΔT_DS = 0``.
    """

    def __init__(self, robot: Robot, params: PSOParams, vary_period: bool = True, rescue: bool = False) -> None:
        self.robot = robot
        self.delta_low, self.delta_high = params.delta_bounds(vary_period=vary_period)
        # The rescue (switch additions.feasibility_rescue): increments as wide as the command box allows
        # (the period only where it may vary), when Table 1's ranges hold nothing feasible.
        span = (robot.command_high - robot.command_low) * np.array([1.0, 1.0, 1.0, vary_period, vary_period])
        self.rescue_low, self.rescue_high = (-span, span) if rescue else (None, None)
        self.settings = dict(
            particles=params.particles, iterations=params.iterations, inertia=params.inertia, c1=params.c1,
            c2=params.c2, patience=params.patience, tolerance=params.tolerance, max_velocity=params.max_velocity,
            deviation_weight=params.deviation_weight, infeasible_penalty=params.infeasible_penalty,
            violation_weight=params.violation_weight)

    def __call__(self, snapshot: Snapshot, reference: np.ndarray, rng: np.random.Generator) -> RepairChoice:
        """``reference`` if the LIPM accepts it from the snapshot's CoM state, else the PSO's closest feasible command.

        One command is checked with the env's own scalar verdict (:func:`lipm.step_feasible`).
        """
        ok = lipm.step_feasible(self.robot, snapshot.com_local, snapshot.vel_local, reference, snapshot.support_side)
        if ok:
            return RepairChoice(reference, True, True, None)
        rep = repair_command(self.robot, snapshot.com_local, snapshot.vel_local, snapshot.support_side, reference,
                             rng, delta_low=self.delta_low, delta_high=self.delta_high, **self.settings)
        if not rep.feasible and self.rescue_low is not None:
            rep = repair_command(self.robot, snapshot.com_local, snapshot.vel_local, snapshot.support_side,
                                 reference, rng, delta_low=self.rescue_low, delta_high=self.rescue_high,
                                 **self.settings)
            return RepairChoice(rep.command, False, rep.feasible, rep.pso, rescued=True)
        return RepairChoice(rep.command, False, rep.feasible, rep.pso)
