"""What a robot could sense *now*: a read-only snapshot of the env, and predictions from it.

A planner sees the world only through :class:`Snapshot` (``env.unwrapped.sensing()``):
its own feet and CoM state, the goal, and each obstacle's shape, pose and *current*
velocity. Nothing about the future is in it; :meth:`Snapshot.shapes_at` extrapolates at
constant velocity and constant angular velocity, which is what a robot that measures
velocities could do (the crowd's real motion is not constant, so the prediction can be
wrong, as it would be on a robot).
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
    _circles: _Bodies = field(init=False, repr=False, compare=False)
    _segments: _Bodies = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_circles", _Bodies.of([o for o in self.obstacles if o.kind == "circle"]))
        object.__setattr__(self, "_segments", _Bodies.of([o for o in self.obstacles if o.kind == "segment"]))

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
        return _shapes(self._circles, self._segments, dt)

    def max_obstacle_speed(self) -> float:
        """Largest speed [m/s] of any point of any obstacle (``|v| + |omega| * reach``)."""
        best = 0.0
        for group in (self._circles, self._segments):
            if len(group.radius):
                reach = np.maximum(np.linalg.norm(group.a, axis=1), np.linalg.norm(group.b, axis=1)) + group.radius
                speed = np.linalg.norm(group.velocity, axis=1) + np.abs(group.angular_velocity) * reach
                best = max(best, float(speed.max()))
        return best
