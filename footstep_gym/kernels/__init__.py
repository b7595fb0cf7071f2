"""The inner loops of the planners and of the world: one interface, two implementations.

The planners ask tens of thousands of small questions per footstep ("is this body point, at
this time, clear of every predicted shape?"). Each hot loop exists twice, behind the one
interface :class:`Kernels`, with identical signatures:

* :class:`~.numpy_kernels.NumpyKernels` (``"numpy"``): vectorised numpy, the readable
  implementation and the test oracle. It checks walks with any :class:`BodyCheck`.
* :class:`~.numba_kernels.NumbaKernels` (``"numba"``): compiled loops over points and shapes
  that stop at the first shape blocking a point. They read the shapes from a
  :class:`ShapeTable`, so they need a body check that has one (a
  :class:`footstep_gym.planners.prediction.BodyModel`) and refuse any other with ``TypeError``.

A planner chooses its kernels once, from ``configs/planner.yaml``'s ``kernels.compiled``
(:func:`select_kernels`), and hands the same object to its stages. ``tests/test_kernels.py``
holds the two equal: the same booleans, instants and tree shapes exactly, the floats to a few
ulps, and whole planner episodes the same with either. Selecting the numpy kernels never imports
numba.

The world's collision sweep lives here too (:mod:`.sweep`, compiled); its oracle is pymunk
(:meth:`footstep_gym.world.World.sweep_pymunk`), chosen by the env's ``compiled_sweep``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, Protocol, Sequence

import numpy as np

#: Columns of a :class:`ShapeTable`'s rows: position [m] and velocity [m/s] of the body origin, yaw [rad] and yaw
#: rate [rad/s], the cosine and sine of the yaw (of a shape that does not turn), the segment's start ``a`` and its
#: vector ``ab`` in the body frame [m], ``|ab|^2`` [m^2] (0 for a circle), the sensed acceleration [m/s^2] and how
#: long it is held [s] (0: none, the shape moves at constant velocity).
(POS_X, POS_Y, VEL_X, VEL_Y, ANGLE, OMEGA, COS0, SIN0, A_X, A_Y, AB_X, AB_Y, AB2,
 ACC_X, ACC_Y, ACC_T) = range(16)
SHAPE_COLUMNS = 16


@dataclass(frozen=True, eq=False)
class ShapeTable:
    """The predicted shapes as both kernels read them: thick segments (a circle: one of zero length).

    ``rows (S, SHAPE_COLUMNS)``: one shape per row, its columns named by :data:`POS_X` ... :data:`ACC_T`;
    ``radius (S,)`` [m]: half thickness; ``horizon (S,)`` [s]: a shape is not checked at later times.
    """

    rows: np.ndarray
    radius: np.ndarray
    horizon: np.ndarray

    def __post_init__(self) -> None:
        if self.rows.ndim != 2 or self.rows.shape[1] != SHAPE_COLUMNS:
            raise ValueError(f"a shape table has {SHAPE_COLUMNS} columns per shape; got an array of shape "
                             f"{self.rows.shape}")
        if not (self.radius.shape == self.horizon.shape == self.rows.shape[:1]):
            raise ValueError(f"radius {self.radius.shape} and horizon {self.horizon.shape} need one entry per "
                             f"shape ({len(self.rows)})")

    @property
    def n_shapes(self) -> int:
        return len(self.rows)

    @functools.cached_property
    def complex_form(self) -> dict[str, Any]:
        """The columns as the numpy kernels read them: 2D vectors as complex numbers ``x + iy`` (``position``,
        ``velocity``, ``a``, ``ab``, ``acceleration``), the rest as they are (``angle``, ``omega``, ``ab2``,
        ``acceleration_time``); ``accelerates``: whether any shape has a sensed acceleration."""
        r = self.rows
        pair = lambda x, y: r[:, x] + 1j * r[:, y]  # noqa: E731
        return dict(position=pair(POS_X, POS_Y), velocity=pair(VEL_X, VEL_Y), a=pair(A_X, A_Y), ab=pair(AB_X, AB_Y),
                    acceleration=pair(ACC_X, ACC_Y), angle=r[:, ANGLE], omega=r[:, OMEGA], ab2=r[:, AB2],
                    acceleration_time=r[:, ACC_T], accelerates=bool((r[:, ACC_T] > 0).any()))


class BodyCheck(Protocol):
    """``free(points (N, 2), times (N,), support_normals (N, 2), period) -> (N,)`` bool, and ``slack``
    (the same arguments) -> clearance [m] beyond the required one (e.g.
    :class:`footstep_gym.planners.prediction.BodyModel`)."""

    def free(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray,
             period: float) -> np.ndarray: ...

    def slack(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray,
              period: float) -> np.ndarray: ...


@dataclass(frozen=True)
class WalkStart:
    """Where a walk (a rollout or the RRT) starts, in the paper's node convention.

    ``node``: the support foot's node (the point ``half_width`` inside the support foot,
    perpendicular to its yaw, i.e. the inverse of :func:`footstep.foot_from_node`);
    ``heading``: the support foot's yaw; ``side``: the support side (+1 left, -1 right);
    ``body``: where the body (CoM ground projection) is now; ``previous_node``: the swing
    foot's node.
    """

    node: np.ndarray  # (2,) [m]
    heading: float  # [rad]
    side: int
    body: np.ndarray  # (2,) [m]
    previous_node: np.ndarray  # (2,) [m]


#: ``(lo, hi)`` [rad]: the turns allowed to the foot swinging from one support side (:func:`footstep.turn_bounds`).
TurnLimits = tuple[float, float]


@dataclass(frozen=True)
class Lanes:
    """The rollouts' lanes (:class:`footstep_gym.planners.rollouts.GoalRollouts`), for :meth:`Kernels.pursue_lanes`.

    Rollout ``r`` follows the line from ``node`` [m] along the unit vector ``axis`` (``length`` [m] to the goal),
    offset sideways by ``offsets[r]`` [m]; it aims ``lookahead`` [m] ahead, waits ``waits[r]`` steps, then strides
    ``strides[r]`` [m]. It starts at ``heading`` [rad] on support ``side`` (+1 left); ``left``/``right``: the
    turn limits from a left / right support; ``goal`` (2,) [m], ``goal_radius`` [m]: where a rollout stops.
    """

    node: np.ndarray
    axis: np.ndarray
    length: float
    goal: np.ndarray
    goal_radius: float
    lookahead: float
    heading: float
    side: int
    offsets: np.ndarray  # (R,) [m]
    strides: np.ndarray  # (R,) [m]
    waits: np.ndarray  # (R,) int64 [steps]
    left: TurnLimits
    right: TurnLimits


@dataclass(frozen=True)
class TreeStep:
    """How the modified RRT extends a node (:meth:`Kernels.extend_tree`), one record per plan.

    ``goal`` (2,) [m] and ``goal_radius`` [m]: the goal region its bodies must reach; ``step_size`` [m]: the
    longest edge; ``first_stride``: ``(lo, hi)`` [m] for the root's edges, or ``None``; ``left``/``right``: the
    turn limits of the foot swinging from a left / right support; ``period`` [s]: a node at depth ``d`` is
    reached during ``[d T, (d + 1) T]`` (checked at ``T`` if not ``time_aware``); ``edge_samples``: points per
    body segment; ``check_node``: the new node is checked (at the start and end of its step) instead of the
    body's path to it.
    """

    goal: np.ndarray
    goal_radius: float
    step_size: float
    first_stride: tuple[float, float] | None
    left: TurnLimits
    right: TurnLimits
    period: float
    time_aware: bool
    edge_samples: int
    check_node: bool


class TreeArrays(Protocol):
    """The RRT's nodes in preallocated arrays, the first ``n`` in use (index 0: the root); what
    :meth:`Kernels.extend_tree` and :meth:`Kernels.insert_walks` append to (e.g. :class:`.rrt.Tree`)."""

    xy: np.ndarray  # (capacity, 2) [m] the nodes
    heading: np.ndarray  # (capacity,) [rad]
    side: np.ndarray  # (capacity,) int: the side of the foot placed at the node
    parent: np.ndarray  # (capacity,) int
    cost: np.ndarray  # (capacity,) [m] path length from the root
    depth: np.ndarray  # (capacity,) int: steps from the root
    body: np.ndarray  # (capacity, 2) [m] the body when the node is reached
    n: int


class Kernels(Protocol):
    """The planners' hot loops; :func:`select_kernels` gives the numpy or the compiled implementation."""

    name: str  # "numpy" or "numba"

    def check_body(self, body: BodyCheck) -> None:
        """Raise ``TypeError`` if these kernels cannot check walks with ``body``."""

    def points_free(self, shapes: ShapeTable, points: np.ndarray, times: np.ndarray,
                    safe_distance: float | np.ndarray) -> np.ndarray:
        """``(N,)`` bool: point ``points[i]`` [m] at ``times[i]`` [s] is at least ``radius + safe_distance`` [m]
        from every shape's centre line (shapes beyond their horizon are not checked)."""

    def body_free(self, body: BodyCheck, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray,
                  period: float) -> np.ndarray:
        """``body.free``: the body near ``points`` (N, 2) at ``times`` clears every obstacle, ``(N,)`` bool."""

    def walks_survival(self, body: BodyCheck, start: WalkStart, walks: Sequence[tuple[np.ndarray, np.ndarray]],
                       periods: Sequence[float], edge_samples: int, goal: np.ndarray,
                       goal_radius: float) -> list[np.ndarray]:
        """For each group ``(nodes (R, D + 1, 2), headings (R, D + 1))`` of ``walks`` at its period
        ``periods[i]`` [s]: ``(R,)`` [s] the time of each walk's first blocked body point, ``inf`` if free.

        Step ``d`` moves the body from the midpoint of nodes ``d - 1, d`` to that of ``d, d + 1`` (``start``'s
        body and previous node before the first) during ``[d T, (d + 1) T]``, checked at ``edge_samples``
        points with the support foot's normal; once the body is within ``goal_radius`` [m] of ``goal`` the
        walk is not checked further."""

    def pursue_lanes(self, lanes: Lanes, window: tuple[float, float] | None,
                     depth: int) -> tuple[np.ndarray, np.ndarray]:
        """Pure pursuit of each lane for ``depth`` steps: nodes ``(R, depth + 1, 2)`` [m], headings
        ``(R, depth + 1)`` [rad]; ``window``: ``(lo, hi)`` [m] of the first stride, or ``None``."""

    def extend_tree(self, tree: TreeArrays, step: TreeStep, body: BodyCheck, samples: np.ndarray,
                    redraw: np.ndarray) -> list[int]:
        """One batch of the modified RRT (Algorithm 2, steps 5-16) on ``tree``, in place; returns the new nodes
        whose body is in the goal region. ``samples (B, 2)`` [m]; ``redraw (B,)`` uniform in [0, 1)."""

    def insert_walks(self, tree: TreeArrays, walks: Sequence[np.ndarray], goal: np.ndarray,
                     goal_radius: float) -> list[int]:
        """Append known-free ``walks`` (``(k + 1, 2)`` [m], row 0 the root) to ``tree`` as chains from the root;
        returns the new nodes whose body is in the goal region."""


def select_kernels(compiled: bool) -> Kernels:
    """The compiled kernels (``compiled``; imports numba) or the numpy ones: ``kernels.compiled`` of
    ``configs/planner.yaml``. The same object for the same answer."""
    if not isinstance(compiled, (bool, np.bool_)):
        raise TypeError(f"select_kernels takes a bool (kernels.compiled), got {compiled!r}")
    if compiled:
        from footstep_gym.kernels.numba_kernels import NUMBA  # imports numba: only when asked for

        return NUMBA
    from footstep_gym.kernels.numpy_kernels import NUMPY

    return NUMPY


@functools.lru_cache(maxsize=8)
def step_fractions(samples: int) -> np.ndarray:
    """``samples`` fractions of a step, ends included (read-only: shared between calls)."""
    out = np.linspace(0.0, 1.0, samples)
    out.flags.writeable = False
    return out
