"""Stage 1 (:mod:`footstep_gym.planners.period_search`): :func:`longest_free_period` (Algorithm 1 as its text
describes it) on hand-made monotone predicates ``collides(T) = T > T*`` whose answer ``T*`` is known; the
centred scan (:func:`centred_free_period`) on hand-made windows of free periods; the stage's record.

The stage's body checks written here are not :class:`~footstep_gym.planners.prediction.BodyModel` s: the stage
runs with the numpy kernels (:data:`NUMPY`, ``kernels.compiled: false``), which take any body check.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym.kernels import select_kernels
from footstep_gym.planners.params import load_planner_config
from footstep_gym.planners.period_search import PeriodSearch, centred_free_period, longest_free_period, stride_windows
from footstep_gym.planners.registry import PAPER
from footstep_gym.planners.walks import walk_start
from planner_helpers import EPS, ZMP_TIE_MARGIN, zmp_edge_gaps

#: The numpy kernels (the compiled ones need a BodyModel's shape table).
NUMPY = select_kernels(False)

T0, TN = 0.3, 0.8


@pytest.mark.parametrize("iterations", [1, 4, 6, 10])
@pytest.mark.parametrize("t_star", [0.31, 0.42, 0.55, 0.5499, 0.7, 0.79])
@pytest.mark.parametrize("strict", [True, False])
def test_binary_search_finds_boundary_inside(t_star, iterations, strict):
    calls = []

    def collides(t):
        calls.append(t)
        return t > t_star if strict else t >= t_star

    res = longest_free_period(collides, T0, TN, iterations)
    assert res.evaluations == len(calls) == 2 + iterations
    assert not res.nominal_free and res.any_free
    # on the free side of the boundary, within the promised resolution
    assert not collides(res.period)
    assert res.period <= t_star + EPS
    assert t_star - res.period <= (TN - T0) / 2 ** iterations + EPS
    assert T0 <= res.period <= TN
    # every evaluated period lies in [T0, T_n]
    assert all(T0 - EPS <= t <= TN + EPS for t in calls)


@pytest.mark.parametrize("t_star", [0.8, 0.9, 5.0])
def test_binary_search_nominal_free_returns_nominal(t_star):
    calls = []

    def collides(t):
        calls.append(t)
        return t > t_star

    res = longest_free_period(collides, T0, TN, 6)
    assert res.period == TN
    assert res.nominal_free and res.any_free
    assert res.evaluations == len(calls) == 1


@pytest.mark.parametrize("t_star", [0.0, 0.1, 0.2999])
def test_binary_search_nothing_free_returns_t_short(t_star):
    calls = []

    def collides(t):
        calls.append(t)
        return t > t_star

    res = longest_free_period(collides, T0, TN, 6)
    assert res.period == T0
    assert not res.nominal_free and not res.any_free
    assert res.evaluations == len(calls) == 2


def test_binary_search_resolution_improves_with_iterations():
    """The error halves per pass (until the boundary is hit exactly)."""
    t_star = 0.3 + 0.5 / math.pi  # not on any dyadic grid point of [0.3, 0.8]
    errors = [t_star - longest_free_period(lambda t: t > t_star, T0, TN, n).period for n in range(1, 16)]
    assert all(0.0 <= e <= (TN - T0) / 2 ** n + EPS for n, e in zip(range(1, 16), errors))
    assert errors[-1] < 2e-5


def test_binary_search_degenerate_interval():
    assert longest_free_period(lambda t: False, 0.5, 0.5, 6).period == 0.5
    assert longest_free_period(lambda t: True, 0.5, 0.5, 6).period == 0.5


def test_binary_search_rejects_inverted_interval():
    with pytest.raises(ValueError):
        longest_free_period(lambda t: False, 0.9, 0.8, 6)


# ====================================================================== the stage: PeriodSearch -> PeriodChoice
class Closes:
    """Body check blocking every point at times ``t > at`` [s]."""

    def __init__(self, at):
        self.at = at

    def free(self, points, times, normals, period):
        return np.asarray(times, dtype=float).reshape(-1) <= self.at


class Zone:
    """Blocks points with ``x0 <= x <= x1`` while ``t < until`` [s] (a crossing that clears at ``until``)."""

    def __init__(self, x0, x1, until):
        self.x0, self.x1, self.until = x0, x1, until

    def free(self, points, times, normals, period):
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        t = np.asarray(times, dtype=float).reshape(-1)
        return ~((p[:, 0] >= self.x0) & (p[:, 0] <= self.x1) & (t < self.until))


@pytest.fixture(scope="module")
def crossing_start():
    """The first snapshot of the crossing (robot near the origin, goal at (1.9, 0)) and its walk start."""
    env = gym.make("FootstepCrossing-v0")
    env.reset(seed=0)
    snap = env.unwrapped.sensing()
    robot = env.unwrapped.robot
    env.close()
    return robot, snap, walk_start(snap, 0.5 * robot.nominal_side_stride)


def paper_search(robot, vary_period=True):
    """Algorithm 1 with every addition off and T0 fixed at period_search.t0_s (T0 = 0.3 s: the bisection's bounds known)."""
    defaults = {"additions": PAPER, "period_search": {"t0_reachable": False}}
    return PeriodSearch(robot, load_planner_config(defaults=defaults), NUMPY, vary_period=vary_period)


@pytest.mark.parametrize("t_star", [0.42, 0.55, 0.7])
def test_paper_search_returns_the_longest_period_whose_next_node_is_free(crossing_start, t_star):
    """Fig. 2: the next node is checked over one step; everything closes at t*, so T is free iff T <= t*.
    The paper's T0 is the configured one (no LIPM floor): the search runs on [0.3, 0.8] with N passes."""
    robot, snap, start = crossing_start
    search = paper_search(robot)
    choice = search(snap, start, Closes(t_star))
    n = load_planner_config().period_search.iterations
    assert choice.floor == T0
    assert t_star - (TN - T0) / 2 ** n - EPS <= choice.period <= t_star + EPS
    assert choice.any_free and not choice.nominal_free and not choice.waiting_walks
    assert choice.evaluations == 2 + n
    assert choice.first_stride is None  # no LIPM window in the paper's planner
    assert choice.free_walks and all(w.shape == (2, 2) for w in choice.free_walks)


def test_paper_search_keeps_nominal_when_free_and_t0_when_nothing_is(crossing_start):
    robot, snap, start = crossing_start
    free = paper_search(robot)(snap, start, Closes(np.inf))
    assert (free.period, free.nominal_free, free.evaluations) == (TN, True, 1)
    blocked = paper_search(robot)(snap, start, Closes(-1.0))
    assert (blocked.period, blocked.any_free, blocked.free_walks, blocked.evaluations) == (T0, False, (), 2)


def test_paper_fixed_period_only_checks_the_nominal_period(crossing_start):
    robot, snap, start = crossing_start
    search = paper_search(robot, vary_period=False)
    assert search(snap, start, Closes(1.0)).period == TN
    closed = search(snap, start, Closes(0.5))
    assert (closed.period, closed.any_free, closed.evaluations) == (TN, False, 1)


def test_second_tier_finds_a_waiting_walk_when_no_period_clears_the_way(crossing_start):
    """A zone 0.1-0.6 m ahead stays blocked for 4 s: walking off at once meets it at any period; waiting six
    nominal steps (4.8 s) lets it clear. With the switch off the search gives up at the shortest period."""
    robot, snap, start = crossing_start
    zone = Zone(0.1, 0.6, 4.0)
    on = PeriodSearch(robot, load_planner_config(), NUMPY)
    choice = on(snap, start, zone)
    assert choice.any_free and choice.waiting_walks
    steps = np.linalg.norm(np.diff(choice.free_walks[0], axis=0), axis=1)
    assert np.all(steps[:3] == 0.0)  # the best free walk first steps in place
    off = PeriodSearch(robot, load_planner_config({"additions_waiting_walks": False}), NUMPY)
    blocked = off(snap, start, zone)
    assert not blocked.any_free and not blocked.waiting_walks and blocked.period == blocked.floor


@pytest.mark.parametrize("compiled", [True, False])
def test_the_stage_checks_its_walks_with_the_kernels_it_is_given(crossing_start, compiled):
    """The stage's kernels reach the walks (rollouts and the paper's fan); the compiled kernels refuse a body check
    that is not a BodyModel instead of falling back to numpy."""
    robot, snap, start = crossing_start
    kernels = select_kernels(compiled)
    for defaults in ({}, {"additions": PAPER}):
        search = PeriodSearch(robot, load_planner_config(defaults=defaults), kernels)
        if compiled:
            with pytest.raises(TypeError, match="need a prediction.BodyModel"):
                search(snap, start, Closes(np.inf))
        else:
            assert search.walks(snap, start, Closes(np.inf), (0,), (1.0,)).kernels is NUMPY
            assert search(snap, start, Closes(np.inf)).nominal_free


def window(lo, hi, blocked_at=1.0):
    """``survival(T)``: free (inf) for ``lo <= T <= hi``, else blocked after ``blocked_at(T)`` seconds."""
    return lambda T: math.inf if lo <= T <= hi else (blocked_at(T) if callable(blocked_at) else blocked_at)


@pytest.mark.parametrize("iterations", [3, 4, 6])
@pytest.mark.parametrize("lo,hi", [(0.45, 0.6), (0.3, 0.55), (0.5, 0.8), (0.6, 0.62)])
def test_centred_scan_takes_the_middle_of_the_free_window(lo, hi, iterations):
    """A crowd's window: too quick runs into the member ahead, too slow is caught from behind."""
    calls = []
    survival = window(lo, hi)
    grid = np.linspace(T0, TN, 2 ** iterations + 1)
    res = centred_free_period(lambda Ts: [calls.append(T) or survival(T) for T in Ts], grid)
    inside = grid[(grid >= lo) & (grid <= hi)]
    assert res.any_free and res.evaluations == len(calls) == grid.size
    np.testing.assert_allclose(sorted(calls), grid)
    assert lo <= res.period <= hi  # free
    # the middle of the free grid periods: as many (give or take one) on either side
    below, above = np.sum(inside < res.period - EPS), np.sum(inside > res.period + EPS)
    assert abs(int(above) - int(below)) <= 1
    assert res.nominal_free == (hi >= TN)


def test_centred_scan_keeps_to_the_window_of_the_longest_free_period():
    """Two windows: the one that holds the longest free period is taken, as the bisection would."""
    survival = lambda T: math.inf if (0.3 <= T <= 0.35 or 0.6 <= T <= 0.7) else 2.0  # noqa: E731
    res = centred_free_period(lambda Ts: [survival(T) for T in Ts], np.linspace(T0, TN, 17))
    assert 0.6 <= res.period <= 0.7
    # where the bisection, whose predicate is assumed monotone, ends at the window's edge
    assert longest_free_period(lambda T: math.isfinite(survival(T)), T0, TN, 4).period != res.period


@pytest.mark.parametrize("blocked_at", [1.0, lambda T: 3.0 * T, lambda T: 5.0 - T])
def test_centred_scan_with_nothing_free_walks_as_fast_as_allowed(blocked_at):
    survival = window(2.0, 3.0, blocked_at)
    res = centred_free_period(lambda Ts: [survival(T) for T in Ts], np.linspace(T0, TN, 17))
    assert res.period == T0 and not res.any_free and not res.nominal_free


@pytest.mark.parametrize("start_period", [0.8, 0.4])
def test_stride_windows_of_a_scan_match_the_scalar_lipm(start_period):
    """The scan's stride windows (found from the ends of the run of feasible strides) against the scalar
    check of every command of the grid: the shortest and longest front stride the LIPM accepts at each period."""
    from footstep_gym import footstep, lipm
    from footstep_gym.robot import load_robot

    robot = load_robot()
    t_ds = robot.nominal_t_ds
    command = (0.08, robot.nominal_side_stride, 0.0, start_period - t_ds, t_ds)
    com, vel = lipm.steady_state(robot, command, footstep.RIGHT)
    periods = np.linspace(0.3, 0.8, 17)
    got = stride_windows(robot, (com.real, com.imag), (vel.real, vel.imag), footstep.RIGHT, periods, 0.1, 11)
    strides = np.linspace(0.0, 0.1, 11)
    for T, window in zip(periods, got):
        ok = [all(lipm.check_step(robot, com, vel, (S, robot.nominal_side_stride, 0.0, max(T - t_ds, robot.t_ss[0]),
                                                       t_ds), footstep.RIGHT)[:2]) for S in strides]
        want = (strides[ok.index(True)], strides[len(ok) - 1 - ok[::-1].index(True)]) if any(ok) else None
        assert window == (pytest.approx(want) if want is not None else None), (T, window, want)
    assert any(w is None or w != (0.0, 0.1) for w in got)  # the LIPM limits some period from this state


def test_centred_scan_rejects_a_grid_that_is_not_ascending():
    with pytest.raises(ValueError, match="ascending"):
        centred_free_period(lambda Ts: [math.inf] * len(Ts), np.array([0.8, 0.3]))
    with pytest.raises(ValueError, match="non-empty"):
        centred_free_period(lambda Ts: [], np.array([]))


def test_the_stage_scans_the_configured_periods_from_the_reachable_floor(crossing_start):
    """``scan_periods`` periods from the LIPM's floor to T_n, every one asked once."""
    robot, snap, start = crossing_start
    config = load_planner_config()
    choice = PeriodSearch(robot, config, NUMPY)(snap, start, Closes(np.inf))
    assert choice.evaluations == config.period_search.scan_periods
    assert choice.any_free and choice.nominal_free
    grid = np.linspace(choice.floor, TN, config.period_search.scan_periods)
    assert choice.period == pytest.approx(grid[(grid.size) // 2])  # all free: the middle of the whole range


@pytest.mark.parametrize("seed", range(4))
def test_floor_is_the_shortest_grid_period_the_batched_lipm_accepts(seed):
    """:func:`shortest_feasible_period` (scalar checks, shortest period first) against one batched
    :func:`lipm.check_steps` of every grid period and stride, from CoM states after random feasible steps.

    Two routes (``math`` against numpy's SIMD kernels), compared exactly on any CPU: no ZMP offset lies within
    ``ZMP_TIE_MARGIN`` of the stable region's edge, where their few-ulp difference could flip a verdict."""
    from footstep_gym import footstep, lipm
    from footstep_gym.planners.period_search import shortest_feasible_period
    from footstep_gym.robot import load_robot

    robot = load_robot()
    rng = np.random.default_rng(seed)
    t_ds = robot.nominal_t_ds
    grid = np.linspace(0.3, 0.8, 11)
    floors = set()
    for _ in range(25):
        period = rng.uniform(0.3, 0.8)
        side = footstep.LEFT if rng.random() < 0.5 else footstep.RIGHT
        com, vel = lipm.steady_state(robot, (rng.uniform(0.0, 0.1), robot.nominal_side_stride, 0.0, period - t_ds,
                                             t_ds), side)
        com, vel = (com.real, com.imag), (vel.real, vel.imag)
        strides = (rng.uniform(0.0, 0.1), 0.1)
        cmd = np.array([[S, robot.nominal_side_stride, 0.0, T - t_ds, t_ds] for S in strides for T in grid])
        batched = lipm.check_steps(robot, com, vel, cmd, side)
        assert zmp_edge_gaps(robot, batched).min() > ZMP_TIE_MARGIN
        ok = batched.feasible.reshape(2, grid.size).all(axis=0)
        want = float(grid[np.argmax(ok)]) if ok.any() else 0.3
        got = shortest_feasible_period(robot, com, vel, side, strides, 0.3, 0.8, 11)
        assert got == want
        floors.add(got)
    assert len(floors) > 1  # the states differ in the periods they can reach


@pytest.mark.parametrize("seed", range(3))
def test_stride_windows_match_the_batched_lipm_on_the_whole_grid(seed):
    """Windows from random CoM states (many of them partial or empty) against one batched
    :func:`lipm.check_steps` of every stride and period of the grid: the feasible strides are one run
    (what lets the windows be found from its ends), and the windows are that run's first and last stride.

    The scalar and the batched verdicts exactly, on any CPU: no ZMP offset within ``ZMP_TIE_MARGIN`` of the
    stable region's edge."""
    from footstep_gym import footstep, lipm
    from footstep_gym.robot import load_robot

    robot = load_robot()
    rng = np.random.default_rng(seed)
    t_ds = robot.nominal_t_ds
    periods = np.linspace(0.3, 0.8, 9)
    strides = np.linspace(0.0, 0.1, 11)
    kinds = set()
    for _ in range(40):  # steady gaits of random commands, the velocity pushed a little
        side = footstep.LEFT if rng.random() < 0.5 else footstep.RIGHT
        c, v = lipm.steady_state(robot, (rng.uniform(0.0, 0.1), robot.nominal_side_stride, 0.0,
                                         rng.uniform(0.3, 0.8) - t_ds, t_ds), side)
        com = np.array([c.real, c.imag])
        vel = np.array([v.real, v.imag]) + rng.normal(0.0, 0.05, 2)
        got = stride_windows(robot, com, vel, side, periods, 0.1, 11)
        cmd = np.array([[S, robot.nominal_side_stride, 0.0, max(T - t_ds, robot.t_ss[0]), t_ds]
                        for T in periods for S in strides])
        batched = lipm.check_steps(robot, com, vel, cmd, side)
        assert zmp_edge_gaps(robot, batched).min() > ZMP_TIE_MARGIN
        ok = batched.feasible.reshape(periods.size, strides.size)
        for row, window in zip(ok, got):
            idx = np.flatnonzero(row)
            if idx.size == 0:
                assert window is None
                kinds.add("empty")
                continue
            assert np.all(row[idx[0]: idx[-1] + 1])  # one run
            assert window == (strides[idx[0]], strides[idx[-1]])
            kinds.add("full" if window == (0.0, 0.1) else "partial")
    assert kinds == {"empty", "full", "partial"}
