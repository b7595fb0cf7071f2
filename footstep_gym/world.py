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

**How a sweep is computed** (the answers are pymunk's, bit for bit; the work is not). A
footstep makes a few to a few hundred checks, and driving pymunk from Python costs
microseconds per call (a query, a ``Space.step``, every attribute read or written), more
than the geometry. For the env's path (a :class:`~footstep_gym.lipm.WorldPath`) the sweep reads
each moving body once and runs the checks in a compiled loop (:mod:`footstep_gym.kernels.sweep`)
that moves the bodies between checks as pymunk's kinematic integration does and computes each
distance with the operations of Chipmunk's point queries; then it writes the bodies back and
lets pymunk re-cache their shapes once, where ``Space.step`` would have left them. A shape's
distance is computed only where it can matter: no distance falls faster than the sweep's
speed bound, so a shape whose last distance, less that bound times the time since, is above
the nearest found so far cannot be the nearest (these bounds carry over to the next sweep,
less how far the robot and each body moved in between). Pymunk's own query still answers a
contact (for the name of the shape hit) and the first check of a sweep when a body was moved
since pymunk last cached its shapes (the crowd sets its members' positions before each step;
pymunk's query then sees the cached places, so the sweep does too). Any other path runs
:meth:`World.sweep_pymunk`, the plain loop that asks pymunk at every check and steps its space
(so does every path of a world made with ``compiled=False``: the env's ``compiled_sweep``
setting, for a process that should not load numba); ``tests/test_world.py`` checks the
compiled sweep against it at random configurations.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np
import pymunk

from footstep_gym import collision, scalars
from footstep_gym.sensing import ObstacleView, nearest_on_segment

_ROBOT = 0b01
_OBSTACLE = 0b10
_OBSTACLE_FILTER = pymunk.ShapeFilter(mask=_OBSTACLE)
#: [m] allowance for rounding in the sweep's lower bounds on a shape's distance (distances and
#: coordinates here are metres to tens of metres, their rounding errors ~1e-14 m).
_BOUND_SLACK = 1e-9
# pymunk's Body setters, called directly: ``body.position = ...`` goes through a Python ``__setattr__``
# of pymunk's typing mixin first, which costs more than the setter.
_SET_POSITION = pymunk.Body.position.fset
_SET_ANGLE = pymunk.Body.angle.fset
_SET_VELOCITY = pymunk.Body.velocity.fset
_SET_ANGULAR_VELOCITY = pymunk.Body.angular_velocity.fset
_kernel = None  # footstep_gym.kernels.sweep, imported on the first compiled sweep (it imports numba)


def _sweep_kernel():
    global _kernel
    if _kernel is None:
        from footstep_gym.kernels import sweep

        _kernel = sweep
    return _kernel


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

    def __post_init__(self) -> None:
        self._reach = collision.shape_reach(scalars, *self.local_a, *self.local_b, self.radius)

    @property
    def body(self) -> pymunk.Body:
        return self.shape.body

    def reach(self) -> float:
        """Farthest distance of the shape's surface from its body's origin [m]."""
        return self._reach


class SweepResult(NamedTuple):
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
                 motion_fraction: float, max_checks: int, compiled: bool = True) -> None:
        if not (isinstance(max_checks, int) and max_checks >= 1):
            raise ValueError(f"max_checks must be an integer >= 1, got {max_checks!r}")
        self.space = pymunk.Space()
        self.space.collision_slop = collision_slop
        self.robot_radius = robot_radius
        self.max_check_interval = max_check_interval
        self.motion_fraction = motion_fraction
        self.max_checks = max_checks
        self.compiled = compiled  # sweep() runs a WorldPath's checks compiled; else sweep_pymunk
        self._warned_cap = False
        self._geometry_cache: list | None = None  # see _geometry()
        self._sweep_rows: list | None = None  # see _rows()
        # What a sweep leaves the next one: (rows, lower bounds of each shape's distance at its end, the robot's
        # point there, the moving bodies' (x, y, angle) there, the nearest shape's index); see sweep().
        self._carry: tuple | None = None
        # (x, y, angle) of each moving body when pymunk last cached its shapes' geometry (None: unknown).
        self._cached_states: list[tuple[float, float, float]] | None = []
        self.obstacles: list[Obstacle] = []
        self._by_shape: dict[pymunk.Shape, Obstacle] = {}
        self._moving: list[Obstacle] = []
        self.time = 0.0
        self.robot_body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.robot_shape = pymunk.Circle(self.robot_body, robot_radius)
        self.robot_shape.filter = pymunk.ShapeFilter(categories=_ROBOT, mask=0)
        self.space.add(self.robot_body, self.robot_shape)

    def clear_moving(self) -> None:
        """Remove every obstacle that is not static and set the clock back to 0 (walls stay).

        Pymunk keeps every shape removed from a space (in ``Space._removed_shapes``, so that a
        collision callback of the removal can still reach it) until the space's next
        ``Space.step``. The compiled sweep moves the bodies itself and never steps the space,
        so without a step here the removed shapes, and their Chipmunk memory, would pile up
        for the life of the world (about 0.9 KB per obstacle per reset). ``step(0.0)`` lets
        pymunk drop them and changes nothing else: Chipmunk's ``cpSpaceStep`` returns at once
        for a zero time step, and this world has no callbacks or dynamic bodies.
        """
        for o in self._moving:
            self.space.remove(o.body, o.shape)
            del self._by_shape[o.shape]
        if self._moving:
            self.space.step(0.0)  # releases the removed shapes (see above); moves nothing
        self.obstacles = [o for o in self.obstacles if o.static]
        self._geometry_cache = self._sweep_rows = None
        self._cached_states = []
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
        self._geometry_cache = self._sweep_rows = None
        self._by_shape[shape] = obstacle
        if not obstacle.static:
            self._moving.append(obstacle)
            if self._cached_states is not None:  # space.add cached the shape where its body is now
                (x, y), angle = body.position, body.angle
                self._cached_states = [*self._cached_states, (x, y, angle)]
        return obstacle

    def add_wall(self, name: str, a: tuple[float, float], b: tuple[float, float], thickness: float) -> Obstacle:
        """A static wall from ``a`` to ``b`` [m] of total ``thickness`` [m]."""
        shape = pymunk.Segment(self.space.static_body, a, b, 0.5 * thickness)
        return self._add(name, "segment", self.space.static_body, shape, a, b, 0.5 * thickness)

    def add_circle(self, name: str, position: tuple[float, float], radius: float,
                   velocity: tuple[float, float] = (0.0, 0.0)) -> Obstacle:
        """A kinematic cylinder of ``radius`` [m] at ``position`` moving at ``velocity`` [m/s]."""
        body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        _SET_POSITION(body, position)
        _SET_VELOCITY(body, velocity)
        shape = pymunk.Circle(body, radius)
        return self._add(name, "circle", body, shape, (0.0, 0.0), (0.0, 0.0), radius)

    def add_rod(self, name: str, position: tuple[float, float], a: tuple[float, float], b: tuple[float, float],
                thickness: float, angle: float = 0.0, velocity: tuple[float, float] = (0.0, 0.0),
                angular_velocity: float = 0.0) -> Obstacle:
        """A kinematic thick segment ``a``-``b`` (body frame) [m], its body at ``position`` turned by ``angle`` [rad]."""
        body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        _SET_POSITION(body, position)
        _SET_ANGLE(body, angle)
        _SET_VELOCITY(body, velocity)
        _SET_ANGULAR_VELOCITY(body, angular_velocity)
        shape = pymunk.Segment(body, a, b, 0.5 * thickness)
        return self._add(name, "segment", body, shape, a, b, 0.5 * thickness)

    # ------------------------------------------------------------ queries
    def max_obstacle_speed(self) -> float:
        """Largest speed [m/s] any point of any obstacle has now."""
        best = 0.0
        for o in self._moving:
            v = o.body.velocity
            best = max(best, collision.body_speed(scalars, v.x, v.y, o.body.angular_velocity, o._reach))
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
        answer of pymunk's ``Space.point_query``, computed here in plain arithmetic, without
        the query's per-shape Python callback.
        """
        px, py = point
        hypot = math.hypot
        statics, movers = self._geometry()
        # (gap, index, obstacle, body or None, body origin, nearest point of the centre line, offset to it, its
        # length); sorted by (gap, index): by gap, ties in the obstacles' order.
        near = []
        for i, o, ax, ay, dx, dy, L2, radius in statics:  # on the static body: the frame is the world's
            qx, qy = nearest_on_segment(px, py, ax, ay, dx, dy, L2)  # nearest point of the centre line
            nx, ny = px - qx, py - qy
            d = hypot(nx, ny)
            if not d - radius > max_distance:
                near.append((d - radius, i, o, None, None, qx, qy, nx, ny, d))
        for i, o in movers:
            radius = o.radius
            body = o.body
            origin, angle = body.position, body.angle
            ox, oy = origin
            c, s = math.cos(angle), math.sin(angle)
            ax, ay = ox + c * o.local_a[0] - s * o.local_a[1], oy + s * o.local_a[0] + c * o.local_a[1]
            bx, by = ox + c * o.local_b[0] - s * o.local_b[1], oy + s * o.local_b[0] + c * o.local_b[1]
            dx, dy = bx - ax, by - ay
            qx, qy = nearest_on_segment(px, py, ax, ay, dx, dy, dx * dx + dy * dy)
            nx, ny = px - qx, py - qy
            d = hypot(nx, ny)
            if not d - radius > max_distance:
                near.append((d - radius, i, o, body, origin, qx, qy, nx, ny, d))
        near.sort()  # by (gap, index): the index is unique, so nothing further is compared
        found = []
        for gap, _, o, body, origin, qx, qy, nx, ny, d in near[:k]:  # the closest point and its velocity: k only
            radius = o.radius
            if d > 0.0:
                cp = (qx + radius * nx / d, qy + radius * ny / d)
            else:  # the point lies on the centre line: any normal will do
                cp = (qx, qy + radius)
            if body is None:
                v = (0.0, 0.0)
            else:
                ox, oy = origin
                w = body.angular_velocity
                vx, vy = body.velocity
                v = (vx - w * (cp[1] - oy), vy + w * (cp[0] - ox))
            found.append((gap, cp, v, o))
        return found

    def _geometry(self) -> tuple[list[tuple], list[tuple[int, Obstacle]]]:
        """``(statics, movers)``: each static obstacle as ``(index, obstacle, ax, ay, dx, dy, |d|^2, radius)``
        (its centre line's fixed numbers) and each moving one as ``(index, obstacle)``, index in
        :attr:`obstacles`. Rebuilt after the obstacles change (:meth:`_add`, :meth:`clear_moving`).
        """
        if self._geometry_cache is None:
            statics, movers = [], []
            for i, o in enumerate(self.obstacles):
                if o.static:
                    (ax, ay), (bx, by) = o.local_a, o.local_b
                    dx, dy = bx - ax, by - ay
                    statics.append((i, o, ax, ay, dx, dy, dx * dx + dy * dy, o.radius))
                else:
                    movers.append((i, o))
            self._geometry_cache = (statics, movers)
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
            self._cached_states = None

    def _table(self) -> tuple[np.ndarray, dict[int, int]]:
        """Every obstacle as a row of the compiled sweep's shape table (:mod:`footstep_gym.kernels.sweep`), in
        :attr:`obstacles`' order, and each obstacle's row keyed by its pymunk shape (the object pymunk's query
        returns; hashed by identity). Not by ``id()``: a ``copy.deepcopy`` or a pickle of the world (of an env
        mid-episode) gets new objects, and a map keyed by the old ids would not find them, whereas a dict keyed
        by the shapes themselves is copied with them. Rebuilt after the obstacles change."""
        if self._sweep_rows is None:
            kernel = _sweep_kernel()
            index = {id(o): i for i, o in enumerate(self._moving)}
            rows = []
            for o in self.obstacles:
                (ax, ay), (bx, by) = o.local_a, o.local_b
                if o.static:
                    if o.kind != "segment":
                        raise ValueError(f"World: static obstacle {o.name!r} of kind {o.kind!r}; only static "
                                         "segments are supported")
                    dx, dy, l2 = collision.segment_frame(ax, ay, bx, by)  # the static body's frame is the world's
                    rows.append((kernel.STATIC_SEGMENT, -1, ax, ay, bx, by, dx, dy, l2, o.radius))
                elif o.kind == "segment":
                    rows.append((kernel.MOVING_SEGMENT, index[id(o)], ax, ay, bx, by, o.radius, 0.0, 0.0, 0.0))
                else:  # a circle on its body's origin (add_circle)
                    rows.append((kernel.MOVING_CIRCLE, index[id(o)], 0.0, 0.0, 0.0, 0.0, o.radius, 0.0, 0.0, 0.0))
            table = np.array(rows) if rows else np.zeros((0, 10))
            self._sweep_rows = (table, {o.shape: j for j, o in enumerate(self.obstacles)})
            n = len(rows)
            self._buffers = (np.empty(n, dtype=np.int64), np.zeros(7, dtype=np.int64), np.zeros(6))
        return self._sweep_rows

    def _write_back(self, states: list[list[float]], read: list[list[float]]) -> None:
        """Set the moving bodies to the sweep's ``states`` and let pymunk cache their shapes there
        (what ``Space.step`` leaves behind). ``read``: the states read at the sweep's start; a
        position or angle that cannot have changed is not written (a zero never is skipped: pymunk's
        ``x + 0 dt`` turns -0.0 into 0.0)."""
        reindex = self.space.reindex_shapes_for_body
        for o, st, r in zip(self._moving, states, read):
            body = o.body
            if r[3] != 0.0 or r[4] != 0.0 or r[0] == 0.0 or r[1] == 0.0:
                _SET_POSITION(body, (st[0], st[1]))
            if r[5] != 0.0 or r[2] == 0.0:
                _SET_ANGLE(body, st[2])
            reindex(body)
        self._cached_states = [(st[0], st[1], st[2]) for st in states]

    def sweep(self, path: Callable[[float], tuple[float, float]], duration: float,
              robot_speed_bound: float) -> SweepResult:
        """Advance the world by ``duration`` [s] while the robot's centre follows ``path(t)``.

        Stops at the first contact (the world is then at that time). ``robot_speed_bound``
        [m/s] must bound the robot's speed over the step. At most ``max_checks`` + 1 checks
        (see the module's docstring).

        Which loop runs is decided by ``path``, on purpose, whatever ``compiled`` says: the
        compiled loop evaluates the robot's path itself, from the constants of its closed form
        that a :class:`footstep_gym.lipm.WorldPath` (the env's path) hands over as
        ``sweep_params``. Any other callable (a path written by hand, as the direct tests of
        ``tests/test_world.py`` and a world scripted outside the env use) can only be asked point
        by point from Python, so it runs :meth:`sweep_pymunk`, the plain pymunk loop, which gives
        the same answers (the compiled loop is checked against it bit for bit). ``compiled=False``
        sends every path there. The env's own sweeps always pass a ``WorldPath``.
        """
        params = getattr(path, "sweep_params", None) if self.compiled else None
        if params is None:
            return self.sweep_pymunk(path, duration, robot_speed_bound)
        kernel = _sweep_kernel()

        radius = self.robot_radius
        # One read of each moving body: [x, y, angle, vx + 0, vy + 0, w + 0] (pymunk adds the zero bias velocity).
        states = []
        obstacle_speed = 0.0
        for o in self._moving:
            body = o.body
            (px, py), (vx, vy) = body.position, body.velocity
            w = body.angular_velocity
            states.append([px, py, body.angle, vx + 0.0, vy + 0.0, w + 0.0, 0.0])
            obstacle_speed = max(obstacle_speed, collision.body_speed(scalars, vx, vy, w, o._reach))
        speed, fine, capped = self._spacing(duration, robot_speed_bound, obstacle_speed)
        cached = self._cached_states
        # Pymunk's shapes sit where their bodies are (else the first check asks pymunk, which sees the cached places).
        fresh = cached is not None and len(cached) == len(states)
        if fresh:
            for c, st in zip(cached, states):
                if c[0] != st[0] or c[1] != st[1] or c[2] != st[2]:
                    fresh = False
                    break
        if self._sweep_rows is None:
            self._table()
        table, row_of = self._sweep_rows
        candidates, ival, fval = self._buffers
        carry, self._carry = self._carry, None
        if carry is not None and carry[0] is table:
            # The last sweep's bounds at its end (less how far the robot and each body moved since: the kernel).
            _, keys, (ex, ey), ends, last = carry
            for o, st, e in zip(self._moving, states, ends):
                st[6] = math.hypot(st[0] - e[0], st[1] - e[1]) + abs(st[2] - e[2]) * o._reach + _BOUND_SLACK
        else:
            keys, ex, ey, last = np.full(len(table), -math.inf), 0.0, 0.0, 0
        prm = np.array(params + [duration, speed, radius, fine, _BOUND_SLACK, ex, ey])
        st_arr = np.array(states) if states else np.zeros((0, 7))
        ival[:] = (0, last, -1, 0, 0 if fresh else 2, 0, 1 if carry is None or carry[0] is not table else 2)
        fval[:] = (0.0, math.inf, self.time, 0.0, 0.0, 0.0)
        obstacles = self.obstacles
        while True:
            status = kernel.sweep(prm, table, st_arr, keys, candidates, ival, fval)
            if status != kernel.ASK:
                break
            # Pymunk answers: a contact (for its shape's name), or a first check against shapes it cached elsewhere.
            t, px, py = fval[0], fval[4], fval[5]
            if ival[3]:
                self._write_back(st_arr.tolist(), states)
            dist, hit = self.clearance((float(px), float(py)), collision.horizon(radius, speed, duration, t))
            ival[4], ival[2], fval[3] = 1, -1 if hit is None else row_of[hit.shape], dist
        t, nearest, self.time, dist, px, py = fval.tolist()
        final = st_arr.tolist()
        if ival[3]:
            self._write_back(final, states)
        checks = int(ival[0])
        if status == kernel.COLLIDED:
            self.robot_body.position = (px, py)
            return SweepResult(True, t, obstacles[int(ival[2])].name, checks, dist - radius, capped)
        end = (px, py) if t == duration else path(duration)
        _SET_POSITION(self.robot_body, end)
        self._carry = (table, keys, end, [(st[0], st[1], st[2]) for st in final], int(ival[1]))
        return SweepResult(False, duration, None, checks, nearest - radius, capped)

    def _spacing(self, duration: float, robot_speed_bound: float, obstacle_speed: float
                 ) -> tuple[float, float, bool]:
        """``(speed, fine, capped)``: the sweep's speed bound [m/s], its finest check interval [s] and whether
        ``max_checks`` widened it (warned once per world)."""
        radius = self.robot_radius
        speed = robot_speed_bound + obstacle_speed
        if not math.isfinite(speed):
            raise ValueError(f"sweep: robot speed bound {robot_speed_bound!r} m/s + obstacles' "
                             f"{obstacle_speed!r} m/s is not finite")
        fine, capped = collision.check_spacing(scalars, duration, speed, self.max_check_interval, self.motion_fraction,
                                               radius, self.max_checks)
        if capped:
            if not self._warned_cap:
                self._warned_cap = True
                warnings.warn(
                    f"World.sweep: a {duration:.3g} s footstep with things moving up to {speed:.3g} m/s (body "
                    f"radius {radius:g} m) needs checks closer than max_sweep_checks={self.max_checks} allows; "
                    f"they are spaced {fine:.3g} s apart instead, so a contact may be found "
                    "late or missed. Keep speeds within the scenario's max_* bounds for exact collisions.",
                    RuntimeWarning, stacklevel=3)
        return speed, fine, capped

    def sweep_pymunk(self, path: Callable[[float], tuple[float, float]], duration: float,
                     robot_speed_bound: float) -> SweepResult:
        """:meth:`sweep` asking pymunk at every check and stepping its space between them: the reference the
        compiled loop must equal, and the loop for a path that is not a :class:`~footstep_gym.lipm.WorldPath`."""
        radius = self.robot_radius
        self._carry = None
        speed, fine, capped = self._spacing(duration, robot_speed_bound, self.max_obstacle_speed())
        t, checks, nearest = 0.0, 0, math.inf
        while True:
            point = path(t)
            dist, hit = self.clearance(point, collision.horizon(radius, speed, duration, t))
            checks += 1
            verdict, nearest, dt, t_next = collision.after_check(scalars, t, dist, hit is not None, nearest, duration,
                                                                 radius, speed, fine)
            if verdict == collision.CONTACT:
                self.robot_body.position = point
                return SweepResult(True, t, hit.name, checks, dist - radius, capped)
            if verdict == collision.END:
                break
            self.advance(dt)
            t = t_next
        self.robot_body.position = path(duration)
        return SweepResult(False, duration, None, checks, nearest - radius, capped)
