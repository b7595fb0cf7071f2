"""LIPM walking-pattern generator and its ZMP feasibility check (docs/model.md §3).

Per horizontal axis the linear inverted pendulum is ``c'' = omega^2 (c - p)``. Its
closed forms are written here in the divergent / convergent components
``xi = c + v/omega`` and ``eta = c - v/omega``, which decouple it:

* constant ZMP ``p``:  ``xi(t) = p + (xi0 - p) e^{omega t}``, ``eta(t) = p + (eta0 - p) e^{-omega t}``
* ZMP ramp ``p(t) = pa + pdot t``: ``xi(t) = p(t) + pdot/omega + (xi0 - pa - pdot/omega) e^{omega t}``
  (``eta``: ``omega -> -omega``)

which are the ``c(t) = p + (c0 - p) cosh + (v0/omega) sinh`` forms of docs/model.md §3
re-arranged (:func:`constant_zmp` and :func:`ramp_zmp` give those directly). A horizontal 2D vector
``(x, y)`` is held as the complex number ``x + iy``, so rotating a frame by ``theta`` is a
multiplication by ``e^{-i theta}`` and both axes go through one expression.

One footstep, in the support foot ``F``'s frame with the CoM state relative to ``F``:
single support for ``T_SS`` with the ZMP at ``F + p``, then double support for ``T_DS``
with the ZMP moving linearly to the new foot's centre ``q = S + i*swing*L``. The state
at the end, relative to the new foot and in its frame (rotated by ``theta``), is the
next step's start state.

The generator picks the one free offset ``p`` (a 2D constant) that brings the end
state closest, in ``a*|dc|^2 + b*|dv/omega|^2``, to the *steady gait* of the command:
the start-of-step state, relative to the support foot, that repeats when the command
is repeated forever. Because the feet alternate, that gait is periodic over two steps
(the lateral axis mirrors); with complex numbers its fixed point is closed form::

    s' = r (a s + beta_side),  r = e^{-i theta},  beta_side = k q_side
    two steps: s = r^2 a^2 s + r^2 a beta_side + r beta_other  ->  s = (...) / (1 - r^2 a^2)

with ``a = e^{omega T}`` for ``xi`` and ``e^{-omega T}`` for ``eta``. With ``theta = 0``
this is the per-axis ``x* = (I - A)^-1 b`` sagittally and ``y* = -(I + A)^-1 b`` laterally
(docs/model.md §3).
A command is feasible iff that ``p`` lies in the stable ZMP rectangle (the foot scaled
by ``zmp_region_scale``) and the command is inside the kinematic limits.

Every function works on numpy arrays (a batch: the PSO's swarm) through :func:`check_steps`,
and on plain Python scalars through :func:`check_step` (the env's per-step path, where
numpy's per-call overhead would dominate); both run the same :func:`step_terms`.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from footstep_gym import footstep, scalars
from footstep_gym.robot import Robot


# ------------------------------------------------------------------ closed forms (one axis)
def constant_zmp(c0: Any, v0: Any, p: Any, t: Any, omega: float) -> tuple[Any, Any]:
    """CoM position and velocity after ``t`` [s] with the ZMP held at ``p`` (docs/model.md §3)."""
    ch, sh = np.cosh(omega * t), np.sinh(omega * t)
    return p + (c0 - p) * ch + (v0 / omega) * sh, (c0 - p) * omega * sh + v0 * ch


def ramp_zmp(c0: Any, v0: Any, pa: Any, pb: Any, tau: float, t: Any, omega: float) -> tuple[Any, Any]:
    """CoM position and velocity after ``t`` [s] of a ZMP moving linearly from ``pa`` to ``pb`` in ``tau``."""
    pdot = (pb - pa) / tau
    ch, sh = np.cosh(omega * t), np.sinh(omega * t)
    p = pa + pdot * t
    return (
        p + (c0 - pa) * ch + ((v0 - pdot) / omega) * sh,
        pdot + (c0 - pa) * omega * sh + (v0 - pdot) * ch,
    )


def to_dcm(c: Any, v: Any, omega: float) -> tuple[Any, Any]:
    """``(xi, eta) = (c + v/omega, c - v/omega)``."""
    return c + v / omega, c - v / omega


def from_dcm(xi: Any, eta: Any, omega: float) -> tuple[Any, Any]:
    """``(c, v)`` from ``(xi, eta)``."""
    return 0.5 * (xi + eta), 0.5 * omega * (xi - eta)


# ------------------------------------------------------------------ one step
@dataclass(frozen=True)
class StepResult:
    """What the pattern generator makes of a batch of commands (arrays of shape ``(N,)``).

    ``zmp_offset`` is ``p`` [m] in the support foot's frame (x forward, y left);
    ``end_com`` / ``end_vel`` the CoM position [m] / velocity [m/s] at the end of the step,
    relative to the new foot, in the new foot's frame.
    """

    feasible: np.ndarray  # bool: kinematic limits and ZMP inside the stable region
    kinematic_ok: np.ndarray  # bool: inside the kinematic limits
    zmp_ok: np.ndarray  # bool: p inside the stable region
    zmp_offset: np.ndarray  # (N, 2) [m]
    end_com: np.ndarray  # (N, 2) [m]
    end_vel: np.ndarray  # (N, 2) [m/s]


def step_terms(xp: Any, ce: Any, xi0: Any, eta0: Any, S: Any, L: Any, theta: Any,
                t_ss: Any, t_ds: Any, swing: Any, omega: float, wa: float, wb: float
                ) -> tuple[Any, Any, Any]:
    """``(p, xi_end, eta_end)`` of one step; ``xp`` is ``math``, ``numpy`` or ``jax.numpy``, ``ce`` ``cmath.exp``,
    ``np.exp`` or ``jnp.exp``.

    All 2D quantities are complex. ``xi0, eta0``: start state relative to the support
    foot; ``xi_end, eta_end``: end state relative to the new foot, in its frame.
    """
    period = t_ss + t_ds
    q = S + 1j * (swing * L)
    q_other = S - 1j * (swing * L)
    r = ce(-1j * theta)
    wd = omega * t_ds
    a_xi = xp.exp(omega * period)
    a_eta = xp.exp(-omega * period)
    k_xi = -xp.expm1(wd) / wd  # end of DS: xi - q = a xi0 + k q + g p
    k_eta = xp.expm1(-wd) / wd
    g_xi = -(a_xi + k_xi)
    g_eta = -(a_eta + k_eta)
    # Steady two-step gait, state at the start of the *next* step (relative to the new foot).
    r2 = r * r
    tgt_xi = (r2 * a_xi * k_xi * q_other + r * k_xi * q) / (1.0 - r2 * a_xi * a_xi)
    tgt_eta = (r2 * a_eta * k_eta * q_other + r * k_eta * q) / (1.0 - r2 * a_eta * a_eta)
    # Residuals at p = 0, in F's axes (the target rotated back by e^{+i theta}).
    u_xi = a_xi * xi0 + k_xi * q - tgt_xi / r
    u_eta = a_eta * eta0 + k_eta * q - tgt_eta / r
    # Least squares over p of wa |dc|^2 + wb |dv/omega|^2, dc = (dxi + deta)/2, dv/omega = (dxi - deta)/2.
    alpha, beta = g_xi + g_eta, g_xi - g_eta
    p = -(wa * alpha * (u_xi + u_eta) + wb * beta * (u_xi - u_eta)) / (wa * alpha * alpha + wb * beta * beta)
    xi_end = r * (u_xi + g_xi * p + tgt_xi / r)
    eta_end = r * (u_eta + g_eta * p + tgt_eta / r)
    return p, xi_end, eta_end


def check_steps(robot: Robot, com: Any, vel: Any, commands: Any, support_side: Any) -> StepResult:
    """Batched verdict for commands ``(N, 5)`` ``[S, L, theta, T_SS, T_DS]`` from one CoM state.

    ``com``, ``vel``: CoM position [m] and velocity [m/s] relative to the support foot in
    its frame, shape ``(2,)`` (shared) or ``(N, 2)``. ``support_side``: +1 left, -1 right
    (scalar or ``(N,)``). One call evaluates the whole batch.
    """
    cmd = np.atleast_2d(np.asarray(commands, dtype=float))
    com = np.asarray(com, dtype=float)
    vel = np.asarray(vel, dtype=float)
    omega = robot.omega
    c0 = com[..., 0] + 1j * com[..., 1]
    v0 = vel[..., 0] + 1j * vel[..., 1]
    xi0, eta0 = to_dcm(c0, v0, omega)
    S, L, theta, t_ss, t_ds = cmd.T
    swing = -np.asarray(support_side, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        p, xi_end, eta_end = step_terms(
            np, np.exp, xi0, eta0, S, L, theta, t_ss, t_ds, swing, omega,
            robot.generator_weight_position, robot.generator_weight_velocity,
        )
    hx, hy = robot.zmp_half_extent
    zmp_ok = (np.abs(p.real) <= hx) & (np.abs(p.imag) <= hy)
    kin_ok = footstep.kinematically_feasible(cmd, support_side, robot)
    c_end, v_end = from_dcm(xi_end, eta_end, omega)
    return StepResult(
        feasible=zmp_ok & kin_ok,
        kinematic_ok=kin_ok,
        zmp_ok=zmp_ok,
        zmp_offset=np.stack([p.real, p.imag], axis=-1),
        end_com=np.stack([c_end.real, c_end.imag], axis=-1),
        end_vel=np.stack([v_end.real, v_end.imag], axis=-1),
    )


def check_step(robot: Robot, com: complex, vel: complex, command: tuple[float, ...],
               support_side: int) -> tuple[bool, bool, complex, complex, complex]:
    """Scalar twin of :func:`check_steps` for one command (plain Python, no numpy).

    ``com``/``vel`` are complex (x + iy) relative to the support foot in its frame.
    Returns ``(kinematic_ok, zmp_ok, p, end_com, end_vel)``; the end state is relative to
    the new foot in its frame.
    """
    S, L, theta, t_ss, t_ds = command
    kin_ok = footstep.kinematic_violation(robot, S, L, theta, t_ss, t_ds, support_side) is None
    if not kin_ok and not (t_ss > 0 and t_ds > 0):
        nan = complex(math.nan, math.nan)
        return False, False, nan, nan, nan  # outside the box: no pattern to generate
    omega = robot.omega
    xi0, eta0 = to_dcm(com, vel, omega)
    p, xi_end, eta_end = step_terms(
        math, cmath.exp, xi0, eta0, S, L, theta, t_ss, t_ds, -support_side, omega,
        robot.generator_weight_position, robot.generator_weight_velocity,
    )
    hx, hy = robot.zmp_half_extent
    zmp_ok = abs(p.real) <= hx and abs(p.imag) <= hy
    c_end, v_end = from_dcm(xi_end, eta_end, omega)
    return kin_ok, zmp_ok, p, c_end, v_end


def step_feasible(robot: Robot, com: Any, vel: Any, command: Any, support_side: int) -> bool:
    """Whether one command ``[S, L, theta, T_SS, T_DS]`` is feasible from ``com`` [m] / ``vel`` [m/s] ``(2,)``
    (relative to the support foot, in its frame): :func:`check_step`, the env's own verdict, for a caller
    that holds the state as pairs (plain Python on one command: no numpy per-call overhead)."""
    kin_ok, zmp_ok, *_ = check_step(robot, complex(float(com[0]), float(com[1])), complex(float(vel[0]), float(vel[1])),
                                    tuple(float(x) for x in command), int(support_side))
    return bool(kin_ok and zmp_ok)


def steady_state(robot: Robot, command: Any, support_side: int) -> tuple[complex, complex]:
    """CoM ``(position, velocity)`` (complex, relative to the support foot) of the steady gait of ``command``.

    The start-of-step state that repeats (over two steps) when ``command`` is repeated
    forever; walking from it at ``command`` needs a zero ZMP offset.
    """
    S, L, theta, t_ss, t_ds = (float(x) for x in command)
    omega = robot.omega
    period = t_ss + t_ds
    swing = -support_side
    q = S + 1j * swing * L
    q_other = S - 1j * swing * L
    r = cmath.exp(-1j * theta)
    wd = omega * t_ds
    out = []
    for a, k in ((math.exp(omega * period), -math.expm1(wd) / wd),
                 (math.exp(-omega * period), math.expm1(-wd) / wd)):
        # Fixed point of the two-step map that starts with this side's step.
        out.append((r * r * a * k * q + r * k * q_other) / (1.0 - r * r * a * a))
    return from_dcm(out[0], out[1], omega)


# ------------------------------------------------------------------ trajectory within a step
class ComPath(NamedTuple):
    """The CoM's path through one step (:func:`com_path`): the closed forms' constants, complex ones complex.

    Fields: ``w`` = omega [1/s]; ``t_ss`` [s] and ``end`` = ``t_ss + t_ds`` [s]; ``p`` the single-support ZMP
    [m] and ``pd`` the double-support ZMP's velocity [m/s] (support foot's frame), ``pdw`` = ``pd / w`` [m];
    ``a_xi``, ``a_eta`` = ``xi0 - p``, ``eta0 - p`` and ``b_xi``, ``b_eta`` = ``xi1 - p - pdw``,
    ``eta1 - p + pdw`` [m] (``xi1``, ``eta1``: the state at the end of single support); ``origin`` [m] and the
    unit ``rot``: the support foot in the world. The fields are scalars or arrays of one array library
    (a JAX pytree), as the ``xp`` of the functions that read it.
    """

    w: Any
    t_ss: Any
    end: Any
    p: Any
    pd: Any
    pdw: Any
    a_xi: Any
    a_eta: Any
    b_xi: Any
    b_eta: Any
    origin: Any
    rot: Any


def com_path(xp: Any, omega: float, xi0: Any, eta0: Any, p: Any, q: Any, t_ss: Any, t_ds: Any,
             origin: Any = 0j, rot: Any = 1 + 0j) -> ComPath:
    """The path of a step from the start state ``xi0, eta0`` (relative to the support foot ``F``): single support
    for ``t_ss`` [s] with the ZMP at ``p``, then the ramp to ``q`` in ``t_ds`` [s] (complex, ``F``'s frame)."""
    xi1 = p + (xi0 - p) * xp.exp(omega * t_ss)
    eta1 = p + (eta0 - p) * xp.exp(-omega * t_ss)
    pd = (q - p) / t_ds
    pdw = pd / omega
    return ComPath(omega, t_ss, t_ss + t_ds, p, pd, pdw, xi0 - p, eta0 - p, xi1 - p - pdw, eta1 - p + pdw, origin, rot)


def com_state(xp: Any, path: ComPath, t: Any) -> tuple[Any, Any]:
    """CoM ``(position, velocity)`` [m, m/s] (complex, the support foot's frame) at ``t`` [s] after the step's
    start (held at the end after ``path.end``); ``xp``: :mod:`footstep_gym.scalars`, ``numpy`` or
    ``jax.numpy`` (``t`` of any shape there)."""
    w, p = path.w, path.p
    single = t <= path.t_ss
    tau = xp.where(path.end < t, path.end, t) - path.t_ss
    s = xp.where(single, t, tau)
    e_up, e_down = xp.exp(w * s), xp.exp((-w) * s)
    pt = p + path.pd * tau
    xi = xp.where(single, p + path.a_xi * e_up, pt + path.pdw + path.b_xi * e_up)
    eta = xp.where(single, p + path.a_eta * e_down, pt - path.pdw + path.b_eta * e_down)
    return 0.5 * (xi + eta), 0.5 * w * (xi - eta)


def com_world(xp: Any, path: ComPath, t: Any) -> tuple[Any, Any]:
    """The CoM's world ``(x, y)`` [m] at ``t`` [s]: ``origin + position * rot`` of :func:`com_state`."""
    c, _ = com_state(xp, path, t)
    z = path.origin + c * path.rot
    return z.real, z.imag


def com_speed_bound(xp: Any, path: ComPath, t_ds: Any) -> Any:
    """An upper bound of the CoM speed [m/s] over the whole step (``t_ds`` [s]: its double support).

    In single support ``v = omega/2 ((xi - p) - (eta - p))`` with ``|xi - p|`` growing and ``|eta - p|``
    shrinking monotonically; the ramp adds ``pd``.
    """
    w = path.w
    ss = 0.5 * w * (xp.abs(path.a_xi) * xp.exp(w * path.t_ss) + xp.abs(path.a_eta))
    ds = xp.abs(path.pd) + 0.5 * w * (xp.abs(path.b_xi) * xp.exp(w * t_ds) + xp.abs(path.b_eta))
    return xp.maximum(ss, ds)


class StepTrajectory:
    """CoM path ``c(t)`` through one step, in the support foot's frame (complex), for ``0 <= t <= T``.

    Single support with the ZMP at ``p``, then the ramp from ``p`` to ``q``; closed forms
    only (:func:`com_path`, :func:`com_state` on Python numbers). :meth:`speed_bound` is a rigorous
    upper bound of ``|v(t)|`` over the step.
    """

    __slots__ = ("t_ss", "t_ds", "path")

    def __init__(self, omega: float, com: complex, vel: complex, p: complex, q: complex,
                 t_ss: float, t_ds: float) -> None:
        self.t_ss, self.t_ds = t_ss, t_ds
        xi0, eta0 = to_dcm(com, vel, omega)
        self.path = com_path(scalars, omega, xi0, eta0, p, q, t_ss, t_ds)

    def state(self, t: float) -> tuple[complex, complex]:
        """``(c, v)`` at time ``t`` [s] after the start of the step."""
        return com_state(scalars, self.path, t)

    def world_path(self, origin: complex, rot: complex) -> "WorldPath":
        """The CoM's path in the world, ``t -> (x, y)``, for a support foot at ``origin`` turned by ``rot``."""
        return WorldPath(ComPath._make(self.path[:10] + (origin, rot)))

    def speed_bound(self) -> float:
        """An upper bound of the CoM speed over the whole step [m/s] (:func:`com_speed_bound`)."""
        return com_speed_bound(scalars, self.path, self.t_ds)


class WorldPath:
    """``t -> (x, y)``: a step's CoM position in the world (:func:`com_world` of its :class:`ComPath`).

    :attr:`sweep_params` hands the path's constants to the compiled collision sweep
    (:mod:`footstep_gym.kernels.sweep`), which evaluates the same function compiled.
    """

    __slots__ = ("path",)

    def __init__(self, path: ComPath) -> None:
        self.path = path

    def __call__(self, t: float) -> tuple[float, float]:
        return com_world(scalars, self.path, t)

    @property
    def sweep_params(self) -> list[float]:
        """``[w, t_ss, end, p, pd, pdw, a_xi, a_eta, b_xi, b_eta, origin, rot]``, complex ones as two floats
        (the layout of :mod:`footstep_gym.kernels.sweep`'s parameters)."""
        w, t_ss, end, p, pd, pdw, a_xi, a_eta, b_xi, b_eta, o, r = self.path
        return [w, t_ss, end, p.real, p.imag, pd.real, pd.imag, pdw.real, pdw.imag, a_xi.real, a_xi.imag, a_eta.real,
                a_eta.imag, b_xi.real, b_xi.imag, b_eta.real, b_eta.imag, o.real, o.imag, r.real, r.imag]
