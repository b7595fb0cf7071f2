""":class:`StaticDistanceField`: a tight lower bound of the distance to the static shapes inside its box,
exact outside it.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)

# ====================================================================== static distance field
def _brute_static_clearance(views, pts):
    """Distance from each point to the nearest static shape, one shape at a time (plain geometry)."""
    best = np.full(len(pts), np.inf)
    for v in views:
        if not v.static:
            continue
        c, s = math.cos(v.angle), math.sin(v.angle)
        ends = [np.array(v.position) + np.array([c * x - s * y, s * x + c * y]) for x, y in (v.a, v.b)]
        a, b = ends if v.kind == "segment" else (ends[0], ends[0])
        ab = b - a
        t = np.clip(((pts - a) @ ab) / max(float(ab @ ab), 1e-300), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(pts - (a + t[:, None] * ab), axis=1) - v.radius)
    return best


def test_static_distance_field_is_a_tight_lower_bound_and_exact_outside_its_box():
    from footstep_gym.planners.distance_field import StaticDistanceField

    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    views = env.unwrapped.sensing().obstacles
    lo, hi = np.array([-1.0, -0.9]), np.array([1.0, 0.7])
    res = 0.01
    field = StaticDistanceField(views, (lo, hi), res)
    rng = np.random.default_rng(0)
    inside = lo + (hi - lo) * rng.random((4000, 2))
    exact = _brute_static_clearance(views, inside)
    got = field.clearance(inside)
    assert np.all(got <= exact + 1e-12)  # never more room than there is
    assert np.all(got >= exact - res * math.sqrt(2.0) - 1e-12)  # and at most a cell's diagonal less
    outside = np.array([[-1.7, -0.3], [1.6, -0.62], [0.0, 1.5]])
    np.testing.assert_allclose(field.clearance(outside), _brute_static_clearance(views, outside), atol=1e-12)
    assert field.covers((lo + 0.1, hi - 0.1)) and not field.covers((lo - 0.1, hi))
    with pytest.raises(ValueError, match="resolution"):
        StaticDistanceField(views, (lo, hi), 0.0)
