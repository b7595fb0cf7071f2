"""Stage 1: the walking period by binary search (paper Algorithm 1, Fig. 2).

:class:`PeriodSearch` is the stage: from a snapshot it returns a :class:`PeriodChoice`
(the period, whether any walk was free, the free walks, diagnostics). Inside:

Between a short period ``T0`` and the nominal ``T_n`` find the **longest** period ``T``
for which ``ObstacleCollision(T)`` is false. The collision predicate is an argument of
:func:`longest_free_period`, so the search is testable with hand-made predicates;
:mod:`.rollouts` holds the two the planners use (the paper's one-step
:class:`~.rollouts.NextNodeFan` and our look-ahead :class:`~.rollouts.GoalRollouts`).

Algorithm 1 as printed tests ``ObstacleCollision(T1)`` at every pass and never moves
``T1`` back up once a free value is found, so it returns the first free value of the
sequence ``T_n, T_n/2, ...`` rather than the longest free period its text describes
("the walking period determined using the binary search is the longest walking
period for coping with dynamic obstacles"). :func:`longest_free_period` is the
bisection the text describes, assuming the predicate is monotone (a shorter period
never collides where a longer one does not):

* ``T_n`` free -> ``T_n`` (the robot keeps its nominal period);
* ``T0`` colliding -> ``T0`` (no period clears the way; walk as fast as allowed);
* else bisect with ``free(lo)``, ``collides(hi)`` for ``iterations`` passes and return
  ``lo``: the longest free period to within ``(T_n - T0) / 2**iterations``.

``T0`` itself has two readings (docs/model.md §5.3). Algorithm 1 prints ``T0 <- 0``; its text
says "T0 is determined to be a short walking period that the robot can use".
``period_search.t0_reachable`` follows the text: ``T0`` is :func:`shortest_feasible_period`,
the shortest period one step can reach from the current CoM state (from the nominal steady
gait about 0.37 s, the shortest period of the paper's Table 2). Off, ``T0`` is the fixed
``period_search.t0_s`` (0.3 s, ours: T_SS 0.1 s, which the LIPM cannot reach from the steady
gait in one step). Every planner uses the text's reading (the YAML's ``t0_reachable: true``);
``paper-period-aware-t0-<s>`` holds ``T0`` fixed at ``<s>`` seconds.

Our additions, each a switch of ``configs/planner.yaml`` (section ``additions``):

* ``lipm_windows``: :func:`stride_window`, the idea of the reachable ``T0`` (cutting ``T_SS``
  from 0.6 s to 0.1 s in one step is infeasible for the LIPM, docs/model.md §3) carried over to
  the stride: at a short period the CoM's momentum forbids stopping (or lengthening the
  stride) in one step, so the first step of the walks and of the RRT keeps to the front
  strides the LIPM accepts. It also implies the reachable ``T0`` whatever ``t0_reachable`` says;
  off (``period-aware-no-lipm-windows``), ``T0`` is the text's reading like the paper's planner's;
* ``long_lookahead``: goal-directed rollouts over the prediction horizon instead of the
  one-step check;
* ``waiting_walks``: only if no period lets the robot go on at full stride, the search
  is repeated with walks that slow down or first step in place (let the obstacle pass);
* ``centred_period``: :func:`centred_free_period` instead of the bisection: a scan of
  ``scan_periods`` periods whose answer is the middle of the window of free periods rather
  than its longest end (a crowd closes in from behind on a robot that walks at the edge of
  the window).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from footstep_gym import lipm
from footstep_gym.kernels import Kernels
from footstep_gym.planners.params import PlannerConfig
from footstep_gym.planners.rollouts import GoalRollouts, NextNodeFan
from footstep_gym.planners.walks import BodyCheck, WalkStart
from footstep_gym.robot import Robot
from footstep_gym.sensing import Snapshot


@dataclass(frozen=True)
class PeriodSearchResult:
    """What the binary search found: ``period`` [s] and how it got there."""

    period: float  # [s] the longest collision-free period (T0 if none, T_n if T_n is free)
    nominal_free: bool  # ObstacleCollision(T_n) was false
    any_free: bool  # some period in [T0, T_n] was free
    evaluations: int  # calls of the predicate


def longest_free_period(collides: Callable[[float], bool], t_short: float, t_nominal: float,
                        iterations: int) -> PeriodSearchResult:
    """Algorithm 1: the longest ``T`` in ``[t_short, t_nominal]`` with ``collides(T)`` false.

    ``iterations`` is ``N``; the answer is within ``(t_nominal - t_short) / 2**N`` of the
    boundary, on its free side.
    """
    if t_short > t_nominal:
        raise ValueError(f"t_short={t_short} must not exceed t_nominal={t_nominal}")
    if not collides(t_nominal):
        return PeriodSearchResult(t_nominal, True, True, 1)
    if collides(t_short):
        return PeriodSearchResult(t_short, False, False, 2)
    lo, hi = t_short, t_nominal
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if collides(mid):
            hi = mid
        else:
            lo = mid
    return PeriodSearchResult(lo, False, True, 2 + iterations)


def centred_free_period(survivals: Callable[[np.ndarray], np.ndarray], periods: np.ndarray) -> PeriodSearchResult:
    """The middle of the window of free periods among ``periods`` [s] (ascending; switch ``additions.centred_period``).

    ``survivals(periods)`` [s] is how long the best walk at each period stays free (``inf``: free),
    asked once for all of them. Among moving obstacles "free" need not be monotone in ``T``: in a
    crowd that walks with the robot, walks that are too quick run into the member ahead and walks
    that are too slow are caught from behind, so the free periods form a window whose *longest*
    end (the bisection's answer) is its edge, where any prediction error is a collision. The middle
    of the window that holds the longest free period is as far from both edges as the grid allows;
    the door and the crossing, whose window reaches down to the shortest period, then walk a
    little quicker than they must. With no free period: the shortest, as the bisection.
    """
    periods = np.asarray(periods, dtype=float)
    if periods.ndim != 1 or periods.size == 0 or np.any(np.diff(periods) < 0):
        raise ValueError(f"periods must be a non-empty ascending 1-D array, got {periods!r}")
    free = np.isinf(np.asarray(survivals(periods), dtype=float))
    if not free.any():
        return PeriodSearchResult(float(periods[0]), False, False, periods.size)
    hi = int(np.flatnonzero(free)[-1])
    lo = hi
    while lo > 0 and free[lo - 1]:
        lo -= 1
    return PeriodSearchResult(float(periods[(lo + hi + 1) // 2]), bool(free[-1]), True, periods.size)


def shortest_feasible_period(robot: Robot, com_local: Sequence[float], vel_local: Sequence[float],
                             support_side: int, strides: Sequence[float], t_short: float,
                             t_nominal: float, grid: int) -> float:
    """The shortest period in ``[t_short, t_nominal]`` (on a ``grid``) reachable in one step.

    Tries ``[S, nominal L, 0, T - nominal T_DS, nominal T_DS]`` for each ``S`` in ``strides``,
    shortest ``T`` first, with the env's own scalar verdict (:func:`lipm.step_feasible`; the
    answer is usually among the first few periods, so a few scalar checks cost less than one
    batched numpy call); returns the shortest ``T`` feasible for all of them, or ``t_short`` if
    no grid period is (then the PSO has to sort it out).
    """
    t_ds, side_stride = robot.nominal_t_ds, robot.nominal_side_stride
    strides = [float(S) for S in strides]
    for T in np.linspace(t_short, t_nominal, grid).tolist():
        if all(lipm.step_feasible(robot, com_local, vel_local, (S, side_stride, 0.0, T - t_ds, t_ds), support_side)
               for S in strides):
            return T
    return float(t_short)


def stride_window(robot: Robot, com_local: Sequence[float], vel_local: Sequence[float], support_side: int,
                  period: float, max_stride: float, grid: int) -> tuple[float, float] | None:
    """``(lo, hi)`` of the front strides ``S`` in ``[0, max_stride]`` feasible now at ``period``.

    The strides of a ``grid`` on which ``[S, nominal L, 0, period - nominal T_DS, nominal T_DS]``
    is feasible (the env's scalar verdict, :func:`lipm.check_step`). For a straight step the
    ZMP offset is affine in ``S`` (docs/model.md §3) and the kinematic limits on ``S`` are an
    interval, so the feasible strides are one run of the grid, found from its ends: two checks
    when every stride is feasible, a bisection for an end inside the grid, and a scan only while
    no feasible stride is known. ``None`` when none is feasible (the PSO has to sort it out).
    """
    return stride_windows(robot, com_local, vel_local, support_side, [period], max_stride, grid)[0]


def stride_windows(robot: Robot, com_local: Sequence[float], vel_local: Sequence[float], support_side: int,
                   periods: Sequence[float], max_stride: float, grid: int) -> list[tuple[float, float] | None]:
    """:func:`stride_window` for each of ``periods`` [s]."""
    strides = np.linspace(0.0, max_stride, grid).tolist()
    com = complex(float(com_local[0]), float(com_local[1]))
    vel = complex(float(vel_local[0]), float(vel_local[1]))
    side = int(support_side)
    t_ds, side_stride = robot.nominal_t_ds, robot.nominal_side_stride
    last = grid - 1
    out: list[tuple[float, float] | None] = []
    for period in periods:
        t_ss = max(float(period) - t_ds, robot.t_ss[0])
        known: dict[int, bool] = {}

        def ok(k: int, known: dict[int, bool] = known, t_ss: float = t_ss) -> bool:
            if k not in known:
                kin_ok, zmp_ok, *_ = lipm.check_step(robot, com, vel, (strides[k], side_stride, 0.0, t_ss, t_ds), side)
                known[k] = kin_ok and zmp_ok
            return known[k]

        inside = 0 if ok(0) else last if ok(last) else next((k for k in range(1, last) if ok(k)), None)
        if inside is None:
            out.append(None)
            continue
        lo, hi = 0, last
        if not ok(0):  # the run starts in (0, inside]: bisect keeping not ok(a), ok(b)
            a, b = 0, inside
            while b - a > 1:
                mid = (a + b) // 2
                a, b = (a, mid) if ok(mid) else (mid, b)
            lo = b
        if not ok(last):  # the run ends in [inside, last): bisect keeping ok(a), not ok(b)
            a, b = inside, last
            while b - a > 1:
                mid = (a + b) // 2
                a, b = (mid, b) if ok(mid) else (a, mid)
            hi = a
        out.append((strides[lo], strides[hi]))
    return out


_UNKNOWN = object()  # a stride window not yet computed


@dataclass(frozen=True)
class PeriodChoice:
    """Stage 1's record: the walking period and the evidence for it."""

    period: float  # [s] T for the next step
    any_free: bool  # some walk was free at some period tried
    free_walks: tuple[np.ndarray, ...]  # free walks (k + 1, 2) [m] at ``period``, best first
    first_stride: tuple[float, float] | None  # [m] front strides the LIPM accepts now at ``period`` (None: any)
    floor: float  # [s] the lower end of the search (T0)
    nominal_free: bool  # ObstacleCollision(T_n) was false
    evaluations: int  # calls of ObstacleCollision
    waiting_walks: bool  # the period came from the second tier (slower / waiting walks)

    def diagnostics(self) -> dict[str, object]:
        """The record as ``policy.last_info`` entries."""
        return dict(period_search=self.period, period_floor=self.floor, nominal_free=self.nominal_free,
                    search_evaluations=self.evaluations, waiting_walks=self.waiting_walks)


class PeriodSearch:
    """Stage 1 with the parameters of ``configs/planner.yaml`` (sections ``period_search``, ``additions``),
    its walks pursued and checked by the planner's ``kernels``.

    ``vary_period=False`` is the fixed-period planner: ``T = T_n``, only checked.
    """

    def __init__(self, robot: Robot, config: PlannerConfig, kernels: Kernels, vary_period: bool = True) -> None:
        ps, add = config.period_search, config.additions
        self.robot = robot
        self.vary_period = vary_period
        self.t0 = min(ps.t0_s, robot.nominal_period)
        self.iterations = ps.iterations
        self.scan_periods = ps.scan_periods
        self.floor_grid = ps.floor_grid
        self.stride_grid = ps.stride_grid
        self.step_size = config.rrt.step_size_m
        self.edge_samples = config.prediction.edge_samples
        self.horizon = config.prediction.horizon_s
        self.lane_offsets = tuple(ps.rollout_lane_offsets_m)
        self.lookahead = ps.rollout_lookahead_m
        self.depth_slack = ps.rollout_depth_slack
        self.extra_steps = ps.rollout_extra_steps
        self.fan_directions = ps.fan_directions
        self.long_lookahead = add.long_lookahead
        self._windows_of: Snapshot | None = None  # the snapshot whose stride windows are remembered
        self._windows: dict[float, tuple[float, float] | None] = {}
        self._floor_of: Snapshot | None = None  # the snapshot of the floor remembered
        self._floor_value = self.t0
        self.lipm_windows = add.lipm_windows
        # T0 = the shortest period reachable from the CoM state: the paper's text (§2.2) and part of lipm_windows.
        self.t0_reachable = ps.t0_reachable or add.lipm_windows
        self.check_node = config.prediction.check == "node"
        self.centred_period = add.centred_period
        self.kernels = kernels
        waits = tuple(int(w) for w in ps.rollout_wait_steps if w > 0)
        fractions = tuple(ps.rollout_stride_fractions)
        if not self.long_lookahead:
            waits = ()  # one step ahead, a wait cannot be told from a step in place
        # The second tier: walks that slow down or first step in place (none if it would add nothing).
        self.slower_walks: tuple[tuple[int, ...], tuple[float, ...]] | None = (
            ((0, *waits), fractions) if add.waiting_walks and (waits or any(f < 1.0 for f in fractions)) else None)

    def __call__(self, snapshot: Snapshot, start: WalkStart, search_body: BodyCheck) -> PeriodChoice:
        """The period for the next step from ``snapshot`` (walks from ``start``, checked by ``search_body``).

        Algorithm 1 asks whether the robot can go on now at full stride (Fig. 2: the next
        node at Max_step_size); only if no period in ``[T0, T_n]`` lets it, and
        ``additions.waiting_walks`` is on, is the same search repeated with the second tier.
        """
        choice = self._search(snapshot, start, search_body, (0,), (1.0,), second_tier=False)
        if not choice.any_free and self.slower_walks is not None:
            later = self._search(snapshot, start, search_body, *self.slower_walks, second_tier=True)
            if later.any_free:
                return later
        return choice

    def stride_window(self, snapshot: Snapshot, period: float) -> tuple[float, float] | None:
        """Front strides [m] the LIPM accepts for the first step at ``period`` [s] (``None``: not limited).

        Remembered per snapshot and period (the search asks for the same ones several times).
        """
        if not self.lipm_windows:
            return None
        if self._windows_of is not snapshot:
            self._windows_of, self._windows = snapshot, {}
        window = self._windows.get(period, _UNKNOWN)
        if window is _UNKNOWN:
            self.remember_stride_windows(snapshot, [period])
            window = self._windows[period]
        return window

    def remember_stride_windows(self, snapshot: Snapshot, periods: Sequence[float]) -> None:
        """Compute the stride windows of ``periods`` [s] the search is about to ask for (those not known yet)."""
        if not self.lipm_windows:
            return
        if self._windows_of is not snapshot:
            self._windows_of, self._windows = snapshot, {}
        todo = [float(T) for T in periods if float(T) not in self._windows]
        if todo:
            windows = stride_windows(self.robot, snapshot.com_local, snapshot.vel_local, snapshot.support_side, todo,
                                     self.step_size, self.stride_grid)
            self._windows.update(zip(todo, windows))

    def _floor(self, snapshot: Snapshot) -> float:
        """:func:`shortest_feasible_period` from the snapshot (``T0`` made state-dependent; remembered for the
        second tier, which searches the same snapshot)."""
        if self._floor_of is not snapshot:
            strides = (float(snapshot.previous_command[0]), self.step_size)
            self._floor_of, self._floor_value = snapshot, shortest_feasible_period(
                self.robot, snapshot.com_local, snapshot.vel_local, snapshot.support_side, strides, self.t0,
                self.robot.nominal_period, self.floor_grid)
        return self._floor_value

    def walks(self, snapshot: Snapshot, start: WalkStart, search_body: BodyCheck, wait_steps: Sequence[int],
              fractions: Sequence[float]) -> GoalRollouts | NextNodeFan:
        """``ObstacleCollision``: the rollouts (``long_lookahead``) or the paper's one-step fan."""
        window = (lambda T: self.stride_window(snapshot, T)) if self.lipm_windows else None
        common = dict(edge_samples=self.edge_samples, first_stride=window, kernels=self.kernels)
        if not self.long_lookahead:
            return NextNodeFan(search_body, self.robot, start, snapshot.goal, snapshot.goal_tolerance,
                               step_size=self.step_size, stride_fractions=fractions,
                               directions=self.fan_directions, check_node=self.check_node, **common)
        return GoalRollouts(search_body, self.robot, start, snapshot.goal, snapshot.goal_tolerance,
                            horizon=self.horizon, step_size=self.step_size, lane_offsets=self.lane_offsets,
                            stride_fractions=fractions, lookahead=self.lookahead, wait_steps=wait_steps,
                            depth_slack=self.depth_slack, extra_steps=self.extra_steps, **common)

    def _search(self, snapshot: Snapshot, start: WalkStart, search_body: BodyCheck, wait_steps: Sequence[int],
                fractions: Sequence[float], *, second_tier: bool) -> PeriodChoice:
        """One search over one library of walks (``second_tier``: the slower / waiting one)."""
        walks = self.walks(snapshot, start, search_body, wait_steps, fractions)
        t_n = self.robot.nominal_period
        if not self.vary_period:
            free_walks = tuple(walks.free_walks(t_n))
            return PeriodChoice(t_n, bool(free_walks), free_walks, self.stride_window(snapshot, t_n), t_n,
                                bool(free_walks), 1, second_tier)
        floor = self._floor(snapshot) if self.t0_reachable else self.t0
        blocked_at: dict[float, np.ndarray] = {}  # per period scanned, when each walk is first blocked [s]
        if self.centred_period:
            periods = np.linspace(floor, t_n, self.scan_periods)
            self.remember_stride_windows(snapshot, periods)
            blocked_at = dict(zip(periods.tolist(), walks.survival_table(periods)))
            result = centred_free_period(lambda scan: [blocked_at[T].max() for T in scan.tolist()], periods)
        else:
            result = longest_free_period(walks, floor, t_n, self.iterations)
        free_walks = (tuple(walks.free_walks(result.period, blocked_at=blocked_at.get(result.period)))
                      if result.any_free else ())
        return PeriodChoice(result.period, result.any_free, free_walks,
                            self.stride_window(snapshot, result.period), floor, result.nominal_free,
                            result.evaluations, second_tier)
