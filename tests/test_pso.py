"""Stage 3: :func:`minimise` on a shifted sphere whose minimiser is known, and :func:`repair_command` on
commands whose (in)feasibility is decided independently by :func:`lipm.check_steps` from docs/model.md §3's
steady gaits, within Table 1's ranges (written here as the paper prints them, not read from the config).
"""

from __future__ import annotations

import numpy as np
import pytest

from footstep_gym import lipm
from footstep_gym.planners.params import load_planner_config
from footstep_gym.planners.pso import minimise, repair_command
from planner_helpers import LEFT, PSO_SETTINGS, RIGHT, TABLE1_HIGH, TABLE1_LOW, angle_limits, robot  # noqa: F401

def shifted_sphere(centre, calls):
    centre = np.asarray(centre, dtype=float)

    def f(x):
        calls.append(np.array(x, copy=True))
        return ((x - centre) ** 2).sum(axis=1)

    return f


PSO_ARGS = dict(particles=30, iterations=150, inertia=0.7, c1=1.5, c2=1.5)


def test_pso_finds_shifted_sphere_minimum():
    centre = np.array([0.3, -0.7, 1.2, -0.1, 0.05])
    low, high = -2.0 * np.ones(5), 2.0 * np.ones(5)
    calls = []
    res = minimise(shifted_sphere(centre, calls), low, high, np.random.default_rng(0), **PSO_ARGS)
    np.testing.assert_allclose(res.x, centre, atol=1e-3)
    assert res.value == pytest.approx(float(((res.x - centre) ** 2).sum()))
    assert res.value < 1e-6
    # once per iteration with the whole swarm, plus the initial swarm
    assert len(calls) == PSO_ARGS["iterations"] + 1 == res.iterations + 1
    assert all(c.shape == (PSO_ARGS["particles"], 5) for c in calls)
    assert res.evaluations == PSO_ARGS["particles"] * len(calls)
    X = np.concatenate(calls)
    assert np.all(X >= low) and np.all(X <= high)


def test_pso_respects_bounds_and_fixed_dimensions():
    """Centre outside the box: the minimiser is the centre clipped to the box; low == high stays put."""
    centre = np.array([0.5, 3.0, -3.0, 0.2, 0.9])
    low = np.array([-1.0, -1.0, -1.0, 0.4, -0.5])
    high = np.array([1.0, 1.0, 1.0, 0.4, 0.5])  # dimension 3 fixed at 0.4
    calls = []
    res = minimise(shifted_sphere(centre, calls), low, high, np.random.default_rng(1), **PSO_ARGS)
    expected = np.clip(centre, low, high)
    np.testing.assert_allclose(res.x, expected, atol=1e-3)
    X = np.concatenate(calls)
    assert np.all(X >= low) and np.all(X <= high)
    assert np.all(X[:, 3] == 0.4)
    assert res.x[3] == 0.4
    assert res.value == pytest.approx(float(((expected - centre) ** 2).sum()), abs=1e-5)


def test_pso_seeds_are_in_the_initial_swarm():
    calls = []
    seed = np.array([[0.1, 0.2, 0.3, 0.4, 0.5]])
    minimise(shifted_sphere(np.zeros(5), calls), -np.ones(5), np.ones(5), np.random.default_rng(0),
             particles=10, iterations=2, inertia=0.7, c1=1.5, c2=1.5, seeds=seed)
    np.testing.assert_array_equal(calls[0][0], seed[0])


def test_pso_patience_stops_early():
    calls = []

    def flat(x):
        calls.append(x.shape)
        return np.zeros(len(x))

    res = minimise(flat, -np.ones(3), np.ones(3), np.random.default_rng(0), particles=8, iterations=100,
                   inertia=0.7, c1=1.5, c2=1.5, patience=5)
    assert res.iterations == 5 and len(calls) == 6
    assert res.evaluations == 8 * 6


def test_pso_is_replayable_and_seed_dependent():
    """The same seed, the same swarm bit for bit (the same code on the same inputs: on any CPU)."""
    centre = np.array([0.3, -0.7, 1.2, -0.1, 0.05])
    args = dict(PSO_ARGS, iterations=10)
    runs = []
    for seed in (4, 4, 5):
        calls = []
        res = minimise(shifted_sphere(centre, calls), -2 * np.ones(5), 2 * np.ones(5),
                       np.random.default_rng(seed), **args)
        runs.append((res, np.concatenate(calls)))
    np.testing.assert_array_equal(runs[0][0].x, runs[1][0].x)
    np.testing.assert_array_equal(runs[0][1], runs[1][1])
    assert runs[0][0].value == runs[1][0].value
    assert not np.array_equal(runs[0][1], runs[2][1])


def test_pso_rejects_empty_box():
    with pytest.raises(ValueError):
        minimise(lambda x: x.sum(axis=1), [0.0, 1.0], [1.0, 0.5], np.random.default_rng(0), **PSO_ARGS)


# ---------------------------------------------------------------------- repair_command
STEADY = (0.05, 0.08, 0.0, 0.6, 0.2)  # docs/model.md §3: walking at S = 5 cm, nominal L, T_SS 0.6, T_DS 0.2


def steady_gait(robot, side):
    com, vel = lipm.steady_state(robot, STEADY, side)
    return (com.real, com.imag), (vel.real, vel.imag)


def verdict(robot, com, vel, command, side):
    return bool(lipm.check_steps(robot, com, vel, np.asarray(command, float)[None], side).feasible[0])


def repair(robot, com, vel, side, reference, seed):
    return repair_command(robot, com, vel, side, reference, np.random.default_rng(seed),
                          delta_low=TABLE1_LOW, delta_high=TABLE1_HIGH, **PSO_SETTINGS)


def test_config_pso_ranges_are_table1():
    from footstep_gym.planners.params import load_planner_config

    lo, hi = load_planner_config().pso.delta_bounds()
    np.testing.assert_allclose(lo, TABLE1_LOW)
    np.testing.assert_allclose(hi, TABLE1_HIGH)


@pytest.mark.parametrize("side", [RIGHT, LEFT])
def test_design_period_cut_figures(robot, side):
    """docs/model.md §3: from the 5 cm steady gait, T_SS 0.6 -> 0.2 s is feasible, -> 0.1 s is not."""
    com, vel = steady_gait(robot, side)
    assert verdict(robot, com, vel, STEADY, side)
    assert verdict(robot, com, vel, (0.05, 0.08, 0.0, 0.2, 0.2), side)
    assert not verdict(robot, com, vel, (0.05, 0.08, 0.0, 0.1, 0.2), side)


#: Commands from the 5 cm steady gait that lipm rejects, with a repair inside Table 1 known
#: here by a 1-D search (see test_known_repairs_exist): cutting T_SS to 0.16 s leaves the
#: lateral ZMP ~1 mm outside the stable region (a slightly narrower L or longer T_DS fixes it).
REPAIRABLE = [(0.05, 0.08, 0.0, 0.16, 0.2), (0.05, 0.08, 0.0, 0.18, 0.12), (0.07, 0.09, 0.05, 0.17, 0.2)]


def known_repair(robot, com, vel, side, reference):
    """The shortest single-axis increment (on a fine grid within Table 1) that makes ``reference`` feasible."""
    best = None
    ref = np.asarray(reference, dtype=float)
    for k in range(5):
        for bound in (max(TABLE1_LOW[k], robot.command_low[k] - ref[k]),
                      min(TABLE1_HIGH[k], robot.command_high[k] - ref[k])):
            steps = np.linspace(0.0, bound, 401)[1:]
            cmds = np.tile(ref, (steps.size, 1))
            cmds[:, k] += steps
            ok = lipm.check_steps(robot, com, vel, cmds, side).feasible
            if ok.any():
                d = abs(steps[np.argmax(ok)])
                if best is None or d < best:
                    best = d
    return best


@pytest.mark.parametrize("side", [RIGHT, LEFT])
@pytest.mark.parametrize("reference", REPAIRABLE)
def test_known_repairs_exist(robot, side, reference):
    com, vel = steady_gait(robot, side)
    assert not verdict(robot, com, vel, reference, side)
    assert known_repair(robot, com, vel, side, reference) is not None


@pytest.mark.parametrize("side", [RIGHT, LEFT])
@pytest.mark.parametrize("reference", REPAIRABLE)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_repair_makes_infeasible_command_feasible(robot, side, reference, seed):
    com, vel = steady_gait(robot, side)
    ref = np.asarray(reference, dtype=float)
    assert not verdict(robot, com, vel, ref, side)
    out = repair(robot, com, vel, side, ref, seed)
    # feasible, by an independent LIPM check of the returned command
    assert out.feasible
    assert verdict(robot, com, vel, out.command, side)
    # every increment inside Table 1's ranges
    delta = out.command - ref
    assert np.all(delta >= TABLE1_LOW - 1e-12) and np.all(delta <= TABLE1_HIGH + 1e-12), delta
    # inside the robot's own limits (action box, side-dependent turn)
    assert np.all(out.command >= robot.command_low - 1e-12) and np.all(out.command <= robot.command_high + 1e-12)
    lo, hi = angle_limits(side, robot)
    assert lo - 1e-12 <= out.command[2] <= hi + 1e-12
    # close to the least change (eq. 7): not far from a known single-axis repair
    known = known_repair(robot, com, vel, side, ref)
    assert np.linalg.norm(delta) <= 2.5 * known + 1e-4, (np.linalg.norm(delta), known)


@pytest.mark.parametrize("side", [RIGHT, LEFT])
def test_repair_honours_given_increment_ranges(robot, side):
    """Only dT_DS in [0, 0.05] s allowed: the repair lengthens T_DS by about the known 19 ms, nothing else."""
    com, vel = steady_gait(robot, side)
    ref = np.array([0.05, 0.08, 0.0, 0.16, 0.2])
    # independently: the shortest dT_DS that makes it feasible, on a 0.1 ms grid
    grid = np.arange(0.0, 0.05, 1e-4)
    cmds = np.tile(ref, (grid.size, 1))
    cmds[:, 4] += grid
    ok = lipm.check_steps(robot, com, vel, cmds, side).feasible
    assert not ok[0] and ok.any()
    needed = grid[np.argmax(ok)]
    low, high = np.zeros(5), np.array([0.0, 0.0, 0.0, 0.0, 0.05])
    out = repair_command(robot, com, vel, side, ref, np.random.default_rng(0), delta_low=low, delta_high=high,
                         **PSO_SETTINGS)
    assert out.feasible and verdict(robot, com, vel, out.command, side)
    np.testing.assert_array_equal(out.command[:4], ref[:4])  # increments of [0, 0]: unchanged on any CPU
    assert needed - 1e-4 <= out.command[4] - ref[4] <= 0.05
    assert out.command[4] - ref[4] <= needed + 0.005  # near the least change


@pytest.mark.parametrize("side", [RIGHT, LEFT])
@pytest.mark.parametrize("reference", [STEADY, (0.05, 0.08, 0.0, 0.2, 0.2), (0.08, 0.1, 0.0, 0.6, 0.2),
                                       (0.0, 0.08, 0.0, 0.6, 0.2)])
def test_repair_leaves_feasible_command_unchanged(robot, side, reference):
    com, vel = steady_gait(robot, side)
    assert verdict(robot, com, vel, reference, side)
    out = repair(robot, com, vel, side, reference, 0)
    assert out.feasible
    # the PSO's seed, no increment, is the only zero of eq. 7: the reference comes back as given, on any CPU
    np.testing.assert_array_equal(out.command, np.asarray(reference, dtype=float))
    assert out.pso.value == 0.0


@pytest.mark.parametrize("side", [RIGHT, LEFT])
def test_repair_flag_matches_lipm_when_not_repairable(robot, side):
    """T_SS 0.6 -> 0.1 s at once cannot be repaired by Table 1's increments (dT_SS <= 0)."""
    com, vel = steady_gait(robot, side)
    ref = np.array([0.05, 0.08, 0.0, 0.1, 0.2])
    out = repair(robot, com, vel, side, ref, 0)
    assert out.feasible == verdict(robot, com, vel, out.command, side)
    delta = out.command - ref
    assert np.all(delta >= TABLE1_LOW - 1e-12) and np.all(delta <= TABLE1_HIGH + 1e-12)


# ====================================================================== stage 3's unit
def test_command_repair_runs_the_pso_only_when_infeasible(robot):
    """:class:`CommandRepair`: a feasible reference passes unchanged (no PSO); an infeasible one comes back
    feasible within Table 1's increments; with ``vary_period=False`` the period is left alone."""
    from types import SimpleNamespace

    from footstep_gym.planners.pso import CommandRepair

    side = RIGHT
    com, vel = steady_gait(robot, side)
    snap = SimpleNamespace(com_local=com, vel_local=vel, support_side=side)
    params = load_planner_config().pso
    stage = CommandRepair(robot, params)
    same = stage(snap, np.asarray(STEADY), np.random.default_rng(0))
    assert same.feasible_before and same.pso is None
    np.testing.assert_array_equal(same.command, STEADY)
    ref = np.asarray(REPAIRABLE[0])
    fixed = ref.copy()
    out = stage(snap, ref, np.random.default_rng(0))
    assert not out.feasible_before and out.pso is not None and out.feasible
    assert verdict(robot, com, vel, out.command, side)
    delta = out.command - ref
    assert np.all(delta >= TABLE1_LOW - 1e-12) and np.all(delta <= TABLE1_HIGH + 1e-12)
    still = CommandRepair(robot, params, vary_period=False)(snap, fixed, np.random.default_rng(0))
    assert still.pso is not None
    np.testing.assert_array_equal(still.command[3:], fixed[3:])


@pytest.mark.parametrize("side", [RIGHT, LEFT])
@pytest.mark.parametrize("seed", [0, 1])
def test_rescue_finds_a_feasible_command_where_table1_cannot(robot, side, seed):
    """Switch ``feasibility_rescue``: T_SS 0.6 -> 0.1 s at once is beyond Table 1's reach (dT_SS <= 0 cannot
    lengthen it back); the rescue's PSO over the whole command box returns a feasible command (checked by
    the LIPM here), inside the robot's limits; without the rescue the stage returns an infeasible one."""
    from types import SimpleNamespace

    from footstep_gym.planners.pso import CommandRepair

    com, vel = steady_gait(robot, side)
    snap = SimpleNamespace(com_local=com, vel_local=vel, support_side=side)
    params = load_planner_config().pso
    ref = np.array([0.05, 0.08, 0.0, 0.1, 0.2])
    plain = CommandRepair(robot, params)(snap, ref, np.random.default_rng(seed))
    assert not plain.feasible and not plain.rescued and not verdict(robot, com, vel, plain.command, side)
    out = CommandRepair(robot, params, rescue=True)(snap, ref, np.random.default_rng(seed))
    assert out.rescued and out.feasible and verdict(robot, com, vel, out.command, side)
    assert np.all(out.command >= robot.command_low - 1e-12) and np.all(out.command <= robot.command_high + 1e-12)
    lo, hi = angle_limits(side, robot)
    assert lo - 1e-12 <= out.command[2] <= hi + 1e-12
    assert out.command[3] > ref[3]  # it lengthened the single support, which Table 1 forbids
    # the fixed-period planner's rescue leaves the period alone
    fixed = CommandRepair(robot, params, vary_period=False, rescue=True)(snap, ref, np.random.default_rng(seed))
    np.testing.assert_array_equal(fixed.command[3:], ref[3:])
