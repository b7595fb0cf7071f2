"""What a robot could sense *now*: a read-only snapshot of the env, and predictions from it.

A planner sees the world only through :class:`Snapshot` (``env.unwrapped.sensing()``):
its own feet and CoM state, the goal, and each obstacle's shape, pose and *current*
velocity. Nothing about the future is in it. :meth:`Snapshot.shapes_at` freezes the shapes
at one instant, extrapolated at constant velocity and constant angular velocity (what a robot
that measures velocities could do; the crowd's real motion is not constant, so the prediction
can be wrong, as it would be on a robot); the planners predict each point at its own time with
:class:`footstep_gym.planners.prediction.ObstaclePredictor`, which the tests hold equal to it.

With the env's sensing options (``configs/env.yaml``: ``sensing_noise_*``, ``sensing_max_range``,
``sensing_fov``; off by default) the moving obstacles' views are what :func:`sense` makes of the truth:
noisy, and only those within range and field of view. :func:`nearest_views` computes the
observation's closest points from such views with ``World.nearest``'s arithmetic.
"""

from __future__ import annotations

import math
import functools
from dataclasses import dataclass

import numpy as np

from footstep_gym.geometry import Shapes, rotate
from footstep_gym.robot import Robot


def _frozen(a: np.ndarray | list | tuple, shape_tail: tuple[int, ...] = ()) -> np.ndarray:
    arr = np.array(a, dtype=float).reshape((-1, *shape_tail)) if shape_tail else np.array(a, dtype=float)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True)
class ObstacleView:
    """One obstacle shape as sensed now (world frame, SI units).

    ``kind`` is ``"circle"`` (centre ``a``, radius ``radius``) or ``"segment"`` (endpoints
    ``a``, ``b``, half thickness ``radius``); ``a``/``b`` are in the body's frame, which
    sits at ``position`` with ``angle``. The body moves at ``velocity`` [m/s] and turns
    at ``angular_velocity`` [rad/s] (counter-clockwise > 0).
    """

    name: str
    kind: str
    static: bool
    position: tuple[float, float]
    angle: float
    velocity: tuple[float, float]
    angular_velocity: float
    radius: float
    a: tuple[float, float]
    b: tuple[float, float]


@dataclass(frozen=True)
class _Bodies:
    """Per-shape arrays of a group of shapes (circles or segments) for vectorised prediction."""

    position: np.ndarray  # (M, 2) body position
    angle: np.ndarray  # (M,)
    velocity: np.ndarray  # (M, 2)
    angular_velocity: np.ndarray  # (M,)
    radius: np.ndarray  # (M,)
    a: np.ndarray  # (M, 2) body frame
    b: np.ndarray  # (M, 2) body frame

    @classmethod
    def of(cls, views: list[ObstacleView]) -> "_Bodies":
        return cls(
            position=_frozen([v.position for v in views], (2,)),
            angle=_frozen([v.angle for v in views]),
            velocity=_frozen([v.velocity for v in views], (2,)),
            angular_velocity=_frozen([v.angular_velocity for v in views]),
            radius=_frozen([v.radius for v in views]),
            a=_frozen([v.a for v in views], (2,)),
            b=_frozen([v.b for v in views], (2,)),
        )

    def world(self, local: np.ndarray, dt: float) -> np.ndarray:
        pos = self.position + self.velocity * dt
        return pos + rotate(local, self.angle + self.angular_velocity * dt)


def _shapes(circles: _Bodies, segments: _Bodies, dt: float) -> Shapes:
    """The shapes of two groups ``dt`` [s] ahead at constant (angular) velocity, world frame."""
    return Shapes(
        circle_centres=circles.world(circles.a, dt),
        circle_radii=circles.radius,
        segment_a=segments.world(segments.a, dt),
        segment_b=segments.world(segments.b, dt),
        segment_radii=segments.radius,
    )


@dataclass(frozen=True)
class Snapshot:
    """The read-only state a planner may use. Poses are ``(x, y, yaw)`` [m, m, rad], world frame.

    ``com_local``/``vel_local`` are the CoM position/velocity relative to the support foot
    in its frame (what :func:`footstep_gym.lipm.check_steps` takes).
    """

    time: float  # [s] simulated
    robot: Robot
    support_side: int  # +1 left, -1 right
    support_foot: tuple[float, float, float]
    swing_foot: tuple[float, float, float]
    com: tuple[float, float]  # [m] world
    com_vel: tuple[float, float]  # [m/s] world
    com_local: tuple[float, float]
    vel_local: tuple[float, float]
    goal: tuple[float, float]
    goal_tolerance: float
    previous_command: tuple[float, float, float, float, float]
    obstacles: tuple[ObstacleView, ...]

    @property
    def centre(self) -> tuple[float, float]:
        """Robot centre: midpoint of the two feet [m]."""
        return (0.5 * (self.support_foot[0] + self.swing_foot[0]), 0.5 * (self.support_foot[1] + self.swing_foot[1]))

    @property
    def heading(self) -> float:
        """The support foot's yaw [rad]."""
        return self.support_foot[2]

    def shapes_at(self, dt: float = 0.0) -> Shapes:
        """Obstacle shapes predicted ``dt`` [s] ahead at constant (angular) velocity."""
        return _shapes(*self._groups, dt)

    @functools.cached_property
    def _groups(self) -> tuple[_Bodies, _Bodies]:
        """The circles' and the segments' arrays, built on the first :meth:`shapes_at` (not per snapshot)."""
        return (_Bodies.of([o for o in self.obstacles if o.kind == "circle"]),
                _Bodies.of([o for o in self.obstacles if o.kind == "segment"]))


# ---------------------------------------------------------------- closest points from sensed views
#: One entry of :func:`nearest_views` (the form of ``World.nearest``'s): the gap [m] from the point to the
#: shape's surface (negative inside), the surface's closest point [m], that point's velocity [m/s] (the
#: body's velocity plus ``omega x r``), and the view.
Near = tuple[float, tuple[float, float], tuple[float, float], ObstacleView]


def nearest_on_segment(px: float, py: float, ax: float, ay: float, dx: float, dy: float,
                       L2: float) -> tuple[float, float]:
    """The point of the segment from ``(ax, ay)`` along ``(dx, dy)`` (squared length ``L2``) nearest ``(px, py)``
    [m]: the one arithmetic ``World.nearest`` and the sensed views share, operation for operation."""
    if L2 == 0.0:
        u = 0.0
    else:  # min(max(u, 0), 1)
        u = ((px - ax) * dx + (py - ay) * dy) / L2
        if 0.0 > u:
            u = 0.0
        if 1.0 < u:
            u = 1.0
    return ax + u * dx, ay + u * dy


def _centre_line(view: ObstacleView, px: float, py: float) -> tuple[float, float, float, float, float, float]:
    """``(gap, qx, qy, nx, ny, d)``: the point of the view's centre line nearest ``(px, py)`` [m], the offset
    from it to the point and its length, and the gap ``d - radius``: ``World.nearest``'s arithmetic, operation
    for operation (a static view's ``a``/``b`` are world coordinates, as a wall's are there)."""
    if view.static:
        ax, ay = view.a
        bx, by = view.b
    else:
        ox, oy = view.position
        c, s = math.cos(view.angle), math.sin(view.angle)
        la, lb = view.a, view.b
        ax, ay = ox + c * la[0] - s * la[1], oy + s * la[0] + c * la[1]
        bx, by = ox + c * lb[0] - s * lb[1], oy + s * lb[0] + c * lb[1]
    dx, dy = bx - ax, by - ay
    qx, qy = nearest_on_segment(px, py, ax, ay, dx, dy, dx * dx + dy * dy)
    nx, ny = px - qx, py - qy
    d = math.hypot(nx, ny)
    return d - view.radius, qx, qy, nx, ny, d


def _surface(view: ObstacleView, qx: float, qy: float, nx: float, ny: float, d: float
             ) -> tuple[tuple[float, float], tuple[float, float]]:
    """The closest surface point and its velocity (``World.nearest``'s arithmetic)."""
    radius = view.radius
    if d > 0.0:
        cp = (qx + radius * nx / d, qy + radius * ny / d)
    else:  # the point lies on the centre line: any normal will do
        cp = (qx, qy + radius)
    if view.static:
        return cp, (0.0, 0.0)
    ox, oy = view.position
    w = view.angular_velocity
    vx, vy = view.velocity
    return cp, (vx - w * (cp[1] - oy), vy + w * (cp[0] - ox))


def nearest_views(views: "tuple[ObstacleView, ...] | list[ObstacleView]", point: tuple[float, float], k: int,
                  max_distance: float) -> list[Near]:
    """Up to ``k`` of ``views`` nearest ``point`` [m] whose gap is within ``max_distance`` [m], nearest first.

    What ``World.nearest`` answers for the bodies themselves, computed from the views instead (their
    sensed, possibly noisy, poses and velocities): each entry is ``(gap, closest_point,
    velocity_of_that_point, view)``, ties in the views' order. With views read from a world
    (``World.views``) the answers are ``World.nearest``'s, the same arithmetic operation for operation
    (``tests/test_sensing_noise.py``).
    """
    px, py = point
    near = []
    for i, view in enumerate(views):
        gap, qx, qy, nx, ny, d = _centre_line(view, px, py)
        if not gap > max_distance:
            near.append((gap, i, qx, qy, nx, ny, d))
    near.sort()  # by (gap, index): the index is unique, so nothing further is compared
    found = []
    for gap, i, qx, qy, nx, ny, d in near[:k]:
        view = views[i]
        cp, v = _surface(view, qx, qy, nx, ny, d)
        found.append((gap, cp, v, view))
    return found


def in_field_of_view(point: tuple[float, float], heading: float, half_fov: float, target: tuple[float, float]
                     ) -> bool:
    """Whether ``target`` [m] lies within ``half_fov`` [rad] (inclusive) either side of ``heading`` [rad] as
    seen from ``point`` [m] (``half_fov >= pi``: all around)."""
    if half_fov >= math.pi:
        return True
    dx, dy = target[0] - point[0], target[1] - point[1]
    c, s = math.cos(heading), math.sin(heading)
    return abs(math.atan2(-s * dx + c * dy, c * dx + s * dy)) <= half_fov


def sense(views: "tuple[ObstacleView, ...]", point: tuple[float, float], heading: float, max_range: float,
          fov: float, noise: "list[list[float]] | None" = None,
          sigma: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)) -> tuple[ObstacleView, ...]:
    """What a robot at ``point`` [m] (its CoM) facing ``heading`` [rad] senses of ``views`` (the truth).

    Static views (walls: the robot's map) are kept as they are. Each moving one, in order, is
    first made noisy when ``noise`` is given: its row ``(x, y, vx, vy, angle, omega)`` of
    standard normals times ``sigma = (position [m], velocity [m/s], angle [rad], angular
    velocity [rad/s])`` stds is added to its position, velocity and, for a rod (a segment),
    angle and angular velocity (a circle's outline is the same at any angle: its angle and
    angular velocity are kept). It is then sensed when the closest point of its (noisy)
    surface is within ``max_range`` [m] of ``point`` and within ``fov`` [deg] (the full
    angle, centred on ``heading``; inclusive) as seen from ``point``; a point inside or on a
    shape (gap <= 0) is always sensed. Returns the sensed views in ``views``' order.
    """
    sp, sv, sa, sw = sigma
    half = 0.5 * math.radians(fov)
    px, py = point
    out = []
    j = 0
    for view in views:
        if view.static:
            out.append(view)
            continue
        if noise is not None:
            zx, zy, zvx, zvy, za, zw = noise[j]
            j += 1
            (x, y), (vx, vy) = view.position, view.velocity
            rod = view.kind == "segment"
            view = ObstacleView(  # positional: a third cheaper than by keyword
                view.name, view.kind, False, (x + sp * zx, y + sp * zy),
                view.angle + sa * za if rod else view.angle, (vx + sv * zvx, vy + sv * zvy),
                view.angular_velocity + sw * zw if rod else view.angular_velocity, view.radius, view.a, view.b,
            )
        gap, qx, qy, nx, ny, d = _centre_line(view, px, py)
        if gap > 0.0:
            if gap > max_range:
                continue
            if half < math.pi and not in_field_of_view(point, heading, half, _surface(view, qx, qy, nx, ny, d)[0]):
                continue
        out.append(view)
    return tuple(out)
