"""Distances between points and obstacle shapes (circles, thick segments), batched numpy."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def rotate(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rotate 2D vectors ``v`` (..., 2) by ``angle`` [rad] (broadcast)."""
    c, s = np.cos(angle), np.sin(angle)
    x, y = v[..., 0], v[..., 1]
    return np.stack([c * x - s * y, s * x + c * y], axis=-1)


def point_segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance [m] from each point ``(N, 2)`` to each segment ``a-b`` ``(K, 2)``: shape ``(N, K)``."""
    # per coordinate rather than on (N, K, 2) arrays: the same arithmetic without the (N, K, 2) temporaries
    apx = points[:, 0, None] - a[None, :, 0]
    apy = points[:, 1, None] - a[None, :, 1]
    abx, aby = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    denom = abx * abx + aby * aby
    t = np.clip((apx * abx + apy * aby) / np.where(denom > 0, denom, 1.0), 0.0, 1.0)  # 0 for a point "segment"
    return np.hypot(apx - t * abx, apy - t * aby)


@dataclass(frozen=True)
class Shapes:
    """Obstacle shapes frozen at one instant, in world coordinates [m].

    Circles: ``circle_centres (M, 2)``, ``circle_radii (M,)``. Segments (rods, walls) with
    thickness: endpoints ``segment_a``, ``segment_b`` ``(K, 2)``, ``segment_radii (K,)``.
    """

    circle_centres: np.ndarray
    circle_radii: np.ndarray
    segment_a: np.ndarray
    segment_b: np.ndarray
    segment_radii: np.ndarray

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Signed distance [m] from each point ``(N, 2)`` to each shape's surface: ``(N, M + K)``."""
        pts = np.atleast_2d(np.asarray(points, dtype=float))
        d_c = np.linalg.norm(pts[:, None, :] - self.circle_centres[None], axis=-1) - self.circle_radii
        d_s = point_segment_distance(pts, self.segment_a, self.segment_b) - self.segment_radii
        return np.concatenate([d_c, d_s], axis=1)

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """Distance [m] from each point ``(N, 2)`` to the nearest shape surface (``inf`` if none)."""
        d = self.distances(points)
        if d.shape[1] == 0:
            return np.full(d.shape[0], np.inf)
        return d.min(axis=1)
