"""The footstep commands walked on a full body: the ROBOTIS OP3 in MuJoCo (docs/fullbody.md).

* :func:`walk` walks a sequence of commands ``[S, L, theta, T_SS, T_DS]`` on the OP3 from the env's start and
  says whether it fell, where each foot landed and how close the centre of pressure came to the sole's edge;
* :func:`verdict` is the env's own verdict on the same sequence (``FootstepEnv`` stepping it, no obstacle
  within reach).

Needs the ``fullbody`` extra (``pip install 'footstep_gym[fullbody]'``): MuJoCo and the package holding the
OP3's model (MuJoCo Menagerie's ``robotis_op3``).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from footstep_gym.robot import Robot, load_robot

if TYPE_CHECKING:
    from footstep_gym.env import FootstepEnv

from footstep_gym.fullbody.model import model_path, shared_op3
from footstep_gym.fullbody.plan import GaitTiming, gait_plan
from footstep_gym.fullbody.walker import WalkResult, walk_plan

__all__ = ["walk", "verdict", "WalkResult", "GaitTiming", "model_path", "env_for_verdict"]

#: The obstacle-free stretch :func:`verdict` walks in: the crossing scene with its car and goal 1 km away.
FAR = 1000.0


def as_robot(robot: Robot | Mapping[str, Any] | str) -> Robot:
    """``robot`` as a :class:`Robot` (a profile name or a mapping of keys is loaded)."""
    return robot if isinstance(robot, Robot) else load_robot(robot)


def _commands(commands: Any) -> np.ndarray:
    cmd = np.atleast_2d(np.asarray(commands, dtype=float))
    if cmd.ndim != 2 or cmd.shape[1] != 5 or not np.all(np.isfinite(cmd)):
        raise ValueError(f"commands must be finite with shape (n, 5) [S, L, theta, T_SS, T_DS]; got shape {cmd.shape}")
    return cmd


def walk(commands: Any, robot: Robot | Mapping[str, Any] | str = "op3", seed: int | None = None,
         timing: GaitTiming = GaitTiming()) -> WalkResult:
    """Walk ``commands`` ``(n, 5)`` on the OP3 in MuJoCo from the env's start; see :class:`WalkResult`.

    ``robot``: the profile whose LIPM plans the CoM (its ``com_height``, ZMP weights, start); ``"op3"`` is the
    OP3's own. ``seed``: ``None`` starts from the planned posture exactly; an int disturbs every servo's start angle
    by up to ±0.01 rad, drawn from it. Commands must lie in the robot's box (the env would clip them).
    """
    cmd = _commands(commands)
    rob = as_robot(robot)
    return walk_plan(shared_op3(), gait_plan(rob, cmd, timing), cmd, seed)


def env_for_verdict(robot: Robot | Mapping[str, Any] | str = "op3", max_steps: int = 10_000) -> "FootstepEnv":
    """A ``FootstepEnv`` with nothing within reach: the crossing scene, its car crossing ``FAR`` metres ahead,
    the goal as far, no start jitter, no time limit within ``max_steps`` footsteps of the longest period."""
    from footstep_gym.env import FootstepEnv

    rob = as_robot(robot)
    longest = float(rob.command_high[3] + rob.command_high[4])
    return FootstepEnv("crossing", robot=robot if not isinstance(robot, Robot) else _robot_keys(robot),
                       crossing_x=FAR, goal=[FAR, 0.0], start=[0.0, 0.0], start_yaw=0.0, start_jitter=0.0,
                       timing_jitter=0.0, max_steps=max_steps, time_limit=2.0 * longest * max_steps)


def _robot_keys(robot: Robot) -> dict[str, Any]:
    return {f.name: getattr(robot, f.name) for f in dataclasses.fields(robot)}


def verdict(commands: Any, robot: Robot | Mapping[str, Any] | str = "op3") -> list[str | None]:
    """The env's verdict on each footstep of ``commands`` ``(n, 5)``: ``None`` (feasible) or its fall reason
    (``"zmp"``, ``"turn_limit"``, ``"overlap"``), by stepping :func:`env_for_verdict` from its start.

    The env's episode ends at its first fall, and so does the list: it holds one entry per command up to and
    including the first fall.
    """
    cmd = _commands(commands)
    env = env_for_verdict(robot, max_steps=max(len(cmd), 1))
    env.reset(seed=0)
    out: list[str | None] = []
    for c in cmd:
        _, _, terminated, truncated, info = env.step(c)
        out.append(info["fall"])
        if terminated or truncated:
            break
    env.close()
    return out
