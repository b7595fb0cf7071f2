"""Walking a footstep sequence on the OP3 in MuJoCo (docs/fullbody.md §2).

The plan (:mod:`footstep_gym.fullbody.plan`) gives the CoM and the feet; inverse kinematics
(:class:`~footstep_gym.fullbody.model.LegIK`) turns them into joint angles with the torso upright at a constant
height and its horizontal position chosen so that the whole body's CoM is the plan's; the angles go to the model's
own position servos. The servos are soft (kp = 21.1 N m/rad), so each target gets the feed-forward rule of
:func:`servo_targets`: the planned joint torque divided by kp. Nothing pushes the body, nothing is welded, no mass or
gain differs from the model's.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import mujoco

from footstep_gym.footstep import LEFT, RIGHT
from footstep_gym.fullbody.model import LegIK, Op3, yaw_matrix
from footstep_gym.fullbody.plan import GaitPlan

#: Torso (free joint) height [m] of the walking posture: the hip-pitch axes 0.176 m above the ankles (of the legs'
#: 0.220 m: knees bent 74 deg), low enough that a 10 cm stride stays within the legs' reach in single support.
TORSO_HEIGHT = 0.235
#: A fall: the torso below this share of its walking height, or tilted beyond this angle [rad].
FALL_HEIGHT_SHARE = 0.6
FALL_TILT = math.radians(45.0)
#: The least normal force on the support sole [share of the weight] for its centre of pressure to count.
COP_MIN_LOAD = 0.2
#: The least height [m] of the swing sole's centre above the floor for the support sole to count as alone.
SWING_CLEAR = 0.002


def _circular_mean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * a) + np.exp(1j * b))


@dataclass
class JointPlan:
    """Joint angles and servo targets of a :class:`GaitPlan` (per plan sample)."""

    qpos: np.ndarray  # (n, nq) the whole configuration, torso included
    ctrl: np.ndarray  # (n, nu) the servo targets
    ik_residual: float  # the largest IK residual [m or rad]


def joint_plan(op3: Op3, plan: GaitPlan, torso_height: float = TORSO_HEIGHT) -> JointPlan:
    """IK for every plan sample, then the servo targets (:func:`servo_targets`)."""
    ik = LegIK(op3)
    m = op3.model
    n = len(plan.t)
    qpos = np.zeros((n, m.nq))
    offset = 0j  # torso minus whole-body CoM, horizontal; refined per sample
    worst = 0.0
    yaw = _circular_mean(plan.foot_yaw[LEFT], plan.foot_yaw[RIGHT])
    for i in range(n):
        feet = {s: (np.array([plan.foot_xy[s][i].real, plan.foot_xy[s][i].imag, plan.foot_z[s][i]]),
                    yaw_matrix(plan.foot_yaw[s][i])) for s in (LEFT, RIGHT)}
        for _ in range(1 if i else 6):  # the offset moves little from one sample to the next
            torso = plan.com[i] + offset
            err = ik.solve(np.array([torso.real, torso.imag, torso_height]), float(yaw[i]), feet)
            com = ik.data.subtree_com[op3.torso]
            offset = torso - complex(com[0], com[1])
        worst = max(worst, err)
        qpos[i] = ik.data.qpos
    return JointPlan(qpos, servo_targets(op3, plan, qpos), worst)


def servo_targets(op3: Op3, plan: GaitPlan, qpos: np.ndarray) -> np.ndarray:
    """Servo targets: planned angle + planned joint torque / kp (the servo's deflection under that torque).

    The torque is MuJoCo's inverse dynamics of the planned motion (velocities and accelerations by finite
    differences of the planned configurations), with the floor's wrench that the torso's six equations need put on
    the feet in the plan's load shares (all on the support foot in single support; shared along the ZMP's path in
    double support), then taken off each leg through its Jacobian.
    """
    m = op3.model
    dm = op3.no_contact
    d = mujoco.MjData(dm)
    n, dt = len(qpos), plan.t[1] - plan.t[0]
    qvel = np.zeros((n, m.nv))
    for i in range(1, n):
        mujoco.mj_differentiatePos(dm, qvel[i], dt, qpos[i - 1], qpos[i])
    qvel[0] = 0.0
    qacc = np.zeros_like(qvel)
    qacc[1:-1] = (qvel[2:] - qvel[:-2]) / (2 * dt)
    kp = m.actuator_gainprm[:, 0]
    ctrl = np.zeros((n, m.nu))
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for i in range(n):
        d.qpos[:], d.qvel[:], d.qacc[:] = qpos[i], qvel[i], qacc[i]
        mujoco.mj_inverse(dm, d)
        tau = d.qfrc_inverse.copy()
        share = {LEFT: plan.load[i], RIGHT: 1.0 - plan.load[i]}
        cols, weights = [], []
        for side in (LEFT, RIGHT):
            pos, _ = op3.sole_pose(d, side)
            mujoco.mj_jac(dm, d, jacp, jacr, pos, op3.soles[side].body)
            cols.append(np.vstack([jacp, jacr]).T)  # (nv, 6): generalised force of a wrench at the sole
            weights.append(max(share[side], 1e-3))
        # The torso's six rows: sum_s J_s[:6]^T w_s = tau[:6], least norm weighted by the load shares.
        a = np.hstack([c[:6] for c in cols])
        wdiag = np.repeat(weights, 6)
        wrench = wdiag * (a.T @ np.linalg.solve((a * wdiag) @ a.T, tau[:6]))
        joint_tau = tau - cols[0] @ wrench[:6] - cols[1] @ wrench[6:]
        ctrl[i] = qpos[i, op3.actuator_qpos] + joint_tau[op3.actuator_dof] / kp
    return ctrl


@dataclass
class WalkResult:
    """What the OP3 made of a footstep sequence.

    ``foot_error[k]``: after footstep ``k``'s double support, the distance [m] between where its foot's sole
    centre landed and where the command puts it relative to the support sole as it actually stands (so an error
    does not carry into the next footsteps'); ``yaw_error[k]`` the same for the yaw [rad]. ``cop_margin[k]``: the
    smallest margin [m] of the measured centre of pressure (from the support sole's contact forces) inside that
    sole's rectangle during footstep ``k``'s single support, while that sole alone carries the robot (the other
    ``SWING_CLEAR`` up), negative outside (``nan`` where the sole never bore
    ``COP_MIN_LOAD`` of the weight). Footsteps after a fall are left out of all three.
    """

    fell: bool
    fell_at: int | None  # the footstep under way when the torso fell (-1: before the first; n: after the last)
    foot_error: np.ndarray  # (k,) [m]
    yaw_error: np.ndarray  # (k,) [rad]
    cop_margin: np.ndarray  # (k,) [m]
    sim_time: float  # [s] simulated, prelude and stop included
    wall_time: float  # [s] planning and simulating
    ik_residual: float  # [m or rad] the plan's largest IK residual: above a millimetre a sole was out of reach
    zmp_offset: list[complex] = field(default_factory=list)  # the LIPM's p of each command (support foot frame)
    frames: list[np.ndarray] = field(default_factory=list)  # rendered frames (``render_every``)


def _sole_load(m: "mujoco.MjModel", d: "mujoco.MjData", op3: Op3, side: int) -> tuple[float, np.ndarray]:
    """Normal force [N] on ``side``'s sole and its centre of pressure (world x, y; nan if unloaded)."""
    geoms = op3.soles[side].geoms
    force = np.zeros(6)
    total, moment = 0.0, np.zeros(2)
    for i in range(d.ncon):
        con = d.contact[i]
        if con.geom1 in geoms or con.geom2 in geoms:
            mujoco.mj_contactForce(m, d, i, force)  # contact frame: force[0] along the normal, frame[0:3]
            fz = abs(force[0] * con.frame[2])
            total += fz
            moment += fz * con.pos[:2]
    return total, (moment / total if total > 0 else np.full(2, np.nan))


def _cop_margin(m: "mujoco.MjModel", d: "mujoco.MjData", op3: Op3, side: int, least_load: float) -> float:
    """Margin [m] of ``side``'s centre of pressure inside its sole rectangle while that sole alone carries the
    robot (at least ``least_load`` [N] on it; the other sole's centre ``SWING_CLEAR`` above the floor and
    touching nothing); nan otherwise."""
    total, cop = _sole_load(m, d, op3, side)
    other, _ = _sole_load(m, d, op3, -side)
    if total < least_load or other > 0.0 or op3.sole_pose(d, -side)[0][2] < SWING_CLEAR:
        return math.nan
    sole = op3.soles[side]
    pos, rot = op3.sole_pose(d, side)
    local = rot[:2, :2].T @ (cop - pos[:2])
    return float(min(sole.length / 2 - abs(local[0]), sole.width / 2 - abs(local[1])))


def _sole_planar(op3: Op3, d: "mujoco.MjData", side: int) -> tuple[complex, float]:
    pos, rot = op3.sole_pose(d, side)
    return complex(pos[0], pos[1]), math.atan2(rot[1, 0], rot[0, 0])


def walk_plan(op3: Op3, plan: GaitPlan, commands: np.ndarray, seed: int | None = None,
              render: "mujoco.Renderer | None" = None, render_every: int = 0) -> WalkResult:
    """Simulate the OP3 through ``plan`` (of ``commands``) and measure the outcome."""
    t0 = time.perf_counter()
    m = op3.model
    jp = joint_plan(op3, plan)
    d = mujoco.MjData(m)
    d.qpos[:] = jp.qpos[0]
    if seed is not None:  # a small disturbance of the start: every servo's angle off by up to +-0.01 rad
        rng = np.random.default_rng(seed)
        d.qpos[op3.actuator_qpos] += rng.uniform(-0.01, 0.01, m.nu)
    mujoco.mj_forward(m, d)
    sub = int(round((plan.t[1] - plan.t[0]) / m.opt.timestep))
    weight = float(np.sum(m.body_mass)) * float(-m.opt.gravity[2])
    torso_height = jp.qpos[0, 2]
    n_cmd = len(commands)
    foot_error, yaw_error, cop = [], [], np.full(n_cmd, np.inf)
    fell_at = None
    frames = []
    for i in range(len(plan.t)):
        d.ctrl[:] = jp.ctrl[i]
        for _ in range(sub):
            mujoco.mj_step(m, d)
        k = int(plan.step[i])
        if d.xpos[op3.torso][2] < FALL_HEIGHT_SHARE * torso_height or math.acos(
                min(1.0, d.xmat[op3.torso][8])) > FALL_TILT:
            fell_at = k
            break
        if plan.single[i]:
            margin = _cop_margin(m, d, op3, int(plan.support[i]), COP_MIN_LOAD * weight)
            if not math.isnan(margin):
                cop[k] = min(cop[k], margin)
        last_of_step = 0 <= k < n_cmd and (i + 1 == len(plan.t) or plan.step[i + 1] != k)
        if last_of_step:  # the foot this command placed, against the command from where the support sole stands
            support = int(plan.support[i])
            (sup_xy, sup_yaw), (new_xy, new_yaw) = _sole_planar(op3, d, support), _sole_planar(op3, d, -support)
            S, L, theta = commands[k, :3]
            want = sup_xy + complex(S, -support * L) * np.exp(1j * sup_yaw)
            foot_error.append(abs(new_xy - want))
            yaw_error.append(abs(math.remainder(new_yaw - sup_yaw - theta, 2 * math.pi)))
        if render is not None and render_every and i % render_every == 0:
            render.update_scene(d, camera=_tracking_camera(d, op3))
            frames.append(render.render())
    done = len(foot_error)
    cop = cop[:done]
    cop[np.isinf(cop)] = np.nan
    return WalkResult(fell_at is not None, fell_at, np.array(foot_error), np.array(yaw_error), cop,
                      float(d.time), time.perf_counter() - t0, jp.ik_residual, list(plan.zmp_offset), frames)


def _tracking_camera(d: "mujoco.MjData", op3: Op3) -> "mujoco.MjvCamera":
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = [d.xpos[op3.torso][0], d.xpos[op3.torso][1], 0.18]
    cam.distance, cam.azimuth, cam.elevation = 1.1, 135.0, -20.0
    return cam

