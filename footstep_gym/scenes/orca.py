"""ORCA (RVO2's algorithm) as pure array functions: one simulator step for a crowd of agents, and a footstep of it.

Written with an array namespace ``xp`` (``numpy`` or ``jax.numpy``) and fixed shapes: RVO2's data-dependent loops
become loops over a fixed number of lines (``lax.fori_loop`` under JAX, Python's ``for`` under numpy) whose
iterations are masked, so the same function runs under ``jit``/``vmap``. It follows RVO2 (``snape/RVO2``,
``src/Agent.cc``, ``KdTree.cc``, ``RVOSimulator.cc``, ``Vector2.cc``) operation for operation, in float32 as
RVO2 computes, so its velocities and positions are RVO2's bit for bit:

* neighbours (``Agent::computeNeighbors``, ``insertAgentNeighbor``): the others whose squared distance
  ``absSq(position - other)`` is below ``neighborDist^2``, the nearest ``maxNeighbors`` of them by insertion
  into a sorted list, ties in the order they are visited. RVO2 visits the agents of a k-d tree leaf in the
  order they were added, and a crowd of at most ``RVO_MAX_LEAF_SIZE`` (10) agents is one leaf: here ties are
  broken by agent index, RVO2's order for such a crowd (a larger crowd could differ from RVO2 only where two
  squared distances are equal floats);
* the ORCA half-planes (``Agent::computeNewVelocity``, agent lines only: the crowd has no RVO2 obstacles),
  the collision case projected on the cut-off circle of the time step included;
* ``linearProgram1``, ``linearProgram2`` and the 3-D fallback ``linearProgram3``;
* ``RVOSimulator::doStep``: every agent's new velocity from the old ones, then ``position += velocity * dt``.

Vector operations are RVO2's: ``v / s`` is ``v * (1 / s)``, ``normalize(v)`` is ``v / abs(v)``,
``det(a, b) = a.x * b.y - a.y * b.x``. :func:`advance` is :class:`footstep_gym.scenarios.orca.OrcaCrowd`'s
footstep (preferred velocities towards the goals, the robot as an agent that sees no one, the chords) with the
reference's own precision: the preferred velocities and chords in the caller's float dtype (the reference's float64
Python), the ORCA step in float32.
"""

from __future__ import annotations

import math
from typing import Any, Callable, NamedTuple

import numpy as np

#: RVO2's ``RVO_EPSILON``.
EPSILON = np.float32(1e-5)
#: RVO2's ``RVO_MAX_LEAF_SIZE``: a crowd of at most this many agents is one k-d tree leaf (index order).
MAX_LEAF_SIZE = 10


class Agents(NamedTuple):
    """One crowd's agents (arrays leading with the agent, float32 but ``max_neighbors`` and ``active``).

    ``position``, ``velocity``, ``pref_velocity`` ``(n, 2)`` [m, m/s]; ``radius`` [m] (as ORCA sees it),
    ``max_speed`` [m/s], ``neighbor_dist`` [m], ``time_horizon`` [s] ``(n,)``; ``max_neighbors`` ``(n,)`` int;
    ``active`` ``(n,)`` bool (an inactive agent is no one's neighbour and stays where it is: padding).
    """

    position: Any
    velocity: Any
    pref_velocity: Any
    radius: Any
    max_speed: Any
    neighbor_dist: Any
    time_horizon: Any
    max_neighbors: Any
    active: Any


def _is_numpy(xp: Any) -> bool:
    return xp is np


def _fori(xp: Any, lower: Any, upper: Any, body: Callable, init: Any) -> Any:
    """``for i in range(lower, upper): init = body(i, init)``: a Python loop under numpy, ``lax.fori_loop`` else."""
    if _is_numpy(xp):
        for i in range(int(lower), int(upper)):
            init = body(i, init)
        return init
    import jax

    if isinstance(lower, int) and isinstance(upper, int):
        return jax.lax.fori_loop(lower, upper, body, init)
    return jax.lax.fori_loop(xp.asarray(lower, xp.int32), xp.asarray(upper, xp.int32), body, init)


def _nearest(xp: Any, key: Any, k: int) -> Any:
    """The first ``k`` columns of a stable argsort of ``key`` ``(n, n)`` along its rows: each entry's rank (the
    entries below it, then the equal ones before it) and, for each of the first ``k`` ranks, the entry holding it.
    Comparisons rather than a sort: for the small rows of a crowd far cheaper under ``vmap``."""
    n = key.shape[-1]
    below = xp.sum(key[:, None, :] < key[:, :, None], axis=-1)
    before = xp.tril(xp.ones((n, n), dtype=bool), -1)  # [j, l]: l before j
    equal = xp.sum((key[:, None, :] == key[:, :, None]) & before[None], axis=-1)
    rank = below + equal  # (n, n): a permutation of 0..n-1 along each row
    hit = rank[:, :, None] == xp.arange(k)[None, None, :]  # (n, n, k)
    return xp.sum(xp.where(hit, xp.arange(n)[None, :, None], 0), axis=1)


def _f32(xp: Any, x: Any) -> Any:
    return xp.asarray(x, dtype=xp.float32)


def _opaque(xp: Any, x: Any) -> Any:
    """``x``, behind a select XLA's compiler does not see through (NaN stays NaN, so the value is ``x``'s): it
    keeps XLA from fusing a product into the sum it enters (an FMA: one rounding fewer than C++'s) and from
    turning ``1 / sqrt(x)`` into an approximate ``rsqrt``. numpy's ``x`` as it is."""
    if _is_numpy(xp):
        return x
    return xp.where(xp.isnan(x), xp.asarray(np.nan, dtype=x.dtype), x)


def _hypot(xp: Any, x: Any, y: Any) -> Any:
    """``hypot(x, y)``: CPython's ``math.hypot`` (the reference's, correctly rounded) under numpy; ``xp.hypot``
    otherwise (within float64 rounding of it)."""
    if _is_numpy(xp):
        return np.vectorize(math.hypot, otypes=[np.float64])(x, y)
    return xp.hypot(x, y)


def _product(xp: Any) -> Callable[[Any, Any], Any]:
    """``a * b`` rounded to its dtype before any sum it enters, as C++ rounds it (:func:`_opaque`)."""
    return lambda a, b: _opaque(xp, a * b)


# ------------------------------------------------------------------ the linear programs
def linear_program1(lines: tuple, valid: Any, no: Any, radius: Any, opt: tuple, direction_opt: bool,
                    xp: Any = np) -> tuple[Any, Any, Any]:
    """RVO2's ``linearProgram1`` for line ``no`` (a scalar index) of every agent's ``lines`` ``(px, py, dx, dy)``
    (each ``(n, K)``, ``valid`` ``(n, K)``: the lines that are there): ``(ok, x, y)``, the result where ``ok``."""
    m = _product(xp)
    px, py, dx, dy = lines
    pnx, pny, dnx, dny = px[:, no], py[:, no], dx[:, no], dy[:, no]
    dot = m(pnx, dnx) + m(pny, dny)
    disc = m(dot, dot) + m(radius, radius) - (m(pnx, pnx) + m(pny, pny))
    fail = disc < 0
    sq = xp.sqrt(xp.where(fail, xp.float32(0), disc))
    t_left, t_right = -dot - sq, -dot + sq

    def body(i: Any, carry: tuple) -> tuple:
        fail, t_left, t_right = carry
        use = valid[:, i]
        dix, diy, pix, piy = dx[:, i], dy[:, i], px[:, i], py[:, i]
        den = m(dnx, diy) - m(dny, dix)
        num = m(dix, pny - piy) - m(diy, pnx - pix)
        parallel = xp.abs(den) <= EPSILON
        fail = fail | (use & parallel & (num < 0))
        t = num / xp.where(parallel, xp.float32(1), den)
        upd = use & ~parallel
        t_right = xp.where(upd & (den >= 0) & (t < t_right), t, t_right)  # std::min(tRight, t)
        t_left = xp.where(upd & (den < 0) & (t_left < t), t, t_left)  # std::max(tLeft, t)
        fail = fail | (upd & (t_left > t_right))
        return fail, t_left, t_right

    fail, t_left, t_right = _fori(xp, 0, no, body, (fail, t_left, t_right))
    ox, oy = opt
    if direction_opt:
        t = xp.where(m(ox, dnx) + m(oy, dny) > 0, t_right, t_left)
    else:
        t0 = m(dnx, ox - pnx) + m(dny, oy - pny)
        t = xp.where(t0 < t_left, t_left, xp.where(t0 > t_right, t_right, t0))
    return ~fail, pnx + m(t, dnx), pny + m(t, dny)


def linear_program2(lines: tuple, valid: Any, radius: Any, opt: tuple, direction_opt: bool,
                    xp: Any = np, program1: Callable | None = None) -> tuple[Any, Any, Any, Any]:
    """RVO2's ``linearProgram2``: ``(failed, fail_line, x, y)``; where ``failed``, ``fail_line`` is the line it
    failed on and ``(x, y)`` the result before it (as RVO2 leaves it).

    ``program1``: ``program1(violated, lines, valid, no, radius, opt, direction_opt)``, :func:`linear_program1`'s
    result for line ``no`` where ``violated`` (anything elsewhere); default :func:`linear_program1` on every agent."""
    m = _product(xp)
    ox, oy = opt
    k = lines[0].shape[1]
    if direction_opt:
        x, y = m(ox, radius), m(oy, radius)
    else:
        norm_sq = m(ox, ox) + m(oy, oy)
        outside = norm_sq > radius * radius
        inv = xp.float32(1) / _opaque(xp, xp.sqrt(xp.where(outside, norm_sq, xp.float32(1))))
        x = xp.where(outside, (ox * inv) * radius, ox)
        y = xp.where(outside, (oy * inv) * radius, oy)
    px, py, dx, dy = lines
    failed = xp.zeros(x.shape, dtype=bool)
    fail_line = xp.full(x.shape, k, dtype=xp.int32)

    def body(i: Any, carry: tuple) -> tuple:
        failed, fail_line, x, y = carry
        violated = valid[:, i] & ~failed & (m(dx[:, i], py[:, i] - y) - m(dy[:, i], px[:, i] - x) > 0)
        if program1 is None:
            ok, nx, ny = linear_program1(lines, valid, i, radius, opt, direction_opt, xp)
        else:
            ok, nx, ny = program1(violated, lines, valid, i, radius, opt, direction_opt)
        take = violated & ok
        x, y = xp.where(take, nx, x), xp.where(take, ny, y)
        now = violated & ~ok
        return failed | now, xp.where(now, i, fail_line), x, y

    # Lines past every agent's last are not there: the loop stops at the last one (under vmap, the batch's).
    return _fori(xp, 0, xp.max(xp.sum(valid, axis=1), initial=0), body, (failed, fail_line, x, y))


def linear_program3(lines: tuple, valid: Any, begin: Any, radius: Any, x: Any, y: Any,
                    xp: Any = np) -> tuple[Any, Any]:
    """RVO2's ``linearProgram3`` (no obstacle lines) from line ``begin`` ``(n,)`` on: the result ``(x, y)``."""
    m = _product(xp)
    px, py, dx, dy = lines
    k = px.shape[1]
    j = xp.arange(k)

    def body(i: Any, carry: tuple) -> tuple:
        distance, x, y = carry
        dix, diy, pix, piy = dx[:, i][:, None], dy[:, i][:, None], px[:, i][:, None], py[:, i][:, None]
        violated = valid[:, i] & (i >= begin) & (m(dix[:, 0], piy[:, 0] - y) - m(diy[:, 0], pix[:, 0] - x) > distance)
        determinant = m(dix, dy) - m(diy, dx)
        parallel = xp.abs(determinant) <= EPSILON
        same = m(dix, dx) + m(diy, dy) > 0
        keep = valid & (j < i)[None, :] & ~(parallel & same)
        q = (m(dx, piy - py) - m(dy, pix - px)) / xp.where(parallel, xp.float32(1), determinant)
        qx = xp.where(parallel, xp.float32(0.5) * (pix + px), pix + m(q, dix))
        qy = xp.where(parallel, xp.float32(0.5) * (piy + py), piy + m(q, diy))
        ux, uy = dx - dix, dy - diy
        norm_sq = m(ux, ux) + m(uy, uy)
        inv = xp.float32(1) / _opaque(xp, xp.sqrt(xp.where(keep, norm_sq, xp.float32(1))))
        proj = (qx, qy, ux * inv, uy * inv)
        failed, _, nx, ny = linear_program2(proj, keep, radius, (-diy[:, 0], dix[:, 0]), True, xp)
        take = violated & ~failed
        x, y = xp.where(take, nx, x), xp.where(take, ny, y)
        distance = xp.where(violated, m(dix[:, 0], piy[:, 0] - y) - m(diy[:, 0], pix[:, 0] - x), distance)
        return distance, x, y

    # From the first line any agent starts at (none: no iteration) to the last line any agent has.
    lower = xp.minimum(xp.min(begin, initial=k), k)
    upper = xp.max(xp.sum(valid, axis=1), initial=0)
    _, x, y = _fori(xp, lower, xp.maximum(lower, upper), body, (xp.zeros(x.shape, dtype=xp.float32), x, y))
    return x, y


def broadcast_batch(axis_size: int, in_batched: Any, args: tuple) -> tuple:
    """A ``jax.custom_batching.custom_vmap`` rule's ``args`` with the unbatched ones (``in_batched`` false)
    broadcast to the batch's ``axis_size``: every leaf then leads with the batch axis."""
    import jax
    import jax.numpy as jnp

    return jax.tree.map(lambda a, b: a if b else jnp.broadcast_to(a, (axis_size,) + jnp.shape(a)), args,
                        tuple(in_batched))


def _batch_rows(axis_size: int, in_batched: Any, args: tuple) -> tuple:
    """A ``custom_vmap`` rule's ``args`` with every crowd's agents as rows: :func:`broadcast_batch`, then each
    array's two leading axes (crowds, agents) made one."""
    import jax

    return jax.tree.map(lambda a: a.reshape((-1,) + a.shape[2:]), broadcast_batch(axis_size, in_batched, args))


def _compacted_program3() -> Callable[..., tuple[Any, Any]]:
    """:func:`linear_program3` under JAX whose batched form (``vmap`` over crowds) runs the program only on the
    agents whose 2-D program failed (``begin < K``), gathered from every crowd of the batch into
    :func:`_failing_slots` rows and scattered back (every failing agent, whatever the batch: where more fail than
    the rows hold, the program runs on all of them). Each agent's result depends on its own lines alone, so it is
    the one :func:`linear_program3` gives it in any company."""
    import jax
    import jax.numpy as jnp

    @jax.custom_batching.custom_vmap
    def program3(lines: tuple, valid: Any, begin: Any, radius: Any, x: Any, y: Any) -> tuple[Any, Any]:
        return linear_program3(lines, valid, begin, radius, x, y, jnp)

    @program3.def_vmap
    def batched(axis_size: int, in_batched: list, lines: tuple, valid: Any, begin: Any, radius: Any, x: Any,
                y: Any) -> tuple[tuple[Any, Any], tuple[bool, bool]]:
        lines, valid, begin, radius, x, y = _batch_rows(axis_size, in_batched, (lines, valid, begin, radius, x, y))
        k = valid.shape[1]
        failing = begin < k
        slots = _failing_slots(failing.shape[0])
        (index,) = jnp.nonzero(failing, size=slots, fill_value=0)  # a filler row: agent 0, written back unchanged

        def some() -> tuple[Any, Any]:
            x3, y3 = linear_program3(jax.tree.map(lambda a: a[index], lines), valid[index], begin[index],
                                     radius[index], x[index], y[index], jnp)
            return x.at[index].set(x3), y.at[index].set(y3)

        def every() -> tuple[Any, Any]:
            return linear_program3(lines, valid, begin, radius, x, y, jnp)

        x, y = jax.lax.cond(jnp.sum(failing) <= slots, some, every)
        shape = (axis_size, -1)
        return (x.reshape(shape), y.reshape(shape)), (True, True)

    return program3


def _failing_slots(agents: int) -> int:
    """The rows :func:`_compacted_program3` gathers the failing agents of ``agents`` into: a sixteenth of them, at
    least 8."""
    return min(agents, max(8, -(-agents // 16)))


_PROGRAM3: list[Callable[..., tuple[Any, Any]]] = []


def _gathered_program1(slots: int) -> Callable[..., tuple[Any, Any, Any]]:
    """:func:`linear_program2`'s ``program1`` under JAX: :func:`linear_program1` on the agents (rows) where the line
    is violated alone, gathered into ``slots`` rows and scattered back (none where no agent violates it; every
    agent where more do than the rows hold). Each agent's result depends on its own lines alone."""
    import jax
    import jax.numpy as jnp

    def program1(violated: Any, lines: tuple, valid: Any, no: Any, radius: Any, opt: tuple,
                 direction_opt: bool) -> tuple[Any, Any, Any]:
        rows = violated.shape[0]
        count = jnp.sum(violated)

        def none() -> tuple[Any, Any, Any]:
            return jnp.zeros(rows, bool), jnp.zeros(rows, jnp.float32), jnp.zeros(rows, jnp.float32)

        def some() -> tuple[Any, Any, Any]:
            (index,) = jnp.nonzero(violated, size=slots, fill_value=0)  # filler rows: agent 0, its own result
            ok, nx, ny = linear_program1(jax.tree.map(lambda a: a[index], lines), valid[index], no, radius[index],
                                         (opt[0][index], opt[1][index]), direction_opt, jnp)
            base = none()
            return base[0].at[index].set(ok), base[1].at[index].set(nx), base[2].at[index].set(ny)

        def every() -> tuple[Any, Any, Any]:
            return linear_program1(lines, valid, no, radius, opt, direction_opt, jnp)

        branch = jnp.where(count == 0, 0, jnp.where(count <= slots, 1, 2))
        return jax.lax.switch(branch, (none, some, every))

    return program1


def _compacted_program2() -> Callable[..., tuple[Any, Any, Any, Any]]:
    """:func:`linear_program2` (``direction_opt`` false) under JAX whose batched form (``vmap`` over crowds) runs
    on the agents of every crowd of the batch as rows, line by line to the batch's last line, each line's
    :func:`linear_program1` on the agents that violate it alone (:func:`_gathered_program1`, into
    :func:`_violating_slots` rows). Each agent's result is the one :func:`linear_program2` gives it in any company."""
    import jax
    import jax.numpy as jnp

    @jax.custom_batching.custom_vmap
    def program2(lines: tuple, valid: Any, radius: Any, opt: tuple) -> tuple[Any, Any, Any, Any]:
        return linear_program2(lines, valid, radius, opt, False, jnp)

    @program2.def_vmap
    def batched(axis_size: int, in_batched: list, lines: tuple, valid: Any, radius: Any,
                opt: tuple) -> tuple[tuple[Any, Any, Any, Any], tuple[bool, bool, bool, bool]]:
        lines, valid, radius, opt = _batch_rows(axis_size, in_batched, (lines, valid, radius, opt))
        program1 = _gathered_program1(_violating_slots(valid.shape[0]))
        out = linear_program2(lines, valid, radius, opt, False, jnp, program1)
        return tuple(a.reshape((axis_size, -1)) for a in out), (True, True, True, True)

    return program2


def _violating_slots(agents: int) -> int:
    """The rows :func:`_gathered_program1` gathers the agents that violate a line into: :func:`_failing_slots`'s."""
    return _failing_slots(agents)


_PROGRAM2: list[Callable[..., tuple[Any, Any, Any, Any]]] = []


def program2(xp: Any) -> Callable[..., tuple[Any, Any, Any, Any]]:
    """:func:`linear_program2` (``direction_opt`` false) for ``xp`` as ``(lines, valid, radius, opt)``: under JAX,
    :func:`_compacted_program2`."""
    if _is_numpy(xp):
        return lambda lines, valid, radius, opt: linear_program2(lines, valid, radius, opt, False, xp)
    if not _PROGRAM2:
        _PROGRAM2.append(_compacted_program2())
    return _PROGRAM2[0]


def program3(xp: Any) -> Callable[..., tuple[Any, Any]]:
    """:func:`linear_program3` for ``xp`` without its ``xp`` argument: under JAX, :func:`_compacted_program3`."""
    if _is_numpy(xp):
        return lambda lines, valid, begin, radius, x, y: linear_program3(lines, valid, begin, radius, x, y, xp)
    if not _PROGRAM3:
        _PROGRAM3.append(_compacted_program3())
    return _PROGRAM3[0]


# ------------------------------------------------------------------ neighbours, half-planes, a step
def neighbors(agents: Agents, k: int, xp: Any = np) -> tuple[Any, Any]:
    """Each agent's neighbours ``(n, k)`` (indices, nearest first, ties by index) and which slots hold one."""
    x, y = agents.position[:, 0], agents.position[:, 1]
    n = x.shape[0]
    m = _product(xp)
    ddx, ddy = x[:, None] - x[None, :], y[:, None] - y[None, :]
    dist_sq = m(ddx, ddx) + m(ddy, ddy)
    range_sq = agents.neighbor_dist * agents.neighbor_dist
    cand = ((dist_sq < range_sq[:, None]) & ~xp.eye(n, dtype=bool) & agents.active[None, :]
            & agents.active[:, None])
    order = _nearest(xp, xp.where(cand, dist_sq, xp.float32(np.inf)), k)
    count = xp.minimum(xp.sum(cand, axis=1), agents.max_neighbors)
    return order, xp.arange(k)[None, :] < count[:, None]


def orca_lines(agents: Agents, order: Any, valid: Any, time_step: Any, xp: Any = np) -> tuple:
    """The agent ORCA lines ``(px, py, dx, dy)`` ``(n, k)`` of ``Agent::computeNewVelocity``, neighbour by neighbour."""
    m = _product(xp)
    pos, vel, radius = agents.position, agents.velocity, agents.radius
    rpx = pos[order, 0] - pos[:, 0:1]
    rpy = pos[order, 1] - pos[:, 1:2]
    rvx = vel[:, 0:1] - vel[order, 0]
    rvy = vel[:, 1:2] - vel[order, 1]
    dist_sq = m(rpx, rpx) + m(rpy, rpy)
    cr = radius[:, None] + radius[order]
    cr_sq = m(cr, cr)
    one = xp.float32(1)
    inv_th = (one / agents.time_horizon)[:, None]
    inv_ts = one / _f32(xp, time_step)
    # No collision: cut-off circle or legs.
    wx, wy = rvx - m(inv_th, rpx), rvy - m(inv_th, rpy)
    w_len_sq = m(wx, wx) + m(wy, wy)
    dot = m(wx, rpx) + m(wy, rpy)
    circle = (dot < 0) & (dot * dot > cr_sq * w_len_sq)
    w_len = xp.sqrt(w_len_sq)
    inv_w = one / xp.where(valid & circle, w_len, one)
    ux_c, uy_c = wx * inv_w, wy * inv_w
    dcx, dcy = uy_c, -ux_c
    sc = m(cr, inv_th) - w_len
    hit = ~(dist_sq > cr_sq)
    legs = valid & ~circle & ~hit
    leg = xp.sqrt(xp.where(legs, dist_sq - cr_sq, one))
    inv_d = one / xp.where(legs, dist_sq, one)
    left = m(rpx, wy) - m(rpy, wx) > 0
    dlx = xp.where(left, (m(rpx, leg) - m(rpy, cr)) * inv_d, -((m(rpx, leg) + m(rpy, cr)) * inv_d))
    dly = xp.where(left, (m(rpx, cr) + m(rpy, leg)) * inv_d, -((m(-rpx, cr) + m(rpy, leg)) * inv_d))
    s = m(rvx, dlx) + m(rvy, dly)
    ulx, uly = m(s, dlx) - rvx, m(s, dly) - rvy
    nx = xp.where(circle, dcx, dlx)
    ny = xp.where(circle, dcy, dly)
    ux = xp.where(circle, sc * ux_c, ulx)
    uy = xp.where(circle, sc * uy_c, uly)
    # Collision: the cut-off circle of the time step.
    wx2, wy2 = rvx - m(inv_ts, rpx), rvy - m(inv_ts, rpy)
    w2 = xp.sqrt(m(wx2, wx2) + m(wy2, wy2))
    inv_w2 = one / xp.where(valid & hit, w2, one)
    ux2, uy2 = wx2 * inv_w2, wy2 * inv_w2
    sc2 = m(cr, inv_ts) - w2
    dx = xp.where(hit, uy2, nx)
    dy = xp.where(hit, -ux2, ny)
    ux = xp.where(hit, sc2 * ux2, ux)
    uy = xp.where(hit, sc2 * uy2, uy)
    half = xp.float32(0.5)
    px = vel[:, 0:1] + m(half, ux)
    py = vel[:, 1:2] + m(half, uy)
    zero = xp.float32(0)
    return (xp.where(valid, px, zero), xp.where(valid, py, zero), xp.where(valid, dx, zero),
            xp.where(valid, dy, zero))


def new_velocities(agents: Agents, time_step: Any, k: int, xp: Any = np) -> Any:
    """Every agent's ``newVelocity_`` ``(n, 2)`` (``computeNeighbors`` then ``computeNewVelocity``), float32."""
    order, valid = neighbors(agents, k, xp)
    lines = orca_lines(agents, order, valid, time_step, xp)
    opt = (agents.pref_velocity[:, 0], agents.pref_velocity[:, 1])
    failed, fail_line, x, y = program2(xp)(lines, valid, agents.max_speed, opt)
    x3, y3 = program3(xp)(lines, valid, xp.where(failed, fail_line, k), agents.max_speed, x, y)
    return xp.stack([xp.where(failed, x3, x), xp.where(failed, y3, y)], axis=1)


def do_step(agents: Agents, time_step: Any, k: int | None = None, xp: Any = np) -> Agents:
    """``RVOSimulator::doStep``: new velocities from the old ones, then ``position += velocity * time_step``.

    ``k``: neighbour slots (default: the most any agent considers, at most ``n - 1``); ``time_step`` [s] is
    rounded to float32 as RVO2's ``setTimeStep`` does."""
    if k is None:
        k = neighbor_slots(agents.max_neighbors, agents.position.shape[0])
    dt = _f32(xp, time_step)
    vel = new_velocities(agents, dt, k, xp)
    vel = xp.where(agents.active[:, None], vel, agents.velocity)
    pos = xp.where(agents.active[:, None], agents.position + _product(xp)(vel, dt), agents.position)
    return agents._replace(position=pos, velocity=vel)


def neighbor_slots(max_neighbors: Any, n: int) -> int:
    """The neighbour slots a crowd of ``n`` agents needs: the most any agent considers, at most ``n - 1``."""
    return int(min(int(np.max(np.asarray(max_neighbors), initial=0)), max(n - 1, 0)))


# ------------------------------------------------------------------ a footstep of the crowd
class Crowd(NamedTuple):
    """An ORCA crowd between footsteps: ``agents`` (pedestrians, then the robot's agent when it is one),
    each pedestrian's ``goal`` and ``origin`` ``(n, 2)`` [m] and ``radius`` ``(n,)`` [m] (the body's) in the
    caller's float dtype, ``speed`` ``(n,)`` its preferred speed [m/s] (the caller's dtype)."""

    agents: Agents
    goal: Any
    origin: Any
    radius: Any
    speed: Any


def substeps(duration: Any, time_step: float, xp: Any = np) -> Any:
    """The number of equal ORCA steps, none longer than ``time_step``, over ``duration`` [s]
    (:func:`footstep_gym.scenarios.orca.substeps`)."""
    return xp.maximum(1, xp.ceil(duration / time_step - 1e-9)).astype(xp.int32)


def preferred(crowd: Crowd, xp: Any = np) -> tuple[Crowd, Any]:
    """Before an ORCA step: a pedestrian within its radius of its goal swaps goal and origin; each one's
    preferred velocity ``(goal - position)`` capped at its speed, in the caller's dtype (rounded to float32 by
    the caller as RVO2's ``setAgentPrefVelocity`` does)."""
    n = crowd.goal.shape[0]
    pos = xp.asarray(crowd.agents.position[:n], dtype=crowd.goal.dtype)
    d = crowd.goal - pos
    reached = _hypot(xp, d[:, 0], d[:, 1]) < crowd.radius
    goal = xp.where(reached[:, None], crowd.origin, crowd.goal)
    origin = xp.where(reached[:, None], crowd.goal, crowd.origin)
    d = goal - pos
    dist = _hypot(xp, d[:, 0], d[:, 1])
    v = crowd.speed
    far = dist > v
    scale = v / xp.where(far, dist, 1.0)
    pref = xp.where(far[:, None], d * scale[:, None], d)  # enters no sum: no FMA
    return crowd._replace(goal=goal, origin=origin), pref


def advance(crowd: Crowd, duration: Any, time_step: Any, max_substeps: int | None = None, robot: tuple | None = None,
            k: int | None = None, xp: Any = np) -> tuple[Crowd, Any, Any]:
    """:meth:`footstep_gym.scenarios.orca.OrcaCrowd.advance`: ORCA over the next ``duration`` [s] in
    ``substeps(duration)`` equal steps (at most ``max_substeps`` where given; under ``vmap`` the loop runs as
    many steps as the batch's longest footstep needs, each crowd keeping its own);
    ``(crowd, start, chords)``: the pedestrians' positions at the start [m] and chord velocities [m/s] over it, in
    the caller's dtype.

    ``robot``: ``(position, velocity)`` of the robot's CoM at the start and its chord over the footstep when the
    crowd's last agent is the robot's (set before every step, as the reference does); ``None`` otherwise.
    """
    n = crowd.goal.shape[0]
    steps = substeps(duration, time_step, xp)
    dt = duration / steps
    start = crowd.agents.position[:n]
    if k is None:
        k = neighbor_slots(crowd.agents.max_neighbors, crowd.agents.position.shape[0])

    def body(step: Any, c: Crowd) -> Crowd:
        return crowd_step(c, step, dt, robot, k, xp)

    upper = steps if max_substeps is None else xp.minimum(steps, max_substeps)
    crowd = _fori(xp, 0, int(upper) if _is_numpy(xp) else upper, body, crowd)
    return chords(crowd, start, duration, xp)


def crowd_step(crowd: Crowd, step: Any, dt: Any, robot: tuple | None, k: int, xp: Any = np) -> Crowd:
    """Step ``step`` of :func:`advance`, ``dt`` [s] long: each pedestrian's preferred velocity
    (:func:`preferred`), the robot's agent set where ``robot`` is given, then :func:`do_step`."""
    n = crowd.goal.shape[0]
    c2, pref = preferred(crowd, xp)
    agents = c2.agents
    pref32 = _f32(xp, pref)
    if robot is not None:
        (rx, ry), (rvx, rvy) = robot
        s = step * dt
        m = _product(xp)
        rpos = _f32(xp, xp.stack([rx + m(rvx, s), ry + m(rvy, s)]))
        rvel = _f32(xp, xp.stack([rvx, rvy]))
        agents = agents._replace(position=_set_row(xp, agents.position, n, rpos),
                                 velocity=_set_row(xp, agents.velocity, n, rvel))
        pref32 = xp.concatenate([pref32, rvel[None]], axis=0)
    else:
        pref32 = xp.concatenate([pref32, agents.pref_velocity[n:]], axis=0)
    agents = do_step(agents._replace(pref_velocity=pref32), dt, k, xp)
    return c2._replace(agents=agents)


def chords(crowd: Crowd, start: Any, duration: Any, xp: Any = np) -> tuple[Crowd, Any, Any]:
    """The end of :func:`advance`: ``(crowd, start, chords)`` from the pedestrians' positions at the start
    ``start`` [m] (float32, as ORCA holds them) and ``crowd`` after ``duration`` [s], each chord capped at the
    pedestrian's speed, in the crowd's float dtype."""
    n = crowd.goal.shape[0]
    hi = crowd.goal.dtype
    end = xp.asarray(crowd.agents.position[:n], dtype=hi)
    start_hi = xp.asarray(start, dtype=hi)
    chord = (end - start_hi) / duration
    v = _hypot(xp, chord[:, 0], chord[:, 1])
    over = v > crowd.speed
    chord = xp.where(over[:, None], chord * (crowd.speed / xp.where(over, v, 1.0))[:, None], chord)
    return crowd, start_hi, chord


def _set_row(xp: Any, a: Any, i: int, row: Any) -> Any:
    if _is_numpy(xp):
        a = a.copy()
        a[i] = row
        return a
    return a.at[i].set(row)


def crowd_of(starts: Any, goals: Any, radii: Any, speeds: Any, neighbor_dist: float, max_neighbors: int,
             time_horizon: float, safety_space: float, robot_radius: float | None = None, xp: Any = np,
             dtype: Any = np.float64) -> Crowd:
    """A crowd at rest at ``starts`` as :class:`~footstep_gym.scenarios.orca.OrcaCrowd` builds it (each agent's
    ORCA radius its own plus ``safety_space``, max speed its preferred speed; ``robot_radius``: the robot is an
    agent after them, ORCA radius ``robot_radius + safety_space``, that sees no one, parked far away)."""
    starts, goals = xp.asarray(starts, dtype=dtype), xp.asarray(goals, dtype=dtype)
    radii, speeds = xp.asarray(radii, dtype=dtype), xp.asarray(speeds, dtype=dtype)
    n = starts.shape[0]
    robot = robot_radius is not None
    m = n + int(robot)
    pos = _f32(xp, starts)
    radius = _f32(xp, radii + safety_space)
    speed = _f32(xp, speeds)
    nd = xp.full((n,), neighbor_dist, dtype=xp.float32)
    mn = xp.full((n,), max_neighbors, dtype=xp.int32)
    if robot:
        pos = xp.concatenate([pos, xp.asarray([[1.0e6, 1.0e6]], dtype=xp.float32)], axis=0)
        radius = xp.concatenate([radius, _f32(xp, [robot_radius + safety_space])])
        speed = xp.concatenate([speed, _f32(xp, [1.0e3])])
        nd = xp.concatenate([nd, _f32(xp, [0.0])])
        mn = xp.concatenate([mn, xp.zeros((1,), dtype=xp.int32)])
    agents = Agents(pos, xp.zeros((m, 2), dtype=xp.float32), xp.zeros((m, 2), dtype=xp.float32), radius, speed, nd,
                    xp.full((m,), time_horizon, dtype=xp.float32), mn, xp.ones((m,), dtype=bool))
    return Crowd(agents, goals, starts, radii, speeds)


__all__ = ["Agents", "Crowd", "EPSILON", "MAX_LEAF_SIZE", "advance", "broadcast_batch", "chords", "crowd_of",
           "crowd_step", "do_step", "linear_program1", "linear_program2", "linear_program3", "neighbor_slots",
           "neighbors", "new_velocities", "orca_lines", "preferred", "substeps"]
