"""The 2D pymunk world: static walls, kinematic obstacles, the robot's body circle.

Units are metres and seconds, so ``Space.collision_slop`` is set from the config (pymunk's
default of 0.1 is sized for pixels and would hide 10 cm of overlap).

Collisions over a footstep are found by :meth:`World.sweep`, which moves the robot's
circle along the CoM path ``c(t)`` and the obstacles on their own velocities, and asks
pymunk for the nearest obstacle surface at each check (``Space.point_query_nearest``).
Checks are spaced by *conservative advancement*: with clearance ``d`` and every point of
robot and obstacles moving no faster than ``V`` between checks, nothing can touch for
``d / V`` seconds, so the next check is that far ahead; where contact is possible the
checks are never further apart than ``max_check_interval`` nor than the time in which
anything moves ``collision_motion_fraction`` of the robot radius.

A footstep's checks are capped at ``max_checks`` (``max_sweep_checks`` in ``configs/env.yaml``)
whatever the speeds: where the rule above would space them closer than
``duration / max_checks`` they are spaced that far apart instead (so a contact may be found
late or missed), :attr:`SweepResult.capped` says so and a ``RuntimeWarning`` is issued once
per world. Within the scenarios' ``max_*`` speed bounds the cap is never reached and the
checks are exactly those of the rule.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Callable

import pymunk

from footstep_gym.sensing import ObstacleView

_ROBOT = 0b01
_OBSTACLE = 0b10
_OBSTACLE_FILTER = pymunk.ShapeFilter(mask=_OBSTACLE)


@dataclass
class Obstacle:
    """One obstacle shape and the name it is reported under."""

    name: str
    kind: str  # "circle" | "segment"
    shape: pymunk.Shape
    local_a: tuple[float, float]
    local_b: tuple[float, float]
    radius: float
    static: bool = False  # on the space's static body (never moves)

    @property
    def body(self) -> pymunk.Body:
        return self.shape.body

    def reach(self) -> float:
        """Farthest distance of the shape's surface from its body's origin [m]."""
        return max(math.hypot(*self.local_a), math.hypot(*self.local_b)) + self.radius


def _first(entry: tuple) -> float:
    return entry[0]


@dataclass(frozen=True)
class SweepResult:
    """Outcome of one footstep's sweep: ``collided``, its time [s] from the step start, the shape's name,
    the number of checks, and whether ``max_checks`` spaced them wider than the rule (``capped``).

    ``clearance`` [m] is the smallest gap between the robot's circle and any obstacle at the
    sweep's checks (negative on a collision; ``inf`` if no obstacle came within reach of the
    robot during the step). The checks are spaced so that nothing can touch between them,
    not to find the exact minimum: between two checks the gap can dip below both by up to
    half the distance the bodies close in that interval.
    """

    collided: bool
    time: float
    obstacle: str | None
    checks: int
    clearance: float
    capped: bool = False


class World:
    """A pymunk space holding the obstacles and the robot's body circle."""

    def __init__(self, robot_radius: float, collision_slop: float, max_check_interval: float,
                 motion_fraction: float, max_checks: int) -> None:
        if not (isinstance(max_checks, int) and max_checks >= 1):
            raise ValueError(f"max_checks must be an integer >= 1, got {max_checks!r}")
        self.space = pymunk.Space()
        self.space.collision_slop = collision_slop
        self.robot_radius = robot_radius
        self.max_check_interval = max_check_interval
        self.motion_fraction = motion_fraction
        self.max_checks = max_checks
        self._warned_cap = False
        self._geometry_cache: list | None = None  # see _geometry()
        self.obstacles: list[Obstacle] = []
        self._by_shape: dict[pymunk.Shape, Obstacle] = {}
        self._moving: list[Obstacle] = []
        self.time = 0.0
        self.robot_body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.robot_shape = pymunk.Circle(self.robot_body, robot_radius)
        self.robot_shape.filter = pymunk.ShapeFilter(categories=_ROBOT, mask=0)
        self.space.add(self.robot_body, self.robot_shape)

    def clear_moving(self) -> None:
        """Remove every obstacle that is not static and set the clock back to 0 (walls stay)."""
        for o in self._moving:
            self.space.remove(o.body, o.shape)
            del self._by_shape[o.shape]
        self.obstacles = [o for o in self.obstacles if o not in self._moving]
        self._geometry_cache = None
        self._moving = []
        self.time = 0.0

    # ------------------------------------------------------------ building
    def _add(self, name: str, kind: str, body: pymunk.Body, shape: pymunk.Shape,
             a: tuple[float, float], b: tuple[float, float], radius: float) -> Obstacle:
        shape.filter = pymunk.ShapeFilter(categories=_OBSTACLE)
        if body.body_type == pymunk.Body.STATIC:
            self.space.add(shape)
        else:
            self.space.add(body, shape)
        obstacle = Obstacle(name, kind, shape, a, b, radius, static=body.body_type == pymunk.Body.STATIC)
        self.obstacles.append(obstacle)
        self._geometry_cache = None
        self._by_shape[shape] = obstacle
        if body.body_type != pymunk.Body.STATIC:
            self._moving.append(obstacle)
        return obstacle

    def add_wall(self, name: str, a: tuple[float, float], b: tuple[float, float], thickness: float) -> Obstacle:
        """A static wall from ``a`` to ``b`` [m] of total ``thickness`` [m]."""
        shape = pymunk.Segment(self.space.static_body, a, b, 0.5 * thickness)
        return self._add(name, "segment", self.space.static_body, shape, a, b, 0.5 * thickness)

    def add_circle(self, name: str, position: tuple[float, float], radius: float,
                   velocity: tuple[float, float] = (0.0, 0.0)) -> Obstacle:
        """A kinematic cylinder of ``radius`` [m] at ``position`` moving at ``velocity`` [m/s]."""
        body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        body.position = position
        body.velocity = velocity
        shape = pymunk.Circle(body, radius)
        return self._add(name, "circle", body, shape, (0.0, 0.0), (0.0, 0.0), radius)

    def add_rod(self, name: str, position: tuple[float, float], a: tuple[float, float], b: tuple[float, float],
                thickness: float, angle: float = 0.0, velocity: tuple[float, float] = (0.0, 0.0),
                angular_velocity: float = 0.0) -> Obstacle:
        """A kinematic thick segment ``a``-``b`` (body frame) [m], its body at ``position`` turned by ``angle`` [rad]."""
        body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        body.position = position
        body.angle = angle
        body.velocity = velocity
        body.angular_velocity = angular_velocity
        shape = pymunk.Segment(body, a, b, 0.5 * thickness)
        return self._add(name, "segment", body, shape, a, b, 0.5 * thickness)

    # ------------------------------------------------------------ queries
    def max_obstacle_speed(self) -> float:
        """Largest speed [m/s] any point of any obstacle has now."""
        best = 0.0
        for o in self._moving:
            v = o.body.velocity
            best = max(best, math.hypot(v.x, v.y) + abs(o.body.angular_velocity) * o.reach())
        return best

    def clearance(self, point: tuple[float, float], horizon: float) -> tuple[float, Obstacle | None]:
        """Distance [m] from ``point`` to the nearest obstacle surface, searched up to ``horizon``."""
        info = self.space.point_query_nearest(point, horizon, _OBSTACLE_FILTER)
        if info is None:
            return horizon, None
        return info.distance, self._by_shape[info.shape]

    def nearest(self, point: tuple[float, float], k: int, max_distance: float
                ) -> list[tuple[float, tuple[float, float], tuple[float, float], Obstacle]]:
        """Up to ``k`` shapes nearest ``point`` within ``max_distance``, nearest first.

        Each entry is ``(distance, closest_point, velocity_of_that_point, obstacle)``: the
        answer of pymunk's ``Space.point_query``, computed here in plain arithmetic because
        the query's per-shape Python callback was half the cost of an env step.
        """
        px, py = point
        found = []
        hypot = math.hypot
        for o, static in self._geometry():
            radius = o.radius
            if static is not None:  # on the space's static body: its frame is the world's, its numbers fixed
                ax, ay, dx, dy, L2 = static
            else:
                body = o.body
                (ox, oy), angle = body.position, body.angle
                c, s = math.cos(angle), math.sin(angle)
                ax, ay = ox + c * o.local_a[0] - s * o.local_a[1], oy + s * o.local_a[0] + c * o.local_a[1]
                bx, by = ox + c * o.local_b[0] - s * o.local_b[1], oy + s * o.local_b[0] + c * o.local_b[1]
                dx, dy = bx - ax, by - ay
                L2 = dx * dx + dy * dy
            u = 0.0 if L2 == 0.0 else min(max(((px - ax) * dx + (py - ay) * dy) / L2, 0.0), 1.0)
            qx, qy = ax + u * dx, ay + u * dy  # nearest point of the centre line
            nx, ny = px - qx, py - qy
            d = hypot(nx, ny)
            if d - radius > max_distance:
                continue
            if d > 0.0:
                cp = (qx + radius * nx / d, qy + radius * ny / d)
            else:  # the point lies on the centre line: any normal will do
                cp = (qx, qy + radius)
            if static is not None:
                v = (0.0, 0.0)
            else:
                w = body.angular_velocity
                vx, vy = body.velocity
                v = (vx - w * (cp[1] - oy), vy + w * (cp[0] - ox))
            found.append((d - radius, cp, v, o))
        found.sort(key=_first)
        return found[:k]

    def _geometry(self) -> list[tuple[Obstacle, tuple[float, float, float, float, float] | None]]:
        """Every obstacle with, for a static one, its centre line's fixed numbers ``(ax, ay, dx, dy, |d|^2)``.

        Rebuilt after the obstacles change (:meth:`_add`, :meth:`clear_moving`).
        """
        if self._geometry_cache is None:
            rows = []
            for o in self.obstacles:
                static = None
                if o.static:
                    (ax, ay), (bx, by) = o.local_a, o.local_b
                    dx, dy = bx - ax, by - ay
                    static = (ax, ay, dx, dy, dx * dx + dy * dy)
                rows.append((o, static))
            self._geometry_cache = rows
        return self._geometry_cache

    def views(self) -> tuple[ObstacleView, ...]:
        """Every obstacle as the sensing snapshot reports it (current state only)."""
        out = []
        for o in self.obstacles:
            body = o.body
            out.append(ObstacleView(
                name=o.name, kind=o.kind, static=o.static,
                position=(body.position.x, body.position.y), angle=body.angle,
                velocity=(body.velocity.x, body.velocity.y), angular_velocity=body.angular_velocity,
                radius=o.radius, a=o.local_a, b=o.local_b,
            ))
        return tuple(out)

    # ------------------------------------------------------------ time
    def advance(self, dt: float) -> None:
        """Move every kinematic body on for ``dt`` [s]."""
        if dt > 0:
            self.space.step(dt)
            self.time += dt

    def sweep(self, path: Callable[[float], tuple[float, float]], duration: float,
              robot_speed_bound: float) -> SweepResult:
        """Advance the world by ``duration`` [s] while the robot's centre follows ``path(t)``.

        Stops at the first contact (the world is then at that time). ``robot_speed_bound``
        [m/s] must bound the robot's speed over the step. At most ``max_checks`` + 1 checks
        (see the module's docstring).
        """
        radius = self.robot_radius
        speed = robot_speed_bound + self.max_obstacle_speed()
        if not math.isfinite(speed):
            raise ValueError(f"sweep: robot speed bound {robot_speed_bound!r} m/s + obstacles' "
                             f"{self.max_obstacle_speed()!r} m/s is not finite")
        fine = self.max_check_interval
        if speed > 0:
            fine = min(fine, self.motion_fraction * radius / speed)
        floor = duration / self.max_checks * (1.0 + 1e-9)  # the slack absorbs rounding in the sum of the steps
        capped = fine < floor
        if capped:
            if not self._warned_cap:
                self._warned_cap = True
                warnings.warn(
                    f"World.sweep: a {duration:.3g} s footstep with things moving up to {speed:.3g} m/s (body "
                    f"radius {radius:g} m) needs checks {fine:.3g} s apart, more than max_sweep_checks="
                    f"{self.max_checks}; they are spaced {floor:.3g} s apart instead, so a contact may be found "
                    "late or missed. Keep speeds within the scenario's max_* bounds for exact collisions.",
                    RuntimeWarning, stacklevel=2)
            fine = floor
        t, checks, nearest = 0.0, 0, math.inf
        while True:
            point = path(t)
            horizon = radius + speed * (duration - t) + 1e-9
            dist, hit = self.clearance(point, horizon)
            checks += 1
            if hit is not None:
                nearest = min(nearest, dist)
            if hit is not None and dist < radius:
                self.robot_body.position = point
                return SweepResult(True, t, hit.name, checks, dist - radius, capped)
            if t >= duration:
                break
            remaining = duration - t
            dt = remaining if speed <= 0 else min(remaining, max(fine, (dist - radius) / speed))
            self.advance(dt)
            t = duration if dt >= remaining else t + dt
        self.robot_body.position = path(duration)
        return SweepResult(False, duration, None, checks, nearest - radius, capped)
