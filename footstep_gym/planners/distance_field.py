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

from footstep_gym.sensing import ObstacleView


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Distances ``(N,)`` [m] from complex ``points`` to the nearest of thick segments ``a-b`` (complex, ``(S,)``)."""
    if a.size == 0:
        return np.full(points.shape, np.inf)
    out = np.full(points.shape, np.inf)
    ab = b - a
    ab2 = np.where(np.abs(ab) > 0, np.abs(ab) ** 2, 1.0)
    for lo in range(0, points.size, 8192):  # bounded temporaries: (8192, S)
        p = points[lo:lo + 8192, None] - a[None, :]
        u = np.clip((p * ab.conj()).real / ab2, 0.0, 1.0)
        out[lo:lo + 8192] = (np.abs(p - u * ab) - radius).min(axis=1)
    return out


def static_geometry(views: Sequence[ObstacleView]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World-frame endpoints ``a, b`` (complex) and radii of the static shapes among ``views``."""
    a, b, r = [], [], []
    for v in views:
        if not v.static:
            continue
        rot = complex(math.cos(v.angle), math.sin(v.angle))
        pos = complex(*v.position)
        a.append(pos + rot * complex(*v.a))
        b.append(pos + rot * complex(*(v.b if v.kind == "segment" else v.a)))
        r.append(v.radius)
    return np.array(a, dtype=complex), np.array(b, dtype=complex), np.array(r, dtype=float)


class StaticDistanceField:
    """Distances to the static shapes of ``views`` on a grid over ``box = (low (2,), high (2,))`` [m]."""

    def __init__(self, views: Sequence[ObstacleView], box: tuple[Sequence[float], Sequence[float]],
                 resolution: float) -> None:
        if not resolution > 0:
            raise ValueError(f"resolution must be > 0, got {resolution}")
        self.resolution = float(resolution)
        self.key = self.geometry_key(views)
        self._a, self._b, self._r = static_geometry(views)
        lo, hi = (np.asarray(v, dtype=float) for v in box)
        self.low = lo
        self.shape = tuple(int(n) + 1 for n in np.ceil((hi - lo) / self.resolution))  # (nx, ny)
        self.high = lo + self.resolution * (np.array(self.shape) - 1)
        xs = lo[0] + self.resolution * np.arange(self.shape[0])
        ys = lo[1] + self.resolution * np.arange(self.shape[1])
        nodes = (xs[:, None] + 1j * ys[None, :]).ravel()
        exact = _segment_distance(nodes, self._a, self._b, self._r).reshape(self.shape)
        self._grid = exact - self.resolution / math.sqrt(2.0)

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
        out[inside] = self._grid[idx[inside, 0], idx[inside, 1]]
        if not inside.all():
            outside = pts[~inside]
            out[~inside] = _segment_distance(outside[:, 0] + 1j * outside[:, 1], self._a, self._b, self._r)
        return out
