"""The tracker (planners/tracking.py), its switch ``additions.tracking`` and the agents' wrapper.

* its maths is a Kalman filter's: predict and update equal a textbook matrix filter written out here;
* against synthetic tracks with known truth its error shrinks with readings and ends below a reading's;
  a fixed pivot is found still; a shape that jumps (a car re-entering) restarts its track;
* the noise levels estimated from the readings come near the stds that made them;
* exact readings pass unchanged, so a noise-free episode plans the same commands with and without it;
* it never reads the env's truth (a scan of what its modules import and touch, which finds a planted use);
* seeded and replayable: the same seed replays a noisy episode command for command;
* the wrapper hands an agent the same estimates, and the env's own observation where readings are exact.
"""

from __future__ import annotations

import ast
import dataclasses
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import make_policy
from footstep_gym.errors import ConfigError
from footstep_gym.planners import POLICIES, load_planner_config, policy_spec
from footstep_gym.planners.tracking import Tracker, predict, update
from footstep_gym.robot import Robot
from footstep_gym.sensing import ObstacleView, Snapshot
from footstep_gym.observation import HEAD, ObservationScales
from footstep_gym.wrappers import TrackedObservation, obstacle_slots

REPO = Path(__file__).resolve().parents[1]
PARAMS = load_planner_config().tracking
#: The hard tier's sensing-noise profile (configs/benchmark.yaml x-noise): position, velocity, angle, turn rate.
PROFILE = (0.02, 0.05, 0.01, 0.01)


# ---------------------------------------------------------------- the maths against a textbook filter
def test_predict_and_update_are_a_textbook_kalman_filter():
    rng = np.random.default_rng(0)
    n = 7
    x = rng.normal(size=(n, 2))
    L = rng.normal(size=(n, 2, 2))
    P = L @ np.swapaxes(L, 1, 2) + 0.1 * np.eye(2)
    dt, q = rng.uniform(0.2, 0.9, n), rng.uniform(0.0, 0.1, n)
    z, r = rng.normal(size=(n, 2)), rng.uniform(0.01, 0.2, (n, 2))
    xp, Pp = predict(x, P, dt, q)
    xu, Pu, nis = update(xp, Pp, z, r)
    for i in range(n):
        F = np.array([[1.0, dt[i]], [0.0, 1.0]])
        # The rate steps by w ~ N(0, q dt) over the footstep; the value moves with the new rate: G = [dt, 1].
        G = np.array([[dt[i]], [1.0]])
        x1 = F @ x[i]
        P1 = F @ P[i] @ F.T + q[i] * dt[i] * G @ G.T
        H, R = np.eye(2), np.diag(r[i])
        S = H @ P1 @ H.T + R
        K = P1 @ H.T @ np.linalg.inv(S)
        y = z[i] - H @ x1
        np.testing.assert_allclose(xp[i], x1, rtol=1e-12)
        np.testing.assert_allclose(Pp[i], P1, rtol=1e-12)
        np.testing.assert_allclose(xu[i], x1 + K @ y, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(Pu[i], (np.eye(2) - K @ H) @ P1, rtol=1e-9, atol=1e-12)
        assert nis[i] == pytest.approx(y @ np.linalg.solve(S, y), rel=1e-10)


def test_an_angle_innovation_is_taken_the_short_way_round():
    x, P = np.array([[math.pi - 0.01, 0.0]]), np.eye(2)[None] * 0.01
    xu, _, _ = update(x, P, np.array([[-math.pi + 0.01, 0.0]]), np.array([[0.01, 0.01]]), np.array([True]))
    assert xu[0, 0] == pytest.approx(math.pi - 0.01 + 0.01, abs=1e-9)  # half way along the 0.02 rad between


# ---------------------------------------------------------------- synthetic tracks with known truth
ROBOT = Robot.load() if hasattr(Robot, "load") else None


def _robot() -> Robot:
    env = gym.make("FootstepDoor-v0")
    robot = env.unwrapped.robot
    env.close()
    return robot


def _snapshot(robot: Robot, time: float, views: tuple[ObstacleView, ...]) -> Snapshot:
    return Snapshot(time=time, robot=robot, support_side=1, support_foot=(0.0, 0.1, 0.0), swing_foot=(0.0, -0.1, 0.0),
                    com=(0.0, 0.0), com_vel=(0.0, 0.0), com_local=(0.0, -0.1), vel_local=(0.0, 0.0), goal=(5.0, 0.0),
                    goal_tolerance=0.1, previous_command=(0.0, 0.2, 0.0, 0.6, 0.2), obstacles=views)


def _synthetic(seed: int, steps: int, stds=PROFILE, members: int = 6):
    """Per footstep (random periods): the truth and a noisy reading of a door (a rod turning at 0.2 rad/s about a
    fixed pivot), a car (a rod crossing at 0.3 m/s) and ``members`` pedestrians (circles at constant velocity)."""
    rng = np.random.default_rng(seed)
    sp, sv, sa, sw = stds
    truths, readings, t = [], [], 0.0
    ped_p0 = rng.uniform(-2, 2, (members, 2))
    ped_v = rng.uniform(-0.3, 0.3, (members, 2))
    for _ in range(steps):
        truth = [ObstacleView("door", "segment", False, (1.0, 0.5), 0.3 + 0.2 * t, (0.0, 0.0), 0.2, 0.02, (-0.6, 0.0),
                              (0.6, 0.0)),
                 ObstacleView("car", "segment", False, (-1.0, -2.0 + 0.3 * t), 0.0, (0.0, 0.3), 0.0, 0.1, (-0.25, 0.0),
                              (0.25, 0.0))]
        truth += [ObstacleView(f"member_{i}", "circle", False, tuple(ped_p0[i] + ped_v[i] * t), 0.0, tuple(ped_v[i]),
                               0.0, 0.1, (0.0, 0.0), (0.0, 0.0)) for i in range(members)]
        noisy = []
        for v in truth:
            z = rng.standard_normal(6)
            rod = v.kind == "segment"
            noisy.append(dataclasses.replace(
                v, position=(v.position[0] + sp * z[0], v.position[1] + sp * z[1]),
                velocity=(v.velocity[0] + sv * z[2], v.velocity[1] + sv * z[3]),
                angle=v.angle + sa * z[4] if rod else v.angle,
                angular_velocity=v.angular_velocity + sw * z[5] if rod else v.angular_velocity))
        wall = ObstacleView("wall", "segment", True, (0.0, 0.0), 0.0, (0.0, 0.0), 0.0, 0.05, (-3.0, 3.0), (3.0, 3.0))
        truths.append((t, tuple(truth)))
        readings.append((t, (wall, *noisy)))
        t += float(rng.uniform(0.3, 0.9))
    return truths, readings


def _errors(truths, estimates):
    """Per footstep and moving shape: (position error [m], velocity error [m/s], angle error [rad])."""
    out = []
    for (_, truth), est in zip(truths, estimates):
        by_name = {v.name: v for v in est}
        out.append([(math.dist(v.position, by_name[v.name].position), math.dist(v.velocity, by_name[v.name].velocity),
                     abs(v.angle - by_name[v.name].angle)) for v in truth])
    return np.array(out)  # (steps, shapes, 3)


@pytest.mark.parametrize("noise", ["profile", "estimated"])
def test_error_shrinks_with_readings_on_synthetic_tracks(noise):
    robot = _robot()
    params = PARAMS if noise == "profile" else dataclasses.replace(PARAMS, estimate_noise=True)
    raw_err, est_err = [], []
    for seed in range(4):
        truths, readings = _synthetic(seed, 40)
        tracker = Tracker(params)
        estimates = [tracker.update(_snapshot(robot, t, views)).obstacles for t, views in readings]
        raw_err.append(_errors(truths, [views for _, views in readings]))
        est_err.append(_errors(truths, estimates))
        assert tracker.restarts == 0  # nothing here jumps
    raw, est = np.concatenate(raw_err, axis=1), np.concatenate(est_err, axis=1)
    rods = [0, 1, 8, 9, 16, 17, 24, 25]  # the door and the car of each run (a circle's angle is not sensed)
    early, late = est[2:6].mean(axis=(0, 1)), est[30:].mean(axis=(0, 1))
    early[2], late[2] = est[2:6, rods, 2].mean(), est[30:, rods, 2].mean()
    raw_late = raw[30:].mean(axis=(0, 1))
    raw_late[2] = raw[30:, rods, 2].mean()
    assert (late < early).all(), (early, late)  # position, velocity and angle errors all shrink
    assert late[0] < 0.6 * raw_late[0] and late[1] < 0.4 * raw_late[1]
    assert late[2] < 0.7 * raw_late[2]
    # The door's pivot stands still: the still model wins and its velocity is zero, not the readings' noise.
    door_velocity = est[30:, 0, 1]
    assert (door_velocity == 0.0).mean() > 0.9


def test_the_estimated_noise_levels_come_near_the_stds_that_made_the_readings():
    robot = _robot()
    stds = (0.03, 0.04, 0.02, 0.015)
    tracker = Tracker(dataclasses.replace(PARAMS, estimate_noise=True))
    _, readings = _synthetic(7, 60, stds, members=12)
    for t, views in readings:
        tracker.update(_snapshot(robot, t, views))
    levels = tracker.levels()
    assert levels["linear"].value == pytest.approx(stds[0], rel=0.15)
    assert levels["linear"].rate == pytest.approx(stds[1], rel=0.3)
    assert levels["linear"].q < 0.01  # constant velocities: the floor or near it
    assert levels["angular"].value == pytest.approx(stds[2], rel=0.3)


def test_a_shape_that_jumps_restarts_its_track_at_the_reading():
    robot = _robot()
    tracker = Tracker(PARAMS)
    truths, readings = _synthetic(1, 12, members=0)
    for t, views in readings:
        tracker.update(_snapshot(robot, t, views))
    t = readings[-1][0] + 0.6
    car = next(v for v in readings[-1][1] if v.name == "car")
    moved = dataclasses.replace(car, position=(car.position[0], car.position[1] - 4.0))  # re-entering the lane
    out = tracker.update(_snapshot(robot, t, (moved,)))  # the door unseen this once: its track waits
    assert tracker.restarts == 1
    assert next(v for v in out.obstacles if v.name == "car").position == moved.position


def _flagged(tracker: Tracker | None, readings, robot, params, stds: float) -> list[set[str]]:
    """Per footstep, the shapes the prediction finds unsteady (their estimated or sensed velocity changed)."""
    from footstep_gym.planners.prediction import steady_motion_horizons

    out, previous = [], None
    for t, views in readings:
        snapshot = _snapshot(robot, t, views)
        if tracker is not None:
            snapshot = tracker.update(snapshot)
        noise = tracker.rate_change_stds() if tracker is not None else None
        out.append(set(steady_motion_horizons(previous, snapshot, 2.0, params.unsteady_speed_mps,
                                              params.unsteady_turn_rad_s, noise, stds)))
        previous = snapshot
    return out


def _stream(seed: int, stds: tuple[float, float], turn_at: int, steps: int = 45):
    """Eight cars of one lane at 0.25 m/s, 0.9 m apart, read with position and velocity stds ``stds``; car 0
    reverses at footstep ``turn_at``."""
    rng = np.random.default_rng(seed)
    readings, t, t_turn = [], 0.0, None
    for k in range(steps):
        if k == turn_at:
            t_turn = t
        views = []
        for i in range(8):
            turned = i == 0 and t_turn is not None
            y = -3.0 + 0.9 * i + (0.25 * (2 * t_turn - t) if turned else 0.25 * t)
            z = rng.standard_normal(4)
            views.append(ObstacleView(f"car_{i}", "segment", False, (0.9 + stds[0] * z[0], y + stds[0] * z[1]), 0.0,
                                      (stds[1] * z[2], (-0.25 if turned else 0.25) + stds[1] * z[3]), 0.0, 0.12,
                                      (0.0, -0.13), (0.0, 0.13)))
        readings.append((t, tuple(views)))
        t += float(rng.uniform(0.3, 0.6))
    return readings


def test_a_steady_stream_is_not_taken_for_unsteady_but_a_turn_is():
    """Cars at one constant velocity, read with noise: while their filters settle the filtered velocities move by
    more than the fixed tolerance (1 cm/s) each footstep, which would take them for a change of motion; measured
    against the filter's own correction std they stay steady, while a car that turns is found at once."""
    robot = _robot()
    prediction = load_planner_config().prediction
    turn_at = 30
    readings = _stream(5, PROFILE[:2], turn_at)
    own = dataclasses.replace(PARAMS, shared_velocity_gate=0.0)  # each car's own filter
    plain = _flagged(Tracker(own), readings, robot, prediction, 0.0)
    tested = _flagged(Tracker(own), readings, robot, prediction, 3.0)
    # With the lane's velocity shared, the fixed tolerance alone leaves the steady cars steady.
    shared = _flagged(Tracker(dataclasses.replace(PARAMS, shared_velocity_gate=6.0)), readings, robot, prediction, 0.0)
    assert sum(len(shared[k]) for k in range(1, turn_at)) < 0.5 * sum(len(plain[k]) for k in range(1, turn_at))
    # The fixed tolerance flags cars that never changed while their filters settle (the footsteps that decide a crossing).
    assert np.mean([len(plain[k]) for k in range(1, 8)]) > 2
    false_alarms = sum(len(tested[k]) for k in range(1, turn_at))
    assert false_alarms <= 0.02 * 8 * (turn_at - 1), false_alarms
    assert "car_0" in tested[turn_at]  # the reversal, found at its first reading
    # Exact readings: the noise std is zero and the test is the fixed tolerance's.
    exact = _stream(5, (0.0, 0.0), turn_at)
    flagged = _flagged(Tracker(PARAMS), exact, robot, prediction, 3.0)
    assert flagged == _flagged(None, exact, robot, prediction, 0.0)
    assert flagged[turn_at] == {"car_0"}


def test_cars_of_a_lane_share_their_velocity_and_others_keep_theirs():
    """A lane of eight cars at one velocity beside pedestrians walking their own ways: handed on conditioned on
    their peers' mean velocity, the cars' velocity and position errors shrink well below their own filters' while
    the pedestrians', whose velocities agree with no one's, stay their filters' own."""
    robot = _robot()
    shared_params = dataclasses.replace(PARAMS, shared_velocity_gate=6.0)
    own_params = dataclasses.replace(PARAMS, shared_velocity_gate=0.0)
    err = {"shared": [], "own": []}
    for seed in range(3):
        rng = np.random.default_rng(100 + seed)
        cars, ped_v = _stream(seed, PROFILE[:2], turn_at=10 ** 6, steps=12), rng.uniform(-0.6, 0.6, (4, 2))
        truth_cars = _stream(seed, (0.0, 0.0), turn_at=10 ** 6, steps=12)
        trackers = {"shared": Tracker(shared_params), "own": Tracker(own_params)}
        for (t, views), (_, truth) in zip(cars, truth_cars):
            peds = [ObstacleView(f"member_{i}", "circle", False, tuple(ped_v[i] * t + (i - 2.0, 1.0)), 0.0,
                                 tuple(ped_v[i]), 0.0, 0.1, (0.0, 0.0), (0.0, 0.0)) for i in range(4)]
            noisy = [dataclasses.replace(p, position=tuple(np.add(p.position, PROFILE[0] * rng.standard_normal(2))),
                                         velocity=tuple(np.add(p.velocity, PROFILE[1] * rng.standard_normal(2))))
                     for p in peds]
            snapshot = _snapshot(robot, t, views + tuple(noisy))
            for kind, tracker in trackers.items():
                out = {v.name: v for v in tracker.update(snapshot).obstacles}
                err[kind].append([(math.dist(v.position, out[v.name].position),
                                   math.dist(v.velocity, out[v.name].velocity)) for v in truth + tuple(peds)])
    shared, own = np.array(err["shared"]), np.array(err["own"])  # (footsteps, 12 shapes, [position, velocity])
    late = slice(2, None)
    # The cars: their velocity error falls by more than half, their position error by a fifth at least.
    assert shared[late, :8, 1].mean() < 0.5 * own[late, :8, 1].mean()
    assert shared[late, :8, 0].mean() < 0.8 * own[late, :8, 0].mean()
    # The pedestrians (0.6 m/s apart at least as often as not): no worse than their own filters'.
    assert shared[late, 8:, 1].mean() < 1.1 * own[late, 8:, 1].mean()


def test_exact_readings_pass_unchanged():
    robot = _robot()
    truths, _ = _synthetic(2, 10)
    tracker = Tracker(PARAMS)
    for t, views in truths:
        snapshot = _snapshot(robot, t, views)
        assert tracker.update(snapshot) is snapshot
    assert all(v is None for v in tracker.levels().values())


def test_only_the_noisy_kind_of_channel_is_filtered():
    robot = _robot()
    truths, _ = _synthetic(3, 12)
    _, readings = _synthetic(3, 12, stds=(0.0, 0.0, 0.01, 0.01))  # a rod's angle noisy, every position exact
    tracker = Tracker(PARAMS)
    for (t, views), (_, truth) in zip(readings, truths):
        out = {v.name: v for v in tracker.update(_snapshot(robot, t, views)).obstacles}
        for v in truth:
            assert out[v.name].position == v.position and out[v.name].velocity == v.velocity
    assert tracker.levels()["linear"] is None and tracker.levels()["angular"] is not None
    assert out["door"].angle != next(v for v in views if v.name == "door").angle  # the angle is the filter's


# ---------------------------------------------------------------- the switch
def test_tracking_is_on_in_period_aware_and_off_in_the_paper_planners_and_the_oracle():
    assert load_planner_config(defaults=POLICIES["period-aware"].defaults()).additions.tracking
    for name in ("paper-period-aware", "paper-fixed-period", "oracle"):
        assert not load_planner_config(defaults=POLICIES[name].defaults()).additions.tracking, name
    assert not load_planner_config(defaults=policy_spec("period-aware-no-tracking").defaults()).additions.tracking
    assert make_policy("period-aware").tracker is not None
    assert make_policy("paper-period-aware").tracker is None


@pytest.mark.parametrize("bad", ["known", [0.02, 0.05, 0.01], [0.02, -0.05, 0.01, 0.01], [0.02, True, 0.01, 0.01]])
def test_a_bad_measurement_noise_is_refused_naming_the_key(bad):
    with pytest.raises(ConfigError, match="tracking.measurement_noise"):
        load_planner_config({"tracking": {"measurement_noise": bad}})


def _commands(name: str, env_id: str, seed: int, steps: int, **make) -> list[np.ndarray]:
    env = gym.make(env_id, **make)
    obs, _ = env.reset(seed=seed)
    policy = make_policy(name, env.unwrapped.robot, seed=seed)
    policy.reset(seed=seed)
    out = []
    for _ in range(steps):
        command = policy.act(obs, env.unwrapped.sensing())
        out.append(command)
        obs, _, terminated, truncated, _ = env.step(command)
        if terminated or truncated:
            break
    env.close()
    return out


def test_a_noise_free_episode_plans_the_same_commands_with_and_without_tracking():
    with_tracking = _commands("period-aware", "FootstepCrowd-v0", 10000, 8)
    without = _commands("period-aware-no-tracking", "FootstepCrowd-v0", 10000, 8)
    assert len(with_tracking) == len(without)
    for a, b in zip(with_tracking, without):
        np.testing.assert_array_equal(a, b)


def test_a_noisy_episode_replays_command_for_command():
    make = dict(tier="noise", tier_cell="train")
    first = _commands("period-aware", "FootstepDoor-v0", 10001, 6, **make)
    again = _commands("period-aware", "FootstepDoor-v0", 10001, 6, **make)
    untracked = _commands("period-aware-no-tracking", "FootstepDoor-v0", 10001, 6, **make)
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a, b)
    assert any(not np.array_equal(a, b) for a, b in zip(first, untracked))  # the tracker did change the plan


# ---------------------------------------------------------------- it never reads the truth
#: What the tracker's modules may not import (the env, its world and scenarios, the oracle) nor touch (the
#: oracle's door, the env's bodies, its generator, its sensed state's private copy).
FORBIDDEN_MODULES = ("footstep_gym.env", "footstep_gym.world", "footstep_gym.scenarios", "footstep_gym.planners.oracle",
                     "footstep_gym.tiers")
FORBIDDEN_ATTRIBUTES = {"world", "bind_truth", "true_snapshot", "scenario", "np_random", "_sensed", "episode_config",
                        "history", "_env"}
#: What the wrapper may ask of ``env.unwrapped``: what the robot senses, and the observation's settings.
ALLOWED_ON_UNWRAPPED = {"sensing", "config"}


def truth_reads(path: Path) -> list[str]:
    """Imports of the env's internals, uses of the truth's attributes, and anything asked of an unwrapped env
    other than :data:`ALLOWED_ON_UNWRAPPED`, in the file at ``path``, as ``file:line: what``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    unwrapped_names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            module = node.module or ""
            names = [f"{module}.{a.name}" for a in node.names]
            if any(m.startswith(FORBIDDEN_MODULES) for m in [module, *names]):
                found.append(f"{path.name}:{node.lineno}: from {module} import ...")
        elif isinstance(node, ast.Import):
            found += [f"{path.name}:{node.lineno}: import {a.name}" for a in node.names
                      if a.name.startswith(FORBIDDEN_MODULES)]
        elif isinstance(node, ast.Attribute) and node.attr in FORBIDDEN_ATTRIBUTES:
            found.append(f"{path.name}:{node.lineno}: .{node.attr}")
        elif (isinstance(node, ast.Assign) and isinstance(node.value, ast.Attribute)
              and node.value.attr == "unwrapped"):
            unwrapped_names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            value = node.value
            on_unwrapped = ((isinstance(value, ast.Attribute) and value.attr == "unwrapped")
                            or (isinstance(value, ast.Name) and value.id in unwrapped_names))
            if on_unwrapped and node.attr not in ALLOWED_ON_UNWRAPPED:
                found.append(f"{path.name}:{node.lineno}: unwrapped.{node.attr}")
    return found


def test_the_tracker_and_its_wrapper_never_read_the_truth():
    files = [REPO / "footstep_gym" / "planners" / "tracking.py", REPO / "footstep_gym" / "wrappers.py"]
    found = [hit for path in files for hit in truth_reads(path)]
    assert not found, "the tracker reads more than what is sensed:\n" + "\n".join(found)


def test_the_truth_scan_finds_what_it_looks_for(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text("from footstep_gym.planners.oracle import true_snapshot\nimport footstep_gym.world\n"
                      "def f(env, policy):\n    base = env.unwrapped\n    base.sensing()\n    base.world.views()\n"
                      "    env.unwrapped.np_random\n    policy.bind_truth(env)\n")
    found = truth_reads(sample)
    assert sorted(found) == sorted(["sample.py:1: from footstep_gym.planners.oracle import ...",
                                    "sample.py:2: import footstep_gym.world",
                     "sample.py:6: .world", "sample.py:7: .np_random", "sample.py:8: .bind_truth",
                     "sample.py:6: unwrapped.world", "sample.py:7: unwrapped.np_random"])


# ---------------------------------------------------------------- the agents' wrapper
def test_the_slots_are_the_envs_own_on_the_sensed_views():
    env = gym.make("FootstepCrowd-v0", tier="noise", tier_cell="train")
    obs, _ = env.reset(seed=5)
    for _ in range(3):
        cfg, snapshot = env.unwrapped.config, env.unwrapped.sensing()
        slots = obstacle_slots(snapshot, cfg.n_obstacles_observed, cfg.sensing_range, ObservationScales.of(cfg))
        np.testing.assert_array_equal(slots, obs[HEAD:])
        obs, *_ = env.step(env.unwrapped.robot.nominal_command)
    env.close()


def test_the_wrapper_gives_the_planners_estimates_and_the_envs_observation_where_readings_are_exact():
    for tier, cell, noisy in (("structure", "two_doors", False), ("noise", "train", True)):
        wrapped = TrackedObservation(gym.make("FootstepDoor-v0", tier=tier, tier_cell=cell))
        raw = gym.make("FootstepDoor-v0", tier=tier, tier_cell=cell)
        assert wrapped.observation_space == raw.observation_space
        tracker = Tracker(PARAMS)
        obs, _ = wrapped.reset(seed=3)
        expected, _ = raw.reset(seed=3)
        differs = []
        for step in range(6):
            cfg = raw.unwrapped.config
            estimate = tracker.update(raw.unwrapped.sensing())
            slots = obstacle_slots(estimate, cfg.n_obstacles_observed, cfg.sensing_range, ObservationScales.of(cfg))
            np.testing.assert_array_equal(obs[:HEAD], expected[:HEAD])
            np.testing.assert_array_equal(obs[HEAD:], slots)
            differs.append(not np.array_equal(obs, expected))
            command = raw.unwrapped.robot.nominal_command
            obs, *_ = wrapped.step(command)
            expected, *_ = raw.step(command)
        assert any(differs) == noisy
        obs, _ = wrapped.reset(seed=3)  # the tracker forgets: the first observation again
        first, _ = raw.reset(seed=3)
        np.testing.assert_array_equal(obs, first)


def _noise_free_cells():
    from footstep_gym.evaluation.benchmark import benchmark_cells

    return [c for c in benchmark_cells()
            if not any(k.startswith("sensing_noise") and v for k, v in c.env_kwargs.items())]


def test_every_noise_free_benchmark_cell_passes_its_readings_unchanged():
    """No loss where there is no noise: the tracker hands every reading on as it is, so period-aware plans what it
    plans without tracking, command for command (the episode test above)."""
    cells = _noise_free_cells()
    assert len(cells) >= 15 and {c.scene for c in cells} == {"door", "crossing", "crowd"}
    rng = np.random.default_rng(0)
    for cell in cells:
        env = gym.make(cell.env_id, **dict(cell.selector))
        env.reset(seed=10000)
        tracker = Tracker(PARAMS)
        robot = env.unwrapped.robot
        for _ in range(12):
            snapshot = env.unwrapped.sensing()
            assert tracker.update(snapshot) is snapshot, cell.label
            command = rng.uniform(robot.command_low, robot.command_high)
            command[0] = abs(command[0])
            _, _, terminated, truncated, _ = env.step(command)
            if terminated or truncated:
                env.reset(seed=10001)
                tracker.reset()
        env.close()
