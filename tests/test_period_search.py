"""Stage 1 (:mod:`footstep_gym.planners.period_search`): :func:`longest_free_period` (Algorithm 1 as its text
describes it) on hand-made monotone predicates ``collides(T) = T > T*`` whose answer ``T*`` is known; the
stage's record; the kept plan bracketing the search from below.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym.planners.period_search import longest_free_period
from planner_helpers import EPS

T0, TN = 0.3, 0.8


@pytest.mark.parametrize("iterations", [1, 4, 6, 10])
@pytest.mark.parametrize("t_star", [0.31, 0.42, 0.55, 0.5499, 0.7, 0.79])
@pytest.mark.parametrize("strict", [True, False])
def test_binary_search_finds_boundary_inside(t_star, iterations, strict):
    calls = []

    def collides(t):
        calls.append(t)
        return t > t_star if strict else t >= t_star

    res = longest_free_period(collides, T0, TN, iterations)
    assert res.evaluations == len(calls) == 2 + iterations
    assert not res.nominal_free and res.any_free
    # on the free side of the boundary, within the promised resolution
    assert not collides(res.period)
    assert res.period <= t_star + EPS
    assert t_star - res.period <= (TN - T0) / 2 ** iterations + EPS
    assert T0 <= res.period <= TN
    # every evaluated period lies in [T0, T_n]
    assert all(T0 - EPS <= t <= TN + EPS for t in calls)


@pytest.mark.parametrize("t_star", [0.8, 0.9, 5.0])
def test_binary_search_nominal_free_returns_nominal(t_star):
    calls = []

    def collides(t):
        calls.append(t)
        return t > t_star

    res = longest_free_period(collides, T0, TN, 6)
    assert res.period == TN
    assert res.nominal_free and res.any_free
    assert res.evaluations == len(calls) == 1


@pytest.mark.parametrize("t_star", [0.0, 0.1, 0.2999])
def test_binary_search_nothing_free_returns_t_short(t_star):
    calls = []

    def collides(t):
        calls.append(t)
        return t > t_star

    res = longest_free_period(collides, T0, TN, 6)
    assert res.period == T0
    assert not res.nominal_free and not res.any_free
    assert res.evaluations == len(calls) == 2


def test_binary_search_resolution_improves_with_iterations():
    """The error halves per pass (until the boundary is hit exactly)."""
    t_star = 0.3 + 0.5 / math.pi  # not on any dyadic grid point of [0.3, 0.8]
    errors = [t_star - longest_free_period(lambda t: t > t_star, T0, TN, n).period for n in range(1, 16)]
    assert all(0.0 <= e <= (TN - T0) / 2 ** n + EPS for n, e in zip(range(1, 16), errors))
    assert errors[-1] < 2e-5


def test_binary_search_degenerate_interval():
    assert longest_free_period(lambda t: False, 0.5, 0.5, 6).period == 0.5
    assert longest_free_period(lambda t: True, 0.5, 0.5, 6).period == 0.5


def test_binary_search_rejects_inverted_interval():
    with pytest.raises(ValueError):
        longest_free_period(lambda t: False, 0.9, 0.8, 6)


# ====================================================================== the planner keeps its plan
@pytest.mark.parametrize("door_speed,seed", [(17.0, 0), (17.0, 2), (14.0, 4)])
def test_kept_plan_brackets_the_period_search_from_below(door_speed, seed):
    """Whenever the previous step's plan is kept, the period searched is no shorter than that plan's
    (the previous step's search result). Episodes 17/2 and 14/4 each have a kept step where a search
    from the reachable floor instead of the kept plan's period would return a shorter period."""
    from footstep_gym.planners import make_policy

    env = gym.make("FootstepDoor-v0", door_speed=door_speed)
    u = env.unwrapped
    policy = make_policy("period-aware", u.robot, seed=0)
    policy.reset(seed=seed)
    obs, _ = env.reset(seed=seed)
    previous, kept = None, 0
    for _ in range(60):
        action = policy.act(obs, u.sensing())
        info = policy.last_info
        if info["plan_kept"]:
            assert previous is not None
            assert info["period_search"] >= previous - 1e-9, (info["period_search"], previous)
            kept += 1
        previous = info["period_search"]
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    env.close()
    assert kept >= 3  # the property was exercised
