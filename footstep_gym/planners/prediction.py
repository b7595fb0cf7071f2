"""Time-aware obstacle prediction for the planners: clearance of points at their own times.

:meth:`footstep_gym.sensing.Snapshot.shapes_at` freezes every obstacle at *one* instant.
A planner that looks several steps ahead needs each point of a candidate body path
checked against the obstacles *at the time the robot would be there* (a node at depth
``d`` of the tree is reached about ``d * T`` after now). :class:`ObstaclePredictor` does
that for a whole batch of ``(point, time)`` pairs in one numpy evaluation, with the same
constant-velocity / constant-angular-velocity extrapolation as ``shapes_at`` (the tests
check that the two agree), built only from what the
:class:`~footstep_gym.sensing.Snapshot` exposes.

Beyond ``horizon`` [s] the extrapolation is not trusted: moving obstacles are left out
there and only obstacles that do not move (walls, posts) are checked. A greedy planner
replans every step, so what it needs from the far future is only "is there a way
around the static scene".

Every shape is held as a thick segment (a circle is a segment of zero length) and 2D
points as complex numbers ``x + iy``, so one vectorised expression serves all shapes.
"""

from __future__ import annotations

import functools
from typing import Sequence

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.robot import Robot
from footstep_gym.sensing import ObstacleView, Snapshot


def _moves(view: ObstacleView) -> bool:
    return (not view.static) and (any(float(c) != 0.0 for c in view.velocity) or view.angular_velocity != 0.0)


def steady_motion_horizons(previous: Snapshot | None, snapshot: Snapshot, short_horizon: float,
                           speed_tolerance: float, turn_tolerance: float) -> dict[str, float]:
    """``{name: short_horizon}`` for the shapes whose sensed motion changed since ``previous``.

    A constant-velocity (or constant-turn) extrapolation is only as good as the motion is
    steady. A robot can judge that from what it sensed one step ago: a shape whose velocity
    changed by more than ``speed_tolerance`` [m/s] (or angular velocity by more than
    ``turn_tolerance`` [rad/s]) is predicted only ``short_horizon`` [s] ahead. Without a
    previous snapshot, every shape keeps the long horizon.
    """
    if previous is None:
        return {}
    before = {v.name: v for v in previous.obstacles}
    out: dict[str, float] = {}
    for v in snapshot.obstacles:
        old = before.get(v.name)
        if old is None or v.static:
            continue
        dv = float(np.hypot(v.velocity[0] - old.velocity[0], v.velocity[1] - old.velocity[1]))
        if dv > speed_tolerance or abs(v.angular_velocity - old.angular_velocity) > turn_tolerance:
            out[v.name] = short_horizon
    return out


def sensed_accelerations(history: Sequence[Snapshot], snapshot: Snapshot,
                         pooled: bool = False) -> dict[str, tuple[float, float]]:
    """``{name: (ax, ay)}`` [m/s^2]: each moving shape's acceleration estimated from what was sensed.

    A finite difference of the sensed velocities between the oldest snapshot of ``history`` (the
    snapshots of earlier steps, oldest first) that saw the shape and ``snapshot``:
    ``(v_now - v_then) / (t_now - t_then)``. Only a robot's own observations enter (never the
    simulator's schedule). Shapes whose sensed velocity did not change (a car, a door turning
    steadily) are left out: their prediction stays exactly constant-velocity. ``pooled``: the
    shapes whose velocity changed share one acceleration, the mean of theirs (a group that speeds
    up together, its members' own back-and-forth averaged out).
    """
    out: dict[str, tuple[float, float]] = {}
    if not history:
        return out
    for v in snapshot.obstacles:
        if v.static:
            continue
        for old_snapshot in history:  # oldest first: the longest baseline that saw this shape
            old = next((o for o in old_snapshot.obstacles if o.name == v.name), None)
            dt = snapshot.time - old_snapshot.time
            if old is None or not dt > 0:
                continue
            dvx, dvy = float(v.velocity[0] - old.velocity[0]), float(v.velocity[1] - old.velocity[1])
            if dvx != 0.0 or dvy != 0.0:
                out[v.name] = (dvx / dt, dvy / dt)
            break
    if pooled and out:
        mean = tuple(float(m) for m in np.mean(np.array(list(out.values())), axis=0))
        out = {name: mean for name in out}
    return out


def centre_line_gap2(p: np.ndarray, centre: np.ndarray, rot: np.ndarray, a: np.ndarray, ab: np.ndarray,
                     ab2: np.ndarray) -> np.ndarray:
    """Squared distances ``(N, S)`` [m^2] from points ``p`` (N,) to shapes' centre lines (complex, world frame).

    A shape's body sits at ``centre`` turned by ``rot`` (unit complex; both (N, S) or broadcastable); its centre
    line runs from ``a`` to ``a + ab`` in the body frame, ``ab2 = |ab|^2`` (a circle: ``ab = 0``).
    """
    ap = p[:, None] - (centre + rot * a)
    ab_world = rot * ab
    u = (ap * ab_world.conj()).real / np.where(ab2 > 0, ab2, 1.0)
    np.clip(u, 0.0, 1.0, out=u)
    d = ap - u * ab_world
    return d.real ** 2 + d.imag ** 2


class ObstaclePredictor:
    """Clearance of body points at given times against the obstacles of a :class:`Snapshot`.

    ``horizon`` [s]: moving obstacles are predicted up to this time and ignored beyond it
    (``np.inf``: always predicted). ``moving_only``: leave obstacles that do not move out.
    ``horizons``: ``{shape name: horizon [s]}``, a shorter horizon for shapes whose motion
    is known to be less predictable (see :func:`steady_motion_horizons`).
    ``accelerations``: ``{shape name: (ax, ay)}`` [m/s^2] (:func:`sensed_accelerations`): such a
    shape's centre is predicted at ``p + v t + a tau (t - tau / 2)``, ``tau = min(t,
    acceleration_horizon)``: accelerating for ``acceleration_horizon`` [s], then at the velocity it
    reached (``p + v t + a t^2 / 2`` up to the cap). Other shapes: ``p + v t``.
    """

    def __init__(self, snapshot: Snapshot, horizon: float = np.inf, moving_only: bool = False,
                 horizons: dict[str, float] | None = None,
                 accelerations: dict[str, tuple[float, float]] | None = None,
                 acceleration_horizon: float = 0.0) -> None:
        self.horizon = float(horizon)
        horizons = horizons or {}
        accelerations = accelerations or {}
        views = [v for v in snapshot.obstacles if _moves(v) or not moving_only]
        n = len(views)
        # Per shape: moving shapes are predicted up to their own horizon (``horizons[name]``, else ``horizon``).
        self._horizon = np.array([min(self.horizon, horizons.get(v.name, np.inf)) if _moves(v) else np.inf
                                  for v in views], dtype=float).reshape(n)

        def col(values: list) -> np.ndarray:
            return np.array(values, dtype=float).reshape(n)

        def cplx(pairs: list) -> np.ndarray:
            arr = np.array(pairs, dtype=float).reshape(n, 2)
            return arr[:, 0] + 1j * arr[:, 1]

        self._position = cplx([v.position for v in views])
        self._velocity = cplx([v.velocity for v in views])
        self._angle = col([v.angle for v in views])
        self._omega = col([v.angular_velocity for v in views])
        self._a = cplx([v.a for v in views])  # body frame
        self._ab = cplx([v.b if v.kind == "segment" else v.a for v in views]) - self._a  # 0 for a circle
        self._ab2 = np.abs(self._ab) ** 2
        self._radius = col([v.radius for v in views])
        # Sensed accelerations, each held for acceleration_horizon [s] (0: none; the prediction is p + v t).
        cap = float(acceleration_horizon)
        accelerating = [v.name in accelerations and _moves(v) and cap > 0 for v in views]
        self._acceleration = cplx([accelerations[v.name] if on else (0.0, 0.0) for v, on in zip(views, accelerating)])
        self._acceleration_cap = col([cap if on else 0.0 for on in accelerating])
        self._accelerates = bool(any(accelerating))
        # The shapes as the compiled kernels read them: one row per shape, its 16 columns named in kernels.py
        # (kernels.SHAPE_COLUMNS; built here without importing kernels, which imports numba).
        self.kernel_radius = np.ascontiguousarray(self._radius)
        self.kernel_horizon = np.ascontiguousarray(self._horizon)
        self.kernel_shapes = np.ascontiguousarray(np.stack([
            self._position.real, self._position.imag, self._velocity.real, self._velocity.imag, self._angle,
            self._omega, np.cos(self._angle), np.sin(self._angle), self._a.real, self._a.imag, self._ab.real,
            self._ab.imag, self._ab2, self._acceleration.real, self._acceleration.imag, self._acceleration_cap],
            axis=1).reshape(n, 16))

    @property
    def n_shapes(self) -> int:
        return self._radius.size

    def _distance2(self, points: np.ndarray, times: np.ndarray) -> np.ndarray:
        """Squared distances ``(N, S)`` from each point to each shape's centre line (``inf``: not checked)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        p = pts[:, 0] + 1j * pts[:, 1]
        tt = np.broadcast_to(np.asarray(times, dtype=float), p.shape)[:, None]
        rot = np.exp(1j * (self._angle + self._omega * tt))
        centre = self._position + self._velocity * tt
        if self._accelerates:  # accelerating for tau = min(t, cap), then at the velocity reached
            tau = np.minimum(tt, self._acceleration_cap)
            centre = centre + self._acceleration * (tau * (tt - 0.5 * tau))
        d2 = centre_line_gap2(p, centre, rot, self._a, self._ab, self._ab2)
        if np.isfinite(self._horizon).any():
            d2[tt > self._horizon] = np.inf
        return d2

    def distances(self, points: np.ndarray, times: np.ndarray) -> np.ndarray:
        """Signed distance [m] from point ``i`` at time ``times[i]`` to each shape's surface: ``(N, S)``.

        Shapes that move are ``+inf`` for times beyond the horizon.
        """
        return np.sqrt(self._distance2(points, times)) - self._radius

    def clearance(self, points: np.ndarray, times: np.ndarray) -> np.ndarray:
        """Distance [m] from each point (at its own time) to the nearest shape surface, ``(N,)``."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if not self.n_shapes:
            return np.full(len(pts), np.inf)
        return (np.sqrt(self._distance2(pts, times)) - self._radius).min(axis=1)

    def free(self, points: np.ndarray, times: np.ndarray, safe_distance: float) -> np.ndarray:
        """``clearance >= safe_distance`` for each point, ``(N,)`` bool (no square roots).

        One compiled loop (:func:`.kernels.points_free`) over points and shapes; its numpy twin is
        :meth:`free_numpy` (the tests hold the two equal).
        """
        from footstep_gym.planners import kernels  # imports numba: only on the compiled route

        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        times = np.broadcast_to(np.asarray(times, dtype=float), pts.shape[:1])
        out = np.empty(len(pts), dtype=bool)
        kernels.points_free(np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]),
                            np.ascontiguousarray(times), self.kernel_shapes, (self._radius + safe_distance) ** 2,
                            self.kernel_horizon, out)
        return out

    def free_numpy(self, points: np.ndarray, times: np.ndarray, safe_distance: float) -> np.ndarray:
        """:meth:`free` in plain numpy: the reference implementation, the test oracle of :meth:`free`
        (``tests/test_kernels.py``), and the route of ``kernels.compiled: false``."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        return (self._distance2(pts, times) >= (self._radius + safe_distance) ** 2).all(axis=1)


@functools.lru_cache(maxsize=8)
def step_fractions(samples: int) -> np.ndarray:
    """``samples`` fractions of a step, ends included (read-only: shared between calls)."""
    out = np.linspace(0.0, 1.0, samples)
    out.flags.writeable = False
    return out


def body_path_points(starts: np.ndarray, ends: np.ndarray, t_start: np.ndarray, t_end: np.ndarray,
                     samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Points and times along straight body-path segments, ``samples`` per segment, ends included.

    ``starts``/``ends`` ``(N, 2)``, ``t_start``/``t_end`` ``(N,)``; returns ``(N * samples, 2)``
    points and ``(N * samples,)`` times, segment by segment.
    """
    s = step_fractions(samples)
    pts = starts[:, None, :] + s[None, :, None] * (ends - starts)[:, None, :]
    times = t_start[:, None] + s[None, :] * (t_end - t_start)[:, None]
    return pts.reshape(-1, 2), times.reshape(-1)


@functools.lru_cache(maxsize=4096)
def sway_band(robot: Robot, period: float, samples: int = 24) -> tuple[float, float]:
    """``(toward, away)`` [m]: how far the CoM strays from the feet's centre line during a step.

    In the steady gait of stepping at ``period`` (``T_SS = period - nominal T_DS``, nominal
    side stride) the CoM sways towards the support foot by up to ``toward`` and away from
    it by up to ``away`` (both shrink with the period), from the closed forms of
    :class:`footstep_gym.lipm.StepTrajectory`.
    """
    t_ds = robot.nominal_t_ds
    t_ss = max(period - t_ds, robot.t_ss[0])
    L = robot.nominal_side_stride
    command = (0.0, L, 0.0, t_ss, t_ds)
    com, vel = lipm.steady_state(robot, command, footstep.RIGHT)
    _, _, p, _, _ = lipm.check_step(robot, com, vel, command, footstep.RIGHT)
    traj = lipm.StepTrajectory(robot.omega, com, vel, p, complex(0.0, L), t_ss, t_ds)
    lateral = [traj.state(t)[0].imag - 0.5 * L for t in np.linspace(0.0, t_ss + t_ds, samples)]
    return max(-min(lateral), 0.0), max(max(lateral), 0.0)


class BodyModel:
    """The robot's body circle along a walk of nodes, checked against an :class:`ObstaclePredictor`.

    The planners' walks are chains of *nodes* (robot centres, paper Fig. 5); the body
    moves along the midpoints of consecutive nodes. The LIPM's lateral sway is folded in
    per period: the circle is shifted towards the support foot by ``(toward - away) / 2``
    and its radius grown by ``(toward + away) / 2`` (:func:`sway_band`), plus
    ``margin`` [m] for everything else (prediction error, turning). ``sway=False`` (switch
    ``additions.com_sway`` off; the paper's "robot radius"): one circle on the centre line at
    every period, grown by the larger sway of the nominal gait so that it holds the body there.

    ``compiled``: :meth:`free` asks :meth:`ObstaclePredictor.free` (the compiled kernel) or its numpy
    twin :meth:`ObstaclePredictor.free_numpy`. The planners' stages put every body check on the route
    of ``configs/planner.yaml``'s ``kernels.compiled`` (:func:`.walks.on_route`, :meth:`routed`).
    """

    def __init__(self, predictor: ObstaclePredictor, robot: Robot, margin: float, sway: bool = True,
                 compiled: bool = True) -> None:
        self.predictor = predictor
        self.robot = robot
        self.margin = margin
        self.with_sway = sway
        self.compiled = compiled

    def routed(self, compiled: bool) -> BodyModel:
        """This body check with its points checked by the compiled kernel (``compiled``) or in numpy."""
        if compiled == self.compiled:
            return self
        return BodyModel(self.predictor, self.robot, self.margin, sway=self.with_sway, compiled=compiled)

    def sway(self, period: float) -> tuple[float, float]:
        """``(shift towards the support foot, radius growth)`` [m] at ``period`` (cached per 0.1 ms of period)."""
        if not self.with_sway:
            return 0.0, max(sway_band(self.robot, round(self.robot.nominal_period, 4)))
        toward, away = sway_band(self.robot, round(period, 4))
        return 0.5 * (toward - away), 0.5 * (toward + away)

    def shift_and_clearance(self, period: float) -> tuple[float, float]:
        """``(shift towards the support foot, clearance needed)`` [m] of the body circle at ``period`` [s]."""
        shift, grow = self.sway(period)
        return shift, self.robot.body_radius + self.margin + grow

    def _body(self, points: np.ndarray, support_normals: np.ndarray, period: float) -> tuple[np.ndarray, float]:
        """Body centres ``(N, 2)`` shifted by the sway, and the clearance [m] each one needs."""
        shift, needed = self.shift_and_clearance(period)
        pts = np.asarray(points, dtype=float).reshape(-1, 2) + shift * np.asarray(support_normals).reshape(-1, 2)
        return pts, needed

    def free(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray, period: float) -> np.ndarray:
        """Whether the body centred near ``points`` at ``times`` clears every obstacle, ``(N,)`` bool.

        ``support_normals (N, 2)``: unit vectors from the centre line towards the support
        foot of the step each point belongs to (zero vectors: no sway shift).
        """
        pts, needed = self._body(points, support_normals, period)
        if self.compiled:
            return self.predictor.free(pts, times, needed)
        return self.predictor.free_numpy(pts, times, needed)

    def slack(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray, period: float) -> np.ndarray:
        """Clearance [m] beyond what :meth:`free` requires at each point, ``(N,)`` (negative: not free)."""
        pts, needed = self._body(points, support_normals, period)
        return self.predictor.clearance(pts, times) - needed


def support_normal(heading: np.ndarray, side: np.ndarray) -> np.ndarray:
    """Unit vectors ``(N, 2)`` towards the support foot: ``side`` (+1 left) times the left normal of ``heading``."""
    heading = np.asarray(heading, dtype=float)
    side = np.asarray(side, dtype=float)
    return np.stack([-side * np.sin(heading), side * np.cos(heading)], axis=-1)
