"""The robot's footstep in JAX: the command's verdict, the CoM's path through the step and its speed bound.

The verdict is :func:`footstep_gym.lipm.step_terms` and :func:`footstep_gym.footstep.kinematically_feasible`
themselves, run with ``jax.numpy`` (written once for both array libraries). So are the path and its speed
bound: :func:`footstep_gym.lipm.com_path`, :func:`~footstep_gym.lipm.com_state` and
:func:`~footstep_gym.lipm.com_speed_bound`, which the reference env runs on Python numbers;
``tests/test_jax_door.py`` checks the two runs against each other.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from footstep_gym import footstep, lipm
from footstep_gym.robot import Robot


class Verdict(NamedTuple):
    """What the pattern generator makes of one command (docs/model.md §3.2): kinematic and ZMP verdicts, the
    single-support ZMP offset ``p`` (complex, support foot's frame) [m], the end state relative to the new
    foot in its frame (complex) [m, m/s], and the start state's divergent/convergent components."""

    kinematic_ok: jax.Array
    zmp_ok: jax.Array
    p: jax.Array
    end_com: jax.Array
    end_vel: jax.Array
    xi0: jax.Array
    eta0: jax.Array


def verdict(robot: Robot, com: jax.Array, vel: jax.Array, command: jax.Array, support_side: jax.Array) -> Verdict:
    """The verdict on ``command`` ``(5,)`` from the CoM state ``com``, ``vel`` (complex, relative to the
    support foot in its frame), ``support_side`` +1/-1: ``lipm.check_step``'s answers."""
    S, L, theta, t_ss, t_ds = (command[i] for i in range(5))
    kin_ok = footstep.kinematically_feasible(command, support_side, robot, xp=jnp)
    omega = robot.omega
    xi0, eta0 = lipm.to_dcm(com, vel, omega)
    p, xi_end, eta_end = lipm.step_terms(jnp, jnp.exp, xi0, eta0, S, L, theta, t_ss, t_ds,
                                         -support_side.astype(S.dtype), omega, robot.generator_weight_position,
                                         robot.generator_weight_velocity)
    hx, hy = robot.zmp_half_extent
    zmp_ok = (jnp.abs(p.real) <= hx) & (jnp.abs(p.imag) <= hy)
    c_end, v_end = lipm.from_dcm(xi_end, eta_end, omega)
    return Verdict(kin_ok, zmp_ok, p, c_end, v_end, xi0, eta0)


class Path(lipm.ComPath):
    """The CoM's path through one step in the world: :class:`footstep_gym.lipm.ComPath` of JAX arrays, read with
    ``jax.numpy`` by :func:`footstep_gym.lipm.com_state` and :func:`~footstep_gym.lipm.com_world`."""

    __slots__ = ()

    def state(self, t: jax.Array) -> tuple[jax.Array, jax.Array]:
        """CoM ``(position, velocity)`` (complex, support foot's frame) at ``t`` [s] (``StepTrajectory.state``)."""
        return lipm.com_state(jnp, self, t)

    def __call__(self, t: jax.Array) -> tuple[jax.Array, jax.Array]:
        """World ``(x, y)`` [m] of the CoM at ``t`` [s] (any shape): ``WorldPath.__call__``."""
        return lipm.com_world(jnp, self, t)


def path_of(robot: Robot, v: Verdict, command: jax.Array, support_side: jax.Array, origin: jax.Array,
            rot: jax.Array) -> tuple[Path, jax.Array]:
    """The step's CoM path (support foot at ``origin``, turned by the unit complex ``rot``) and the bound of
    its speed [m/s] (``StepTrajectory.speed_bound``)."""
    S, L, t_ss, t_ds = command[0], command[1], command[3], command[4]
    q = S + 1j * ((-support_side.astype(S.dtype)) * L)
    path = Path(*lipm.com_path(jnp, robot.omega, v.xi0, v.eta0, v.p, q, t_ss, t_ds, origin, rot))
    return path, lipm.com_speed_bound(jnp, path, t_ds)
