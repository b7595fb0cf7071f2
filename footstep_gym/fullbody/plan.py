"""The gait a footstep sequence stands for, sampled in time: CoM, ZMP, feet (docs/fullbody.md §2).

The CoM follows the env's own LIPM (:mod:`footstep_gym.lipm`): each footstep's ZMP offset ``p`` and CoM path come
from :func:`lipm.check_step` and :class:`lipm.StepTrajectory` with the CoM state carried from step to step, from
the env's start (the robot on its right foot, its CoM in the steady gait of stepping in place). Infeasible steps
are planned too (``p`` outside the stable region, feet overlapping): the full body then shows what happens.

Around the commands: a *prelude* (both feet down: stand still, then a quintic CoM move into the env's start
state) and a *stop* (both feet down: a quintic CoM move to rest between the feet, then standing still).
"""

from __future__ import annotations

import cmath
from dataclasses import dataclass

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.footstep import LEFT, RIGHT
from footstep_gym.robot import Robot


@dataclass(frozen=True)
class GaitTiming:
    """Durations [s] and swing height [m] of the plan around and within the commands."""

    settle: float = 0.5  # standing still before the prelude's CoM move
    prelude: float = 1.0  # the CoM's move from rest between the feet into the env's start state
    stop: float = 1.0  # the CoM's move from the last step's end state to rest between the feet
    hold: float = 0.5  # standing still at the end
    swing_height: float = 0.025  # the swing foot's highest lift above the floor
    dt: float = 0.004  # the plan's sampling interval (the IK's)


@dataclass
class GaitPlan:
    """The plan sampled every ``timing.dt`` (``n`` samples); world frame, complex = x + iy."""

    t: np.ndarray  # (n,) [s]
    com: np.ndarray  # (n,) complex [m]
    com_acc: np.ndarray  # (n,) complex [m/s^2]
    zmp: np.ndarray  # (n,) complex [m] the LIPM's ZMP (c - c''/omega^2)
    foot_xy: dict[int, np.ndarray]  # side -> (n,) complex [m] sole centre
    foot_z: dict[int, np.ndarray]  # side -> (n,) [m] sole height
    foot_yaw: dict[int, np.ndarray]  # side -> (n,) [rad]
    load: np.ndarray  # (n,) share of the weight on the LEFT foot, 0..1
    step: np.ndarray  # (n,) int: the footstep under way; -1 in the prelude, len(commands) in the stop
    single: np.ndarray  # (n,) bool: single support (one foot swinging)
    support: np.ndarray  # (n,) int: the support side of the footstep under way
    landed: list[tuple[float, float, float]]  # the pose each command places its foot at (world)
    start_feet: dict[int, tuple[float, float, float]]
    zmp_offset: list[complex]  # p of each command (support foot frame)


def _quintic(c0: complex, v0: complex, a0: complex, c1: complex, v1: complex, a1: complex, T: float,
             t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position and acceleration of the quintic from (c0, v0, a0) to (c1, v1, a1) over ``T``, at ``t``."""
    m = np.array([[T ** 3, T ** 4, T ** 5], [3 * T ** 2, 4 * T ** 3, 5 * T ** 4], [6 * T, 12 * T ** 2, 20 * T ** 3]])
    rhs = np.array([c1 - c0 - v0 * T - a0 * T ** 2 / 2, v1 - v0 - a0 * T, a1 - a0])
    k3, k4, k5 = np.linalg.solve(m, rhs)
    pos = c0 + v0 * t + a0 * t ** 2 / 2 + k3 * t ** 3 + k4 * t ** 4 + k5 * t ** 5
    acc = a0 + 6 * k3 * t + 12 * k4 * t ** 2 + 20 * k5 * t ** 3
    return pos, acc


def _min_jerk(s: np.ndarray) -> np.ndarray:
    """0 -> 1 with zero velocity and acceleration at both ends."""
    return s ** 3 * (10 - 15 * s + 6 * s ** 2)


def start_feet(robot: Robot) -> dict[int, tuple[float, float, float]]:
    """The env's start: the robot centre at the origin facing +x, feet ``nominal_side_stride / 2`` either side."""
    half = 0.5 * robot.nominal_side_stride
    return {side: tuple(float(v) for v in footstep.foot_from_node((0.0, 0.0), 0.0, side, half)) for side in (LEFT, RIGHT)}


def gait_plan(robot: Robot, commands: np.ndarray, timing: GaitTiming = GaitTiming()) -> GaitPlan:
    """The plan of ``commands`` ``(n, 5)`` ``[S, L, theta, T_SS, T_DS]`` from the env's start."""
    commands = np.atleast_2d(np.asarray(commands, dtype=float))
    if commands.ndim != 2 or commands.shape[1] != 5 or not np.all(np.isfinite(commands)):
        raise ValueError(f"commands must be finite, shape (n, 5) [S, L, theta, T_SS, T_DS]; got shape {commands.shape}")
    low, high = robot.command_low, robot.command_high
    if np.any(commands < low - 1e-9) or np.any(commands > high + 1e-9):
        raise ValueError(f"a command lies outside the robot's box {low.tolist()} .. {high.tolist()} (the env would clip it)")
    w, dt = robot.omega, timing.dt
    feet = start_feet(robot)
    start = dict(feet)
    support = RIGHT
    com_l, vel_l = lipm.steady_state(robot, robot.nominal_command, support)
    rows: list[tuple] = []  # per segment: (t, com, acc, zmp, feet xy/z/yaw per side, load, step, single, support)

    def cpx(pose: tuple[float, float, float]) -> complex:
        return complex(pose[0], pose[1])

    def still(n: int) -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        return {s: (np.full(n, cpx(feet[s])), np.zeros(n), np.full(n, feet[s][2])) for s in (LEFT, RIGHT)}

    def load_between(zmp: np.ndarray) -> np.ndarray:
        a, b = cpx(feet[LEFT]), cpx(feet[RIGHT])
        u = ((zmp - b) * (a - b).conjugate()).real / abs(a - b) ** 2
        return np.clip(u, 0.0, 1.0)

    def segment(n_t: np.ndarray, com: np.ndarray, acc: np.ndarray, zmp: np.ndarray, fe: dict, load: np.ndarray,
                step: int, single: bool) -> None:
        rows.append((n_t, com, acc, zmp, fe, load, np.full(len(n_t), step), np.full(len(n_t), single),
                     np.full(len(n_t), support)))

    # Prelude: stand, then move the CoM from rest between the feet into the env's start state.
    rot = cmath.exp(1j * feet[support][2])
    c_start = cpx(feet[support]) + com_l * rot
    v_start = vel_l * rot
    first = commands[0] if len(commands) else robot.nominal_command
    _, _, p0, _, _ = lipm.check_step(robot, com_l, vel_l, tuple(first), support)
    a_start = w * w * (c_start - (cpx(feet[support]) + p0 * rot))
    mid = 0.5 * (cpx(feet[LEFT]) + cpx(feet[RIGHT]))
    t = np.arange(0.0, timing.settle, dt)
    segment(t, np.full(len(t), mid), np.zeros(len(t), complex), np.full(len(t), mid), still(len(t)),
            load_between(np.full(len(t), mid)), -1, False)
    t = np.arange(0.0, timing.prelude, dt)
    c, a = _quintic(mid, 0j, 0j, c_start, v_start, a_start, timing.prelude, t)
    segment(t, c, a, c - a / w ** 2, still(len(t)), load_between(c - a / w ** 2), -1, False)

    com_w, vel_w = c_start, v_start
    landed, offsets = [], []
    for k, cmd in enumerate(commands):
        S, L, theta, t_ss, t_ds = (float(x) for x in cmd)
        sup = feet[support]
        rot = cmath.exp(1j * sup[2])
        origin = cpx(sup)
        local_c, local_v = (com_w - origin) / rot, vel_w / rot
        _, _, p, end_c, end_v = lipm.check_step(robot, local_c, local_v, (S, L, theta, t_ss, t_ds), support)
        swing = -support
        traj = lipm.StepTrajectory(w, local_c, local_v, p, complex(S, swing * L), t_ss, t_ds)
        new = footstep.place_foot_scalar(sup, support, S, L, theta)
        landed.append(new)
        offsets.append(p)
        old = feet[swing]
        for phase, t0, T in (("ss", 0.0, t_ss), ("ds", t_ss, t_ds)):
            t = np.arange(0.0, T - 1e-12, dt)
            states = [traj.state(t0 + x) for x in t]
            c = origin + np.array([s[0] for s in states]) * rot
            if phase == "ss":
                zmp = np.full(len(t), origin + p * rot)
                u = _min_jerk(t / T)
                swing_xy = cpx(old) + (cpx(new) - cpx(old)) * u
                swing_yaw = old[2] + footstep.wrap_angle(new[2] - old[2]) * u
                swing_z = timing.swing_height * np.sin(np.pi * t / T) ** 2
                fe = still(len(t))
                fe[swing] = (swing_xy, swing_z, swing_yaw)
                load = np.full(len(t), 1.0 if support == LEFT else 0.0)
            else:
                zmp = origin + (p + (complex(S, swing * L) - p) * t / T) * rot
                feet[swing] = new
                fe = still(len(t))
                share_new = t / T
                load = share_new if swing == LEFT else 1.0 - share_new
            acc = w * w * (c - zmp)
            segment(t, c, acc, zmp, fe, load, k, phase == "ss")
        feet[swing] = new
        new_rot = cmath.exp(1j * new[2])
        com_w = cpx(new) + end_c * new_rot
        vel_w = end_v * new_rot
        support = swing

    # Stop: from the last state to rest between the feet, then stand.
    mid = 0.5 * (cpx(feet[LEFT]) + cpx(feet[RIGHT]))
    a_end = w * w * (com_w - cpx(feet[support]))
    t = np.arange(0.0, timing.stop, dt)
    c, a = _quintic(com_w, vel_w, a_end, mid, 0j, 0j, timing.stop, t)
    segment(t, c, a, c - a / w ** 2, still(len(t)), load_between(c - a / w ** 2), len(commands), False)
    t = np.arange(0.0, timing.hold, dt)
    segment(t, np.full(len(t), mid), np.zeros(len(t), complex), np.full(len(t), mid), still(len(t)),
            load_between(np.full(len(t), mid)), len(commands), False)

    n = sum(len(r[0]) for r in rows)
    cat = lambda i: np.concatenate([r[i] for r in rows])  # noqa: E731
    return GaitPlan(
        t=np.arange(n) * dt, com=cat(1), com_acc=cat(2), zmp=cat(3),
        foot_xy={s: np.concatenate([r[4][s][0] for r in rows]) for s in (LEFT, RIGHT)},
        foot_z={s: np.concatenate([r[4][s][1] for r in rows]) for s in (LEFT, RIGHT)},
        foot_yaw={s: np.concatenate([r[4][s][2] for r in rows]) for s in (LEFT, RIGHT)},
        load=cat(5), step=cat(6), single=cat(7), support=cat(8), landed=landed, start_feet=start,
        zmp_offset=offsets,
    )
