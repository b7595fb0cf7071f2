"""The LIPM pattern generator (footstep_gym/lipm.py) against independent references.

Every closed form is checked against scipy's numerical integration of the pendulum
``c'' = omega^2 (c - p(t))`` (docs/model.md §3), the steady gait against the per-axis
2x2 fixed-point formulas, and the generator's verdicts against the figures of docs/model.md §3.

The scalar path (``math``, ``cmath``: libm) and the batched one (numpy, whose ``exp``, ``expm1``, ``cosh``,
``sinh`` and complex products take SIMD kernels chosen per CPU at run time) agree to a few ulps, not bit for
bit, on any CPU: their floats are compared with tolerances, their verdicts exactly with no ZMP offset near a tie
(``ZMP_TIE_MARGIN``).
"""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from footstep_gym import footstep, lipm
from footstep_gym.robot import load_robot
from planner_helpers import ZMP_TIE_MARGIN, zmp_edge_gaps

RTOL_ODE, ATOL_ODE = 1e-10, 1e-12


@pytest.fixture(scope="module")
def robot():
    return load_robot()


# ------------------------------------------------------------------ independent reference
def integrate(c0, v0, zmp, breaks, omega, t_eval=None):
    """Integrate ``c'' = omega^2 (c - zmp(t))`` in 2D (complex c0, v0) with solve_ivp.

    ``zmp(t)`` is complex; ``breaks`` are the times ``[0, t1, ..., T]`` where ``zmp`` has a
    kink (integrated piece by piece so that no adaptive step straddles one). Returns
    ``(c, v)`` complex at ``breaks[-1]`` or, with ``t_eval``, arrays at those times
    (from each piece's dense output).
    """
    w2 = omega ** 2

    def rhs(t, y):
        p = zmp(t)
        return [y[2], y[3], w2 * (y[0] - p.real), w2 * (y[1] - p.imag)]

    y = np.array([c0.real, c0.imag, v0.real, v0.imag], dtype=float)
    out = []
    for k, (a, b) in enumerate(zip(breaks[:-1], breaks[1:])):
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=RTOL_ODE, atol=ATOL_ODE,
                        dense_output=t_eval is not None)
        assert sol.success, sol.message
        if t_eval is not None:
            t_eval = np.asarray(t_eval, dtype=float)
            last = k == len(breaks) - 2
            sel = t_eval[(t_eval >= a) & ((t_eval <= b) if last else (t_eval < b))]
            out.append(sol.sol(sel) if sel.size else np.empty((4, 0)))
        y = sol.y[:, -1]
    if t_eval is None:
        return complex(y[0], y[1]), complex(y[2], y[3])
    ys = np.concatenate(out, axis=1)
    return ys[0] + 1j * ys[1], ys[2] + 1j * ys[3]


def integrate_1d(c0, v0, zmp, T, omega):
    """Scalar ODE ``c'' = w^2 (c - zmp(t))`` from 0 to T; returns (c, v)."""
    sol = solve_ivp(lambda t, y: [y[1], omega ** 2 * (y[0] - zmp(t))], (0.0, T), [c0, v0],
                    method="DOP853", rtol=RTOL_ODE, atol=ATOL_ODE)
    assert sol.success
    return sol.y[0, -1], sol.y[1, -1]


def step_zmp(p, q, t_ss, t_ds):
    """Nominal-with-offset ZMP schedule of one step: p during T_SS, then linear p -> q."""
    def zmp(t):
        if t <= t_ss:
            return complex(p)
        return p + (q - p) * min(t - t_ss, t_ds) / t_ds
    return zmp


def ode_step(robot, com, vel, command, support_side, p):
    """End state of one step by ODE integration, relative to the new foot in its frame."""
    S, L, theta, t_ss, t_ds = command
    q = S + 1j * (-support_side) * L
    c, v = integrate(complex(com), complex(vel), step_zmp(p, q, t_ss, t_ds), [0.0, t_ss, t_ss + t_ds],
                     robot.omega)
    rot = cmath.exp(-1j * theta)
    return (c - q) * rot, v * rot


def random_command(rng, robot, both_sides=True, theta=True):
    """A random command inside the action box, kinematically feasible for both sides."""
    lo, hi = robot.command_low, robot.command_high
    while True:
        cmd = rng.uniform(lo, hi)
        if not theta:
            cmd[2] = 0.0
        sides = (1, -1) if both_sides else (1,)
        if all(footstep.kinematically_feasible(cmd, s, robot) for s in sides):
            return cmd


# ------------------------------------------------------------------ 1. closed forms vs ODE
@pytest.mark.parametrize("T", [0.05, 0.2, 0.6, 1.0])
def test_constant_zmp_matches_ode(robot, T):
    rng = np.random.default_rng(1)
    w = robot.omega
    for _ in range(4):
        c0, v0, p = rng.uniform(-0.1, 0.1), rng.uniform(-0.5, 0.5), rng.uniform(-0.05, 0.05)
        c_ref, v_ref = integrate_1d(c0, v0, lambda t: p, T, w)
        c, v = lipm.constant_zmp(c0, v0, p, T, w)
        scale = abs(c0 - p) + abs(v0) / w
        grow = math.exp(w * T)
        assert c == pytest.approx(c_ref, rel=1e-8, abs=1e-9 * scale * grow)
        assert v == pytest.approx(v_ref, rel=1e-8, abs=1e-9 * w * scale * grow)


@pytest.mark.parametrize("tau", [0.1, 0.2, 0.3, 0.7])
def test_ramp_zmp_matches_ode(robot, tau):
    rng = np.random.default_rng(2)
    w = robot.omega
    for _ in range(4):
        c0, v0 = rng.uniform(-0.1, 0.1), rng.uniform(-0.5, 0.5)
        pa, pb = rng.uniform(-0.1, 0.1, size=2)
        for t in (0.3 * tau, tau):  # mid-ramp and end of ramp
            c_ref, v_ref = integrate_1d(c0, v0, lambda s: pa + (pb - pa) * s / tau, t, w)
            c, v = lipm.ramp_zmp(c0, v0, pa, pb, tau, t, w)
            scale = (abs(c0) + abs(pa) + abs(pb) + abs(v0) / w) * math.exp(w * t)
            assert c == pytest.approx(c_ref, rel=1e-8, abs=1e-9 * scale)
            assert v == pytest.approx(v_ref, rel=1e-8, abs=1e-9 * w * scale)
        c_start, v_start = lipm.ramp_zmp(c0, v0, pa, pb, tau, 0.0, w)
        assert c_start == pytest.approx(c0, abs=1e-15) and v_start == pytest.approx(v0, abs=1e-15)


def test_closed_forms_vectorised(robot):
    """numpy's ``cosh``/``sinh`` (SIMD, per CPU) against ``math``'s (libm): within 1e-14, about 45 ulps."""
    rng = np.random.default_rng(3)
    w = robot.omega
    c0, v0, p = rng.uniform(-0.1, 0.1, 5), rng.uniform(-0.5, 0.5, 5), rng.uniform(-0.05, 0.05, 5)
    t = rng.uniform(0.05, 0.8, 5)
    c, v = lipm.constant_zmp(c0, v0, p, t, w)
    for i in range(5):
        ci, vi = lipm.constant_zmp(float(c0[i]), float(v0[i]), float(p[i]), float(t[i]), w)
        assert c[i] == pytest.approx(ci, rel=1e-14) and v[i] == pytest.approx(vi, rel=1e-14)


def test_dcm_round_trip(robot):
    rng = np.random.default_rng(4)
    w = robot.omega
    c, v = rng.normal(size=7) + 1j * rng.normal(size=7), rng.normal(size=7) + 1j * rng.normal(size=7)
    xi, eta = lipm.to_dcm(c, v, w)
    np.testing.assert_allclose(xi, c + v / w, rtol=1e-15)
    c2, v2 = lipm.from_dcm(xi, eta, w)
    np.testing.assert_allclose(c2, c, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(v2, v, rtol=1e-13, atol=1e-15)


# ------------------------------------------------------------------ 2. StepTrajectory
def test_step_trajectory_matches_ode_and_speed_bound(robot):
    rng = np.random.default_rng(5)
    w = robot.omega
    for _ in range(6):
        com = complex(*rng.uniform(-0.05, 0.05, 2))
        vel = complex(*rng.uniform(-0.4, 0.4, 2))
        p = complex(*rng.uniform(-0.02, 0.02, 2))
        side = int(rng.choice([1, -1]))
        S, L, _, t_ss, t_ds = rng.uniform(robot.command_low, robot.command_high)
        q = S + 1j * (-side) * L
        traj = lipm.StepTrajectory(w, com, vel, p, q, t_ss, t_ds)
        T = t_ss + t_ds
        ts = np.linspace(0.0, T, 401)
        c_ref, v_ref = integrate(com, vel, step_zmp(p, q, t_ss, t_ds), [0.0, t_ss, T], w, t_eval=ts)
        got = np.array([traj.state(float(t)) for t in ts])
        scale = (abs(com) + abs(p) + abs(q) + abs(vel) / w) * math.exp(w * T)
        np.testing.assert_allclose(got[:, 0], c_ref, rtol=1e-8, atol=1e-9 * scale)
        np.testing.assert_allclose(got[:, 1], v_ref, rtol=1e-8, atol=1e-9 * w * scale)
        # continuity across the single/double support boundary
        before, after = traj.state(t_ss * (1 - 1e-12)), traj.state(t_ss * (1 + 1e-12))
        assert abs(before[0] - after[0]) < 1e-9 * scale and abs(before[1] - after[1]) < 1e-8 * w * scale
        # speed bound: above every sampled speed (ODE and closed form), dense sampling
        bound = traj.speed_bound()
        dense = np.linspace(0.0, T, 4001)
        speeds = np.abs([traj.state(float(t))[1] for t in dense])
        assert bound >= speeds.max() * (1 - 1e-12)
        assert bound >= np.abs(v_ref).max() * (1 - 1e-9)


def test_speed_bound_is_attained_when_only_the_convergent_part_moves(robot):
    """CoM starting on the ZMP's stable manifold (c + v/w = p) with q = p: the fastest point is t=0.

    The speed then only decays, so the bound must reach ``|v0|`` (and need not be much more).
    """
    rng = np.random.default_rng(13)
    w = robot.omega
    for _ in range(5):
        p = complex(*rng.uniform(-0.02, 0.02, 2))
        vel = complex(*rng.uniform(-0.4, 0.4, 2))
        com = p - vel / w
        traj = lipm.StepTrajectory(w, com, vel, p, p, 0.4, 0.2)
        _, v_ref = integrate(com, vel, step_zmp(p, p, 0.4, 0.2), [0.0, 0.4, 0.6], w,
                                 t_eval=np.linspace(0, 0.6, 101))
        assert np.abs(v_ref).max() == pytest.approx(abs(vel), rel=1e-9)
        assert traj.speed_bound() >= abs(vel) * (1 - 1e-12)
        assert traj.speed_bound() <= 2.0 * abs(vel)


def test_speed_bound_on_steady_walk(robot):
    """Along a real walk (p from the generator) the bound still holds."""
    rng = np.random.default_rng(6)
    w = robot.omega
    for _ in range(5):
        cmd = random_command(rng, robot)
        side = 1
        com, vel = lipm.steady_state(robot, cmd, side)
        _, _, p, _, _ = lipm.check_step(robot, com, vel, tuple(cmd), side)
        q = cmd[0] + 1j * (-side) * cmd[1]
        traj = lipm.StepTrajectory(w, com, vel, p, q, cmd[3], cmd[4])
        speeds = np.abs([traj.state(float(t))[1] for t in np.linspace(0, cmd[3] + cmd[4], 2001)])
        assert speeds.max() <= traj.speed_bound() * (1 + 1e-12)
        assert math.isfinite(traj.speed_bound())


# ------------------------------------------------------------------ 3. check_step end state vs ODE
def test_check_step_end_state_matches_ode(robot):
    rng = np.random.default_rng(7)
    w = robot.omega
    for _ in range(10):
        side = int(rng.choice([1, -1]))
        cmd = tuple(float(x) for x in rng.uniform(robot.command_low, robot.command_high))
        com = complex(*rng.uniform(-0.03, 0.03, 2))
        vel = complex(*rng.uniform(-0.3, 0.3, 2))
        _, _, p, c_end, v_end = lipm.check_step(robot, com, vel, cmd, side)
        c_ref, v_ref = ode_step(robot, com, vel, cmd, side, p)
        scale = (abs(com) + abs(vel) / w + 0.2) * math.exp(w * (cmd[3] + cmd[4]))
        assert abs(c_end - c_ref) <= 1e-9 * scale
        assert abs(v_end - v_ref) <= 1e-9 * w * scale


def test_check_step_offset_minimises_generator_cost(robot):
    """p minimises a|dc|^2 + b|dv/w|^2 against the next step's steady gait (end states by ODE)."""
    rng = np.random.default_rng(8)
    w = robot.omega
    wa, wb = robot.generator_weight_position, robot.generator_weight_velocity
    for _ in range(4):
        side = int(rng.choice([1, -1]))
        cmd = tuple(float(x) for x in random_command(rng, robot))
        com = complex(*rng.uniform(-0.03, 0.03, 2))
        vel = complex(*rng.uniform(-0.2, 0.2, 2))
        _, _, p, _, _ = lipm.check_step(robot, com, vel, cmd, side)
        tc, tv = lipm.steady_state(robot, cmd, -side)  # target: steady gait, next support = new foot

        def cost(pp):
            c, v = ode_step(robot, com, vel, cmd, side, pp)
            return wa * abs(c - tc) ** 2 + wb * abs((v - tv) / w) ** 2

        c0 = cost(p)
        for d in (1e-4, 1e-4j, -1e-4, -1e-4j, 7e-5 + 7e-5j, -7e-5 + 7e-5j):
            assert cost(p + d) > c0


# ------------------------------------------------------------------ 4. steady walking
def test_steady_walking_needs_no_offset(robot):
    rng = np.random.default_rng(9)
    cmds = [robot.nominal_command, np.array([0.05, 0.08, 0.0, 0.6, 0.2]),
            np.array([0.08, 0.09, 0.15, 0.3, 0.15]), np.array([-0.03, 0.1, -0.18, 0.1, 0.1])]
    cmds += [random_command(rng, robot) for _ in range(10)]
    assert sum(abs(c[2]) > 0.05 for c in cmds) >= 3  # turning commands included
    for cmd in cmds:
        for side0 in (1, -1):
            side = side0
            com, vel = lipm.steady_state(robot, cmd, side)
            for _ in range(24):
                kin, zmp, p, com, vel = lipm.check_step(robot, com, vel, tuple(cmd), side)
                assert abs(p) < 1e-9, (cmd, side, p)
                assert kin and zmp
                side = -side
            # and the state is still the steady one of the side now supporting
            s_com, s_vel = lipm.steady_state(robot, cmd, side)
            assert abs(com - s_com) < 1e-9 and abs(vel - s_vel) < 1e-8


def test_steady_state_is_two_step_periodic_by_ode(robot):
    """Independent of check_step: two ODE steps with the ZMP at the foot centres return the state."""
    rng = np.random.default_rng(10)
    cmds = [np.array([0.06, 0.09, 0.17, 0.4, 0.2]), np.array([0.0, 0.08, -0.2, 0.6, 0.3])]
    cmds += [random_command(rng, robot) for _ in range(3)]
    for cmd in cmds:
        side = int(rng.choice([1, -1]))
        com0, vel0 = lipm.steady_state(robot, cmd, side)
        c1, v1 = ode_step(robot, com0, vel0, cmd, side, 0.0)
        c1s, v1s = lipm.steady_state(robot, cmd, -side)
        assert abs(c1 - c1s) < 1e-8 and abs(v1 - v1s) < 1e-7
        c2, v2 = ode_step(robot, c1, v1, cmd, -side, 0.0)
        assert abs(c2 - com0) < 1e-8 and abs(v2 - vel0) < 1e-7


# ------------------------------------------------------------------ 5. the per-axis 2x2 fixed points
def _two_by_two(robot, d, t_ss, t_ds):
    """A and b of docs/model.md §3 for a foot displacement d along one axis, b by ODE integration."""
    w, T = robot.omega, t_ss + t_ds
    A = np.array([[math.cosh(w * T), math.sinh(w * T) / w], [w * math.sinh(w * T), math.cosh(w * T)]])
    zmp = lambda t: 0.0 if t <= t_ss else d * (t - t_ss) / t_ds  # noqa: E731
    c, v = integrate_1d(0.0, 0.0, zmp, T, w)
    # A itself against the ODE with the ZMP at 0 (columns: unit position, unit velocity)
    for j, (c0, v0) in enumerate(((1.0, 0.0), (0.0, 1.0))):
        cA, vA = integrate_1d(c0, v0, lambda t: 0.0, T, w)
        np.testing.assert_allclose([cA, vA], A[:, j], rtol=1e-8)
    return A, np.array([c - d, v])


@pytest.mark.parametrize("cmd", [
    [0.0, 0.08, 0.0, 0.6, 0.2], [0.05, 0.08, 0.0, 0.6, 0.2], [0.1, 0.12, 0.0, 0.1, 0.1],
    [-0.04, 0.07, 0.0, 0.35, 0.3], [0.07, 0.1, 0.0, 0.2, 0.15],
])
@pytest.mark.parametrize("side", [1, -1])
def test_steady_state_matches_per_axis_fixed_points(robot, cmd, side):
    S, L, _, t_ss, t_ds = cmd
    I2 = np.eye(2)
    A, b_x = _two_by_two(robot, S, t_ss, t_ds)
    x_star = np.linalg.solve(I2 - A, b_x)
    _, b_y = _two_by_two(robot, -side * L, t_ss, t_ds)  # lateral foot displacement: swing * L
    y_star = -np.linalg.solve(I2 + A, b_y)
    com, vel = lipm.steady_state(robot, cmd, side)
    np.testing.assert_allclose([com.real, vel.real], x_star, rtol=1e-7, atol=1e-11)
    np.testing.assert_allclose([com.imag, vel.imag], y_star, rtol=1e-7, atol=1e-11)
    # the lateral CoM stays between the two feet
    if S == 0:
        assert com.real == pytest.approx(0.0, abs=1e-15)
    assert abs(com.imag) < L / 2


# ------------------------------------------------------------------ 6. the figures of docs/model.md §3
def _walk(robot, com, vel, side, commands):
    ps, ok = [], []
    for cmd in commands:
        kin, zmp, p, com, vel = lipm.check_step(robot, com, vel, tuple(float(x) for x in cmd), side)
        ps.append(p)
        ok.append(kin and zmp)
        side = -side
    return ps, ok


def test_robot_defaults(robot):
    assert robot.com_height == pytest.approx(0.23)
    assert robot.omega == pytest.approx(math.sqrt(9.81 / 0.23))
    assert robot.zmp_half_extent == pytest.approx((0.25 * 0.104, 0.25 * 0.066))


@pytest.mark.parametrize("side", [1, -1])
def test_cutting_single_support_time(robot, side):
    base = [0.05, 0.08, 0.0, 0.6, 0.2]
    com, vel = lipm.steady_state(robot, base, side)
    # to 0.2 s in one step: |p_x| about 9 mm, feasible
    (p,), (ok,) = _walk(robot, com, vel, side, [[0.05, 0.08, 0.0, 0.2, 0.2]])
    assert ok
    assert 8e-3 < abs(p.real) < 10e-3
    # to 0.1 s in one step: infeasible (docs/model.md §3: p_x about -25 mm)
    (p,), (ok,) = _walk(robot, com, vel, side, [[0.05, 0.08, 0.0, 0.1, 0.2]])
    assert not ok
    assert 23e-3 < abs(p.real) < 27e-3
    # gradually: geometric (6, 8, 10 steps) and linear (8, 10 steps), then hold 0.1 s
    for sched in (0.6 * (0.1 / 0.6) ** (np.arange(1, 7) / 6), 0.6 * (0.1 / 0.6) ** (np.arange(1, 9) / 8),
                  0.6 * (0.1 / 0.6) ** (np.arange(1, 11) / 10), np.linspace(0.6, 0.1, 9)[1:],
                  np.linspace(0.6, 0.1, 11)[1:]):
        ts = list(sched) + [0.1] * 4
        ps, ok = _walk(robot, com, vel, side, [[0.05, 0.08, 0.0, t, 0.2] for t in ts])
        assert all(ok), (sched, ps)
    ps, _ = _walk(robot, com, vel, side,
                  [[0.05, 0.08, 0.0, t, 0.2] for t in 0.6 * (0.1 / 0.6) ** (np.arange(1, 7) / 6)])
    assert max(max(abs(p.real), abs(p.imag)) for p in ps) < 11e-3  # docs/model.md §3: six steps under 11 mm


@pytest.mark.parametrize("side", [1, -1])
def test_speeding_up_from_stepping_in_place(robot, side):
    com, vel = lipm.steady_state(robot, robot.nominal_command, side)
    strides = [0.05 / 3, 0.1 / 3, 0.05, 0.05, 0.05, 0.05]
    ps, ok = _walk(robot, com, vel, side, [[S, 0.08, 0.0, 0.6, 0.2] for S in strides])
    assert all(ok)
    assert max(abs(p) for p in ps) < 0.5e-3
    # an abrupt jump to 5 cm is larger than the gradual one (the CoM momentum matters)
    ps_abrupt, _ = _walk(robot, com, vel, side, [[0.05, 0.08, 0.0, 0.6, 0.2]])
    assert abs(ps_abrupt[0]) > max(abs(p) for p in ps[:3])


# ------------------------------------------------------------------ 7. batched vs scalar
def test_batched_matches_scalar(robot):
    """The verdicts exactly (no ZMP offset within ``ZMP_TIE_MARGIN`` of a tie), the offsets and end states within
    tolerances (measured: 2e-16 m, 2e-15 m, 1.2e-14 m/s apart, with numpy's AVX-512 kernels or none)."""
    rng = np.random.default_rng(11)
    N = 64
    lo, hi = robot.command_low, robot.command_high
    span = hi - lo
    cmds = rng.uniform(lo - 0.1 * span, hi + 0.1 * span, size=(N, 5))  # some outside the box
    cmds[:, 3:] = np.maximum(cmds[:, 3:], 0.05)
    com, vel = np.array([0.01, -0.02]), np.array([0.1, 0.15])
    for side in (1, -1):
        res = lipm.check_steps(robot, com, vel, cmds, side)
        assert res.feasible.shape == (N,) and res.zmp_offset.shape == (N, 2)
        assert zmp_edge_gaps(robot, res).min() > ZMP_TIE_MARGIN
        for i in range(N):
            kin, zmp, p, c, v = lipm.check_step(robot, complex(*com), complex(*vel), tuple(cmds[i]), side)
            assert res.kinematic_ok[i] == kin and res.zmp_ok[i] == zmp
            assert res.feasible[i] == (kin and zmp)
            assert lipm.step_feasible(robot, com, vel, cmds[i], side) == (kin and zmp)  # pairs in, the same verdict
            np.testing.assert_allclose(res.zmp_offset[i], [p.real, p.imag], rtol=1e-12, atol=1e-15)
            np.testing.assert_allclose(res.end_com[i], [c.real, c.imag], rtol=1e-11, atol=1e-13)
            np.testing.assert_allclose(res.end_vel[i], [v.real, v.imag], rtol=1e-11, atol=1e-12)
        assert res.feasible.any() and not res.feasible.all()


def test_batched_per_row_sides_and_states(robot):
    rng = np.random.default_rng(12)
    N = 32
    cmds = np.array([random_command(rng, robot) for _ in range(N)])
    sides = rng.choice([1, -1], size=N)
    coms = rng.uniform(-0.03, 0.03, size=(N, 2))
    vels = rng.uniform(-0.2, 0.2, size=(N, 2))
    res = lipm.check_steps(robot, coms, vels, cmds, sides)
    assert zmp_edge_gaps(robot, res).min() > ZMP_TIE_MARGIN  # the verdicts below are compared exactly
    for i in range(N):
        kin, zmp, p, c, v = lipm.check_step(robot, complex(*coms[i]), complex(*vels[i]), tuple(cmds[i]), int(sides[i]))
        assert res.kinematic_ok[i] == kin and res.zmp_ok[i] == zmp
        np.testing.assert_allclose(res.zmp_offset[i], [p.real, p.imag], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(res.end_com[i], [c.real, c.imag], rtol=1e-11, atol=1e-13)


def test_batched_nan_rows_are_infeasible(robot):
    good = [0.05, 0.08, 0.0, 0.6, 0.2]
    cmds = np.array([good] * 6)
    for i in range(5):
        cmds[i + 1, i] = np.nan
    com, vel = lipm.steady_state(robot, good, 1)
    res = lipm.check_steps(robot, [com.real, com.imag], [vel.real, vel.imag], cmds, 1)
    assert res.feasible.tolist() == [True, False, False, False, False, False]
    assert not res.zmp_ok[1:].any()
    # a single scalar NaN command is infeasible too, not an exception
    kin, zmp, *_ = lipm.check_step(robot, com, vel, (np.nan, 0.08, 0.0, 0.6, 0.2), 1)
    assert not (kin and zmp)


def test_scalar_zero_double_support_is_infeasible_not_an_error(robot):
    res = lipm.check_steps(robot, [0.0, 0.0], [0.0, 0.0], [[0.05, 0.08, 0.0, 0.6, 0.0]], 1)
    assert not res.feasible[0]
    kin, zmp, *_ = lipm.check_step(robot, 0j, 0j, (0.05, 0.08, 0.0, 0.6, 0.0), 1)
    assert not (kin and zmp)
