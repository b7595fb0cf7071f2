"""A grid of distances to the static shapes (walls, posts), looked up conservatively.

The planners ask "how far is this body point from every obstacle" tens of thousands of
times per footstep. Static shapes never move, so their part of the answer is the same
at every instant and at every footstep of an episode: it is computed once on a grid of
``resolution`` [m] over a box and then read off. A point ``p`` reads the value at the
nearest grid node ``c``; since a distance function is 1-Lipschitz,
``d(p) >= d(c) - |p - c| >= d(c) - resolution / sqrt(2)``, and that lower bound is what
:meth:`StaticDistanceField.clearance` returns: never more than the true clearance, at
most ``resolution * sqrt(2)`` less. Points outside the box are measured exactly.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from footstep_gym.planners import kernels
from footstep_gym.sensing import ObstacleView, shapes_of



class StaticDistanceField:
    """Distances to the static shapes of ``views`` on a grid over ``box = (low (2,), high (2,))`` [m]."""

    def __init__(self, views: Sequence[ObstacleView], box: tuple[Sequence[float], Sequence[float]],
                 resolution: float) -> None:
        if not resolution > 0:
            raise ValueError(f"resolution must be > 0, got {resolution}")
        self.resolution = float(resolution)
        self.key = self.geometry_key(views)
        self._shapes = shapes_of([v for v in views if v.static])
        lo, hi = (np.asarray(v, dtype=float) for v in box)
        self.low = lo
        self.shape = tuple(int(n) + 1 for n in np.ceil((hi - lo) / self.resolution))  # (nx, ny)
        self.high = lo + self.resolution * (np.array(self.shape) - 1)
        xs = lo[0] + self.resolution * np.arange(self.shape[0])
        ys = lo[1] + self.resolution * np.arange(self.shape[1])
        sh = self._shapes
        exact = kernels.grid_clearance(xs, ys, np.ascontiguousarray(sh.circle_centres, dtype=float).reshape(-1, 2),
                                       np.ascontiguousarray(sh.circle_radii, dtype=float),
                                       np.ascontiguousarray(sh.segment_a, dtype=float).reshape(-1, 2),
                                       np.ascontiguousarray(sh.segment_b, dtype=float).reshape(-1, 2),
                                       np.ascontiguousarray(sh.segment_radii, dtype=float))
        self.grid = exact - self.resolution / math.sqrt(2.0)  # (nx, ny) lower bounds [m] at the nodes

    @staticmethod
    def geometry_key(views: Sequence[ObstacleView]) -> tuple:
        """What identifies the static geometry: the field can be reused while this is unchanged."""
        return tuple((v.name, v.kind, v.position, v.angle, v.a, v.b, v.radius) for v in views if v.static)

    def covers(self, box: tuple[Sequence[float], Sequence[float]]) -> bool:
        """Whether ``box`` lies inside the grid."""
        lo, hi = (np.asarray(v, dtype=float) for v in box)
        return bool(np.all(lo >= self.low) and np.all(hi <= self.high))

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """A lower bound ``(N,)`` [m] of the distance from each point ``(N, 2)`` to the nearest static shape."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        idx = np.rint((pts - self.low) / self.resolution).astype(np.intp)
        inside = np.all((idx >= 0) & (idx < np.array(self.shape)), axis=1)
        out = np.empty(len(pts))
        out[inside] = self.grid[idx[inside, 0], idx[inside, 1]]
        if not inside.all():
            out[~inside] = self._shapes.clearance(pts[~inside])
        return out
