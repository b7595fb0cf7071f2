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

Every shape is held as a thick segment (a circle is a segment of zero length), one row of a
:class:`~footstep_gym.kernels.ShapeTable` (:attr:`ObstaclePredictor.shapes`): the table both the
numpy and the compiled kernels (:mod:`footstep_gym.kernels`) read.
"""

from __future__ import annotations

import functools
from typing import Sequence

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.kernels import SHAPE_COLUMNS, ShapeTable
from footstep_gym.kernels.numpy_kernels import NUMPY, body_path_points, shape_gap2  # noqa: F401  (re-exported)
from footstep_gym.robot import Robot
from footstep_gym.sensing import ObstacleView, Snapshot


def _moves(view: ObstacleView) -> bool:
    return (not view.static) and (any(float(c) != 0.0 for c in view.velocity) or view.angular_velocity != 0.0)


def steady_motion_horizons(previous: Snapshot | None, snapshot: Snapshot, short_horizon: float,
                           speed_tolerance: float, turn_tolerance: float,
                           noise: dict[str, tuple[float, float]] | None = None, noise_stds: float = 0.0
                           ) -> dict[str, float]:
    """``{name: short_horizon}`` for the shapes whose sensed motion changed since ``previous``.

    A constant-velocity (or constant-turn) extrapolation is only as good as the motion is
    steady. A robot can judge that from what it sensed one step ago: a shape whose velocity
    changed by more than ``speed_tolerance`` [m/s] (or angular velocity by more than
    ``turn_tolerance`` [rad/s]) is predicted only ``short_horizon`` [s] ahead. Without a
    previous snapshot, every shape keeps the long horizon.

    ``noise``: ``{name: (speed std [m/s], turn std [rad/s])}``, the change that noise alone makes in
    estimated velocities (a tracker's :meth:`~footstep_gym.planners.tracking.Tracker.rate_change_stds`):
    a shape's tolerances grow by ``noise_stds`` times its stds, so that only a change beyond the noise
    counts.
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
        speed_std, turn_std = (noise or {}).get(v.name, (0.0, 0.0))
        if (dv > speed_tolerance + noise_stds * speed_std
                or abs(v.angular_velocity - old.angular_velocity) > turn_tolerance + noise_stds * turn_std):
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
        horizon_of = np.array([min(self.horizon, horizons.get(v.name, np.inf)) if _moves(v) else np.inf
                               for v in views], dtype=float).reshape(n)

        def col(values: list) -> np.ndarray:
            return np.array(values, dtype=float).reshape(n)

        def cplx(pairs: list) -> np.ndarray:
            arr = np.array(pairs, dtype=float).reshape(n, 2)
            return arr[:, 0] + 1j * arr[:, 1]

        position = cplx([v.position for v in views])
        velocity = cplx([v.velocity for v in views])
        angle = col([v.angle for v in views])
        a = cplx([v.a for v in views])  # body frame
        ab = cplx([v.b if v.kind == "segment" else v.a for v in views]) - a  # 0 for a circle
        # Sensed accelerations, each held for acceleration_horizon [s] (0: none; the prediction is p + v t).
        cap = float(acceleration_horizon)
        accelerating = [v.name in accelerations and _moves(v) and cap > 0 for v in views]
        acceleration = cplx([accelerations[v.name] if on else (0.0, 0.0) for v, on in zip(views, accelerating)])
        rows = np.stack([
            position.real, position.imag, velocity.real, velocity.imag, angle, col([v.angular_velocity for v in views]),
            np.cos(angle), np.sin(angle), a.real, a.imag, ab.real, ab.imag, np.abs(ab) ** 2, acceleration.real,
            acceleration.imag, col([cap if on else 0.0 for on in accelerating])], axis=1).reshape(n, SHAPE_COLUMNS)
        #: The shapes as the kernels read them.
        self.shapes = ShapeTable(np.ascontiguousarray(rows), np.ascontiguousarray(col([v.radius for v in views])),
                                 np.ascontiguousarray(horizon_of))

    @property
    def n_shapes(self) -> int:
        return self.shapes.n_shapes

    @property
    def _radius(self) -> np.ndarray:
        return self.shapes.radius

    def _distance2(self, points: np.ndarray, times: np.ndarray) -> np.ndarray:
        """Squared distances ``(N, S)`` from each point to each shape's centre line (``inf``: not checked)."""
        return shape_gap2(self.shapes, points, times)

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
        """``clearance >= safe_distance`` for each point, ``(N,)`` bool (no square roots; the numpy kernels)."""
        return NUMPY.points_free(self.shapes, points, times, safe_distance)


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

    :meth:`free` and :meth:`slack` are numpy; the compiled kernels read :attr:`shapes` and
    :meth:`shift_and_clearance` and check the same circles (:mod:`footstep_gym.kernels`).
    """

    def __init__(self, predictor: ObstaclePredictor, robot: Robot, margin: float, sway: bool = True) -> None:
        self.predictor = predictor
        self.robot = robot
        self.margin = margin
        self.with_sway = sway

    @property
    def shapes(self) -> ShapeTable:
        """The predictor's shape table (what the compiled kernels read)."""
        return self.predictor.shapes

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

    def centres(self, points: np.ndarray, support_normals: np.ndarray, period: float) -> tuple[np.ndarray, float]:
        """Body centres ``(N, 2)`` shifted by the sway, and the clearance [m] each one needs."""
        shift, needed = self.shift_and_clearance(period)
        pts = np.asarray(points, dtype=float).reshape(-1, 2) + shift * np.asarray(support_normals).reshape(-1, 2)
        return pts, needed

    def free(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray, period: float) -> np.ndarray:
        """Whether the body centred near ``points`` at ``times`` clears every obstacle, ``(N,)`` bool.

        ``support_normals (N, 2)``: unit vectors from the centre line towards the support
        foot of the step each point belongs to (zero vectors: no sway shift).
        """
        pts, needed = self.centres(points, support_normals, period)
        return self.predictor.free(pts, times, needed)

    def slack(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray, period: float) -> np.ndarray:
        """Clearance [m] beyond what :meth:`free` requires at each point, ``(N,)`` (negative: not free)."""
        pts, needed = self.centres(points, support_normals, period)
        return self.predictor.clearance(pts, times) - needed

