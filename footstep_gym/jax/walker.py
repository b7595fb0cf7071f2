"""The robot's footstep in JAX: the command's verdict, the CoM's path through the step and its speed bound.

The verdict is :func:`footstep_gym.lipm.step_terms` and :func:`footstep_gym.footstep.kinematically_feasible`
themselves, run with ``jax.numpy`` (written once for both array libraries). The path and its speed bound
are :class:`footstep_gym.lipm.WorldPath` and :meth:`~footstep_gym.lipm.StepTrajectory.speed_bound` as array
expressions (those are scalar Python with branches, the env's per-step path); ``tests/test_jax_door.py``
checks them against the scalar ones.
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


class Path(NamedTuple):
    """The CoM's path through one step in the world (``WorldPath``'s constants; complex ones complex)."""

    w: float
    t_ss: jax.Array
    end: jax.Array
    p: jax.Array
    pd: jax.Array
    pdw: jax.Array
    a_xi: jax.Array
    a_eta: jax.Array
    b_xi: jax.Array
    b_eta: jax.Array
    origin: jax.Array
    rot: jax.Array

    def state(self, t: jax.Array) -> tuple[jax.Array, jax.Array]:
        """CoM ``(position, velocity)`` (complex, support foot's frame) at ``t`` [s] (``StepTrajectory.state``)."""
        w, p = self.w, self.p
        single = t <= self.t_ss
        tau = jnp.minimum(t, self.end) - self.t_ss
        s = jnp.where(single, t, tau)
        e_up, e_down = jnp.exp(w * s), jnp.exp(-w * s)
        pt = p + self.pd * jnp.where(single, 0.0, tau)
        shift = jnp.where(single, 0.0, self.pdw)
        xi = jnp.where(single, p + self.a_xi * e_up, pt + shift + self.b_xi * e_up)
        eta = jnp.where(single, p + self.a_eta * e_down, pt - shift + self.b_eta * e_down)
        return 0.5 * (xi + eta), 0.5 * w * (xi - eta)

    def __call__(self, t: jax.Array) -> tuple[jax.Array, jax.Array]:
        """World ``(x, y)`` [m] of the CoM at ``t`` [s] (any shape): ``WorldPath.__call__``."""
        w, p = self.w, self.p
        single = t <= self.t_ss
        tau = jnp.where(self.end < t, self.end, t) - self.t_ss
        s = jnp.where(single, t, tau)
        e_up, e_down = jnp.exp(w * s), jnp.exp((-w) * s)
        pt = p + self.pd * tau
        xi = jnp.where(single, p + self.a_xi * e_up, pt + self.pdw + self.b_xi * e_up)
        eta = jnp.where(single, p + self.a_eta * e_down, pt - self.pdw + self.b_eta * e_down)
        z = self.origin + 0.5 * (xi + eta) * self.rot
        return z.real, z.imag


def path_of(robot: Robot, v: Verdict, command: jax.Array, support_side: jax.Array, origin: jax.Array,
            rot: jax.Array) -> tuple[Path, jax.Array]:
    """The step's CoM path (support foot at ``origin``, turned by the unit complex ``rot``) and the bound of
    its speed [m/s] (``StepTrajectory.speed_bound``)."""
    w = robot.omega
    S, L, t_ss, t_ds = command[0], command[1], command[3], command[4]
    q = S + 1j * ((-support_side.astype(S.dtype)) * L)
    p = v.p
    xi1 = p + (v.xi0 - p) * jnp.exp(w * t_ss)
    eta1 = p + (v.eta0 - p) * jnp.exp(-w * t_ss)
    pd = (q - p) / t_ds
    pdw = pd / w
    path = Path(w, t_ss, t_ss + t_ds, p, pd, pdw, v.xi0 - p, v.eta0 - p, xi1 - p - pdw, eta1 - p + pdw, origin,
                rot)
    ss = 0.5 * w * (jnp.abs(v.xi0 - p) * jnp.exp(w * t_ss) + jnp.abs(v.eta0 - p))
    ds = jnp.abs(pd) + 0.5 * w * (jnp.abs(xi1 - p - pdw) * jnp.exp(w * t_ds) + jnp.abs(eta1 - p + pdw))
    return path, jnp.maximum(ss, ds)
