"""``oracle-lookahead`` (the solvability reference of protocol 3) and the calibration that certifies cells with it.

Its rollouts' truth is checked against independent forms of the future: the constant-velocity prediction where
the scenario's motion is constant (the door's rod), the scripted crowd's own schedule at the grid's instants; it is
an upper bound registered as one, refuses to act unbound, and acts once bound. The calibration's rules (best
privileged solver, certification on 100 episodes) on hand-made scores.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from footstep_gym import make_policy
from footstep_gym.evaluation import calibration as cal
from footstep_gym.evaluation.benchmark import benchmark_cells
from footstep_gym.evaluation.runner import bind_truth
from footstep_gym.planners import POLICIES
from footstep_gym.planners.oracle import TruthModel, true_snapshot
from footstep_gym.planners.oracle_lookahead import TRUTH_STEP_S, OracleLookaheadPlanner, ScheduleTruth
from footstep_gym.planners.prediction import ObstaclePredictor
from footstep_gym.registry import resolve


def test_registered_as_an_upper_bound_that_acts_only_bound():
    spec = POLICIES["oracle-lookahead"]
    assert spec.planner is OracleLookaheadPlanner and resolve("oracle-lookahead").reads_truth
    assert spec.description.startswith("UPPER BOUND, not a baseline") and resolve("oracle-lookahead").label == \
        "oracle-lookahead (upper bound)"
    env = gym.make("FootstepCrossing-v0", tier="train", tier_cell="train")
    obs, _ = env.reset(seed=10000)
    policy = make_policy("oracle-lookahead", env.unwrapped.robot, seed=10000)
    policy.reset(seed=10000)
    assert policy.config.lookahead.horizon_steps > POLICIES["lookahead"].build("lookahead", policy.robot).params \
        .horizon_steps  # a larger budget than lookahead's
    with pytest.raises(RuntimeError, match="acts only once bound"):
        policy.act(obs, env.unwrapped.sensing())
    assert bind_truth(policy, env) and policy.bound and policy.greedy.bound
    for _ in range(2):
        command = policy.act(obs, None)  # reads the true snapshot off the env
        assert command.shape == (5,) and np.all(np.isfinite(command))
        obs, _, terminated, truncated, _ = env.step(command)
        assert not (terminated or truncated)


def _points(n: int = 40, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.0, 1.0, (n, 2)), TRUTH_STEP_S * rng.integers(0, 60, n)


def test_the_truth_of_constant_motion_is_the_constant_velocity_prediction():
    env = gym.make("FootstepDoor-v0")  # the rod turns at door_speed for ever: its truth is constant motion
    env.reset(seed=10000)
    u = env.unwrapped
    snap = true_snapshot(u)
    truth = ScheduleTruth(snap, TruthModel(u, snap.obstacles, 30.0), 30.0)
    points, times = _points()
    np.testing.assert_allclose(truth.clearance(points, times), ObstaclePredictor(snap, 30.0).clearance(points, times),
                               rtol=0, atol=1e-12)


def test_the_truth_of_the_scripted_crowd_is_its_schedule_on_the_grid():
    env = gym.make("FootstepCrowd-v0")
    env.reset(seed=10000)
    u = env.unwrapped
    for _ in range(3):
        env.step(u.robot.nominal_command)
    snap = true_snapshot(u)
    truth = ScheduleTruth(snap, TruthModel(u, snap.obstacles, 30.0), 30.0)
    points, times = _points(seed=1)
    got = truth.clearance(points, times)
    radius = {o.name: o.radius for o in snap.obstacles}
    names = [o.name for o in u.scenario.members]
    for p, t, g in zip(points, times, got):
        places = np.asarray(u.scenario.positions(u.time + t), dtype=float)
        expected = min(np.hypot(*(p - c)) - radius[n] for n, c in zip(names, places))
        assert g == pytest.approx(expected, abs=1e-9)


def _score(label: str, policy: str, wins: int, n: int) -> cal.CellScore:
    cell = next(c for c in benchmark_cells() if c.label == label)
    return cal.CellScore(cell, policy, wins, n)


def test_the_calibration_takes_the_best_privileged_solver_and_certifies_on_100_episodes():
    cell = "crossing/structure/wide_cars"
    scores = [_score(cell, "oracle", 80, 100), _score(cell, "oracle-lookahead", 95, 100),
              _score(cell, "null-stand", 0, 30)]
    best = cal.best_privileged(scores)[cell]
    assert (best.policy, best.rate) == ("oracle-lookahead", 0.95) and cal.certified(best)
    assert not cal.broken(scores)
    assert not cal.certified(_score(cell, "oracle-lookahead", 19, 20))  # 0.95, but on 20 episodes
    failing = [_score(cell, "oracle", 80, 100), _score(cell, "oracle-lookahead", 85, 100)]
    assert cal.broken(failing) == [f"{cell}: the best privileged solver (oracle-lookahead) succeeds in 85/100 < 0.9"]
    table = cal.markdown_table(scores + [_score("door/structure/two_doors", "oracle-lookahead", 19, 20)])
    assert "| oracle (validation) | oracle-lookahead (validation) | rule kept | certified |" in table
    assert "| 0.80 (80/100) | 0.95 (95/100) | yes | yes |" in table
    assert "no (20 < 100 episodes)" in table



def test_the_calibration_runs_named_cells_and_keeps_the_seeds_of_its_failures():
    cells = cal.select_cells(benchmark_cells(), ["structure/door/any_phase"])
    assert [cal.cell_name(c) for c in cells] == ["structure/door/any_phase"]
    with pytest.raises(ValueError, match="unknown cell.*'door/structure/any_phase'.*structure/door/any_phase"):
        cal.select_cells(benchmark_cells(), ["door/structure/any_phase"])  # the label's order is not the table's
    train = cal.select_cells(benchmark_cells(), ["train/door/train"])
    (standing,) = cal.score(train, ["null-stand"], 2, progress=False)  # steps in place: never reaches the goal
    assert (standing.successes, [seed for seed, _ in standing.failed]) == (0, [10000, 10001])
    assert all(outcome != "goal" for _, outcome in standing.failed)


@pytest.mark.parametrize("env_id, kwargs", [("FootstepDoor-v0", {"tier": "structure", "tier_cell": "two_doors"}),
                                            ("FootstepCrowd-v0", {}),
                                            ("FootstepCrossing-v0", {"tier": "structure", "tier_cell": "wide_cars"})])
def test_the_truths_checks_are_those_of_every_shape_at_its_time(env_id, kwargs):
    """The truth places a shape at rest once, leaves out walls no point comes near, turns shapes that never turn
    (the crowd's circles, the stream's cars) once and places the moving ones once per time a library's walks share:
    the same numbers, bit for bit, as every shape's pose at every point's time (TruthModel.poses) through the
    centre-line distance."""
    from footstep_gym.kernels.numpy_kernels import centre_line_gap2
    from footstep_gym.planners.oracle import TruthPredictor

    env = gym.make(env_id, **kwargs)
    env.reset(seed=10000)
    u = env.unwrapped
    env.step(u.robot.nominal_command)
    snap = true_snapshot(u)
    model = TruthModel(u, snap.obstacles, 6.0)
    truth = TruthPredictor(snap, model, 6.0)
    assert truth._fixed.size == sum(o.static for o in snap.obstacles)
    assert (truth._moves_rot is None) == (env_id == "FootstepDoor-v0")  # only the door's rods turn
    period = 0.7
    rng = np.random.default_rng(3)
    centre = np.asarray(snap.centre, dtype=float)
    for spread in (0.05, 0.5, 3.0):  # points in a small box (most walls pruned), a wide one (none)
        points = centre + rng.uniform(-spread, spread, (300, 2))
        times = rng.uniform(0.0, 8.0, 300)
        if spread == 0.5:  # 10 walks of 30 points at the same 30 times (a library's walks share their times)
            times = np.tile(times[:30], 10)
        c, a = model.poses(times, period)
        d2 = centre_line_gap2(points[:, 0] + 1j * points[:, 1], c, np.exp(1j * a), truth._la, truth._lab, truth._lab2)
        d2[times[:, None] > truth._truth_horizon] = np.inf
        if env_id == "FootstepDoor-v0" and spread < 1:  # the pruning is exercised: a small box leaves walls out
            p = points[:, 0] + 1j * points[:, 1]
            assert len(truth._near_fixed(p, truth._r[truth._fixed] + 0.4)) < truth._fixed.size
        for safe in (0.0, 0.15, 0.4):
            np.testing.assert_array_equal(truth.free_at(points, times, safe, period),
                                          (d2 >= (truth._r + safe) ** 2).all(axis=1))
        np.testing.assert_array_equal(truth.clearance_at(points, times, period),
                                      (np.sqrt(d2) - truth._r).min(axis=1))


def test_calibration_runs_merge_into_one_certification_table():
    def run(policy: str, wins: int, failed: list[int], s_per_episode: float) -> dict:
        return {"offset": 0, "cost": {policy: {"s_per_episode": s_per_episode}},
                "scores": [{"scene": "door", "tier": "structure", "cell": "any_phase", "policy": policy,
                            "successes": wins, "episodes": 100,
                            "failed": [{"seed": s, "outcome": "collision"} for s in failed]}]}

    first = run("oracle", 98, [], 2.0)
    again = run("oracle", 98, [10003, 10007], 1.0)  # the same seeds again, now with its failures' seeds
    scores, cost = cal.scores_from_runs([first, again, run("oracle-lookahead", 91, [], 5.0)])
    oracle = next(s for s in scores if s.policy == "oracle")
    assert oracle.failed == ((10003, "collision"), (10007, "collision")) and len(scores) == 2
    assert cost == {("structure/door/any_phase", "oracle"): 1.0, ("structure/door/any_phase", "oracle-lookahead"): 5.0}
    table = cal.certification_table(scores, cost)
    assert "| structure/door/any_phase | 0.98 (98/100) | 0.91 (91/100) | oracle 0.98 | oracle 1.0, " \
           "oracle-lookahead 5.0 | yes |" in table
    with pytest.raises(ValueError, match="disagree: 98/100 and 97/100"):
        cal.scores_from_runs([first, run("oracle", 97, [], 1.0)])
    # a calibration split over processes: disjoint seed ranges add up; overlapping ones are refused
    halves = [dict(run("oracle-lookahead", 46, [10007], 4.0), offset=0),
              dict(run("oracle-lookahead", 47, [10130], 6.0), offset=100)]
    for h in halves:
        h["scores"][0]["episodes"] = 50
    (joined,), cost = cal.scores_from_runs(halves)
    assert (joined.successes, joined.episodes, [seed for seed, _ in joined.failed]) == (93, 100, [10007, 10130])
    assert cost == {("structure/door/any_phase", "oracle-lookahead"): 5.0}
    with pytest.raises(ValueError, match="overlap"):
        cal.scores_from_runs([halves[0], dict(halves[1], offset=25)])


def test_the_centre_line_distance_of_circles_is_the_distance_to_their_centres():
    """Circles only (every centre line a point): the squared distance to the turned centre, bit for bit."""
    from footstep_gym.kernels.numpy_kernels import centre_line_gap2

    rng = np.random.default_rng(5)
    p = rng.uniform(-2, 2, 50) + 1j * rng.uniform(-2, 2, 50)
    centre = rng.uniform(-2, 2, (50, 4)) + 1j * rng.uniform(-2, 2, (50, 4))
    rot = np.exp(1j * rng.uniform(-np.pi, np.pi, 4))
    a = np.array([0, 0.1, -0.2j, 0.05 + 0.05j])  # a circle off its body's centre
    got = centre_line_gap2(p, centre, rot, a, np.zeros(4, complex), np.zeros(4))
    world = centre + rot * a
    np.testing.assert_array_equal(got, (p.real[:, None] - world.real) ** 2 + (p.imag[:, None] - world.imag) ** 2)


def test_the_crowds_schedule_at_many_times_is_its_schedule_at_each():
    env = gym.make("FootstepCrowd-v0", tier="structure", tier_cell="dense")
    env.reset(seed=10000)
    scenario = env.unwrapped.scenario
    times = np.concatenate([[0.0, 0.05, 3.7, 12.345, 80.0], 1.3 + 0.1 * np.arange(80)])  # before and after the ramp
    np.testing.assert_array_equal(scenario.positions_at(times), np.stack([scenario.positions(float(t)) for t in times]))


def test_the_streams_schedule_at_many_times_is_its_schedule_at_each():
    env = gym.make("FootstepCrossing-v0", tier="structure", tier_cell="wide_cars")
    env.reset(seed=10000)
    scenario = env.unwrapped.scenario
    times = np.array([0.0, 0.1, 3.7, 12.345, 80.0, 400.0])  # the last ones past a loop of the stream
    expected = np.stack([scenario.positions(float(t)) for t in times])
    np.testing.assert_array_equal(scenario.positions_at(times), expected)
    u = env.unwrapped
    views = true_snapshot(u).obstacles
    centres, *_ = TruthModel(u, views, 30.0).boundaries(0.7)  # the truth reads the schedule at a walk's boundaries
    taus = 0.7 * np.arange(len(centres))
    places = np.stack([scenario.positions(u.time + float(tau)) for tau in taus])
    columns = [i for i, v in enumerate(views) if not v.static]
    np.testing.assert_array_equal(centres[:, columns], places[..., 0] + 1j * places[..., 1])


def test_the_rollouts_read_the_truth_the_oracle_has_just_planned_on():
    """One truth per footstep: the rollouts reuse the greedy oracle's model (built from the same env at the same
    instant), whose tables are those of a model built afresh (an ORCA crowd's forward run included)."""
    env = gym.make("FootstepCrowd-v0", tier="structure", tier_cell="closing_in")
    obs, _ = env.reset(seed=10000)
    policy = make_policy("oracle-lookahead", env.unwrapped.robot, seed=10000)
    policy.reset(seed=10000)
    bind_truth(policy, env)
    obs, *_ = env.step(policy.act(obs, None))
    u = env.unwrapped
    snap = true_snapshot(u)
    policy.greedy.act(None, snap)
    truth = policy._rollout_predictor(snap).truth
    assert truth is policy.greedy.predictor.truth and truth.t0 == u.time
    fresh = TruthModel(u, snap.obstacles, policy.config.prediction.horizon_s)
    for period in (TRUTH_STEP_S, 0.7):
        for ours, theirs in zip(truth.boundaries(period), fresh.boundaries(period)):
            np.testing.assert_array_equal(ours, theirs)
    now = u.time
    policy.act(obs, None)  # each footstep plans on a truth of its own instant
    assert policy.greedy.predictor.truth is not truth and policy.greedy.predictor.truth.t0 == now
