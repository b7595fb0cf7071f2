"""What a robot senses: noise on the moving obstacles, a sensing range, a field of view.

The options are keys of ``configs/env.yaml`` (``sensing_noise_position``, ``sensing_noise_velocity``,
``sensing_noise_angle``, ``sensing_noise_angular_velocity``, ``sensing_max_range``, ``sensing_fov``), all off by
default. Checked here: off, the env is today's (observation and snapshot read off the world; the golden replay
is ``tests/test_replay_golden.py``); :func:`footstep_gym.sensing.nearest_views` answers what ``World.nearest``
does; the observation's slots and ``sensing()`` carry the same noisy state; the noise has the configured
statistics (the truth read from ``env.unwrapped.world``, here only); range and field of view leave out exactly
the obstacles outside them; seeded episodes with noise replay exactly; bad values raise ``ConfigError`` naming
the key.
"""

from __future__ import annotations

import cmath
import math

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401
from env_helpers import ENV_IDS, NOMINAL, read_yaml
from footstep_gym.errors import ConfigError
from footstep_gym.sensing import ObstacleView, nearest_views, sense

NOISE = dict(sensing_noise_position=0.05, sensing_noise_velocity=0.1, sensing_noise_angle=0.03,
             sensing_noise_angular_velocity=0.04)
ALL_ON = dict(NOISE, sensing_max_range=1.5, sensing_fov=150.0)
KEYS = ("sensing_noise_position", "sensing_noise_velocity", "sensing_noise_angle", "sensing_noise_angular_velocity",
        "sensing_max_range", "sensing_fov")


def steps_of(env, seed, steps, actions_seed=0):
    """Yields ``(obs, reward, terminated, truncated, info, snapshot)`` after the reset and after each step of one
    seeded episode of random commands (the env is at that step while the caller looks)."""
    rng = np.random.default_rng(actions_seed)
    obs, info = env.reset(seed=seed)
    yield obs, 0.0, False, False, info, env.unwrapped.sensing()
    for _ in range(steps):
        low, high = env.action_space.low, env.action_space.high
        action = (0.5 * (low + rng.random(5) * (high - low)) + 0.5 * NOMINAL).astype(np.float32)  # longer episodes
        obs, reward, terminated, truncated, info = env.step(action)
        yield obs, reward, terminated, truncated, info, env.unwrapped.sensing()
        if terminated or truncated:
            break


def episode(env, seed, steps, actions_seed=0):
    """:func:`steps_of` as a list."""
    return list(steps_of(env, seed, steps, actions_seed))


def slots_from_snapshot(snap, cfg):
    """The observation's obstacle slots recomputed from a snapshot's views (float64)."""
    x, y, yaw = snap.support_foot
    rot = cmath.exp(-1j * yaw)
    com = complex(*snap.com)
    ps, vs = cfg.observation_position_scale, cfg.observation_velocity_scale
    out = []
    near = nearest_views(snap.obstacles, snap.com, cfg.n_obstacles_observed, cfg.sensing_range)
    for _, cp, v, _ in near:
        rel = (complex(*cp) - com) * rot / ps
        vel = complex(*v) * rot / vs
        out += [rel.real, rel.imag, vel.real, vel.imag, 1.0]
    out += [0.0] * (5 * (cfg.n_obstacles_observed - len(near)))
    return np.array(out)


# ------------------------------------------------------------------ the keys and their checks
def test_the_keys_are_in_env_yaml_and_off_by_default():
    data = read_yaml("env.yaml")
    assert {k: data[k] for k in KEYS} == {"sensing_noise_position": 0.0, "sensing_noise_velocity": 0.0,
                                          "sensing_noise_angle": 0.0, "sensing_noise_angular_velocity": 0.0,
                                          "sensing_max_range": math.inf, "sensing_fov": 360.0}
    cfg = gym.make("FootstepDoor-v0").unwrapped.config
    assert not cfg.sensing_noise and not cfg.sensing_limited
    assert gym.make("FootstepDoor-v0", sensing_max_range=2).unwrapped.config.sensing_max_range == 2.0


@pytest.mark.parametrize("key, value", [
    ("sensing_noise_position", -0.01), ("sensing_noise_velocity", -1.0), ("sensing_noise_angle", -1e-9),
    ("sensing_noise_angular_velocity", -0.5), ("sensing_noise_position", math.nan), ("sensing_noise_velocity", "0.1"),
    ("sensing_fov", 0.0), ("sensing_fov", -30.0), ("sensing_fov", 360.5), ("sensing_fov", math.inf),
    ("sensing_fov", math.nan), ("sensing_max_range", 0.0), ("sensing_max_range", -1.0),
    ("sensing_max_range", math.nan), ("sensing_max_range", -math.inf), ("sensing_max_range", "far"),
    ("sensing_max_range", True),
])
def test_bad_values_raise_naming_the_key(key, value):
    with pytest.raises(ConfigError, match=key):
        gym.make("FootstepDoor-v0", **{key: value})


@pytest.mark.parametrize("key, value", [("sensing_fov", 360.0), ("sensing_fov", 1e-3), ("sensing_max_range", math.inf),
                                        ("sensing_max_range", 1e-6), ("sensing_noise_position", 0.0)])
def test_edge_values_are_accepted(key, value):
    gym.make("FootstepDoor-v0", **{key: value}).reset(seed=0)


# ------------------------------------------------------------------ nearest_views == World.nearest
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_nearest_views_answer_what_world_nearest_does(env_id):
    """With views read off the world (noise off) the pure function gives World.nearest's answers (same
    shapes, same order, the same closest points and velocities, omega x r included, within a few ulps)."""
    env = gym.make(env_id, door_speed=30.0) if "Door" in env_id else gym.make(env_id)
    rng = np.random.default_rng(1)
    compared = 0
    for seed in range(3):
        for obs, *_, snap in steps_of(env, seed, 12):
            world = env.unwrapped.world
            views = world.views()
            cx, cy = snap.com
            points = [(cx, cy)] + [(cx + dx, cy + dy) for dx, dy in rng.uniform(-1.5, 1.5, (8, 2))]
            for p in points:
                for k, reach in ((6, 3.0), (50, math.inf), (2, 0.5)):
                    want = world.nearest(p, k, reach)
                    got = nearest_views(views, p, k, reach)
                    assert [o.name for *_, o in want] == [v.name for *_, v in got]
                    for (g0, cp0, v0, _), (g1, cp1, v1, _) in zip(want, got):
                        a, b = np.array([g0, *cp0, *v0]), np.array([g1, *cp1, *v1])
                        ulps = 4 * np.spacing(np.maximum(np.abs(a), 1.0))
                        assert np.all(np.abs(a - b) <= ulps), (a, b)
                        compared += 1
    assert compared > 100


def test_nearest_views_give_a_turning_rods_point_velocity_with_omega_cross_r():
    rod = ObstacleView(name="rod", kind="segment", static=False, position=(1.0, 0.0), angle=math.pi / 2,
                       velocity=(0.1, 0.0), angular_velocity=-0.5, radius=0.01, a=(-0.5, 0.0), b=(0.5, 0.0))
    ((gap, cp, v, _),) = nearest_views([rod], (0.0, 0.3), 1, math.inf)
    assert gap == pytest.approx(0.99)
    assert cp == pytest.approx((0.99, 0.3))
    # omega x r with r = cp - position = (-0.01, 0.3): (-w ry, w rx)
    assert v == pytest.approx((0.1 + 0.5 * 0.3, 0.5 * 0.01))


# ------------------------------------------------------------------ off = today's env
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_off_the_observation_and_snapshot_are_read_off_the_world(env_id):
    env = gym.make(env_id)
    cfg = env.unwrapped.config
    for obs, *_, info, snap in steps_of(env, 3, 15):
        assert "sensed_obstacles" not in info
        assert snap.obstacles == env.unwrapped.world.views()
        assert obs[12:] == pytest.approx(slots_from_snapshot(snap, cfg).astype(np.float32), abs=0)


@pytest.mark.parametrize("env_id", ENV_IDS + ["FootstepMix-v0"])
def test_a_range_beyond_everything_gives_todays_episodes_bit_for_bit(env_id):
    """The sensed path (nearest_views from the sensed views; no noise, so no draws) with a range that leaves
    nothing out: every observation, reward, info value and snapshot as the default env's."""
    kw = {"sensing_max_range": 1e6, "sensing_fov": 360.0}
    on = gym.make(env_id, **({s: kw for s in ("door", "crossing", "crowd")} if "Mix" in env_id else kw))
    off = gym.make(env_id)
    for seed in (0, 5):
        a, b = episode(on, seed, 40), episode(off, seed, 40)
        assert len(a) == len(b)
        for (o1, r1, t1, tr1, i1, s1), (o2, r2, t2, tr2, i2, s2) in zip(a, b):
            assert o1.tobytes() == o2.tobytes()
            assert (r1, t1, tr1) == (r2, t2, tr2)
            moving = sum(1 for v in s2.obstacles if not v.static)
            assert i1.pop("sensed_obstacles") == moving
            assert repr(i1) == repr(i2)
            assert s1 == s2


# ------------------------------------------------------------------ the same noise in observation and snapshot
@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("options", [NOISE, ALL_ON], ids=["noise", "noise+range+fov"])
def test_the_observation_and_the_snapshot_carry_the_same_sensed_state(env_id, options):
    env = gym.make(env_id, **options, **(dict(crossing_x=0.6) if "Crossing" in env_id else {}))
    cfg = env.unwrapped.config
    differs = 0
    for seed in range(3):
        for obs, *_, info, snap in steps_of(env, seed, 40):
            assert obs[12:] == pytest.approx(slots_from_snapshot(snap, cfg), abs=2e-6, rel=1e-6)
            assert env.observation_space.contains(obs)
            assert env.unwrapped.sensing() == snap  # one draw per step: asking again senses the same
            assert info["sensed_obstacles"] == sum(1 for v in snap.obstacles if not v.static)
            truth = {v.name: v for v in env.unwrapped.world.views()}
            for v in snap.obstacles:
                if v.static:
                    assert v == truth[v.name]  # walls: exact
                else:
                    differs += v.position != truth[v.name].position
    assert differs > 5


# ------------------------------------------------------------------ the noise's statistics
def test_the_noise_has_the_configured_statistics():
    """Over many steps the sensed - true error of each moving body has mean 0 and the configured std per axis;
    a rod's angle and angular velocity get theirs, a circle's none."""
    cases = (("FootstepCrowd-v0", {}), ("FootstepDoor-v0", {}), ("FootstepCrossing-v0", dict(crossing_x=0.6)))
    err = {"circle": [], "segment": []}
    for env_id, kw in cases:
        env = gym.make(env_id, **NOISE, **kw)
        seed, n = 0, 0
        while n < 600:
            rng = np.random.default_rng(seed)
            obs, info = env.reset(seed=seed)
            seed += 1
            while True:
                snap = env.unwrapped.sensing()
                truth = {o.name: o.body for o in env.unwrapped.world.obstacles if not o.static}
                for v in snap.obstacles:
                    if v.static:
                        continue
                    body = truth.pop(v.name)
                    err[v.kind].append((v.position[0] - body.position.x, v.position[1] - body.position.y,
                                        v.velocity[0] - body.velocity.x, v.velocity[1] - body.velocity.y,
                                        v.angle - body.angle, v.angular_velocity - body.angular_velocity))
                assert not truth  # no range or field of view: every moving obstacle is sensed
                n += 1
                box = env.action_space
                action = (0.6 * NOMINAL + 0.4 * rng.uniform(box.low, box.high)).astype(np.float32)
                *_, terminated, truncated, _ = env.step(action)
                if terminated or truncated:
                    break
    sigma = np.array([NOISE["sensing_noise_position"]] * 2 + [NOISE["sensing_noise_velocity"]] * 2
                     + [NOISE["sensing_noise_angle"], NOISE["sensing_noise_angular_velocity"]])
    circles, rods = np.array(err["circle"]), np.array(err["segment"])
    assert len(circles) > 3000 and len(rods) > 1000
    np.testing.assert_array_equal(circles[:, 4:], 0.0)  # a circle's angle and angular velocity: not noised
    for e, cols in ((circles, slice(0, 4)), (rods, slice(0, 6))):
        n = len(e)
        std = e[:, cols].std(axis=0, ddof=1)
        mean = e[:, cols].mean(axis=0)
        s = sigma[cols]
        assert np.all(np.abs(std / s - 1.0) < 4.5 / math.sqrt(2 * n)), (std, s, n)  # the std of a std: s / sqrt(2n)
        assert np.all(np.abs(mean) < 4.5 * s / math.sqrt(n)), (mean, s, n)
    # the axes are independent
    c = np.corrcoef(rods.T)
    assert np.all(np.abs(c - np.eye(6)) < 4.5 / math.sqrt(len(rods)))


# ------------------------------------------------------------------ range and field of view
def circle(name, x, y, r=0.1, static=False):
    return ObstacleView(name=name, kind="circle", static=static, position=(x, y), angle=0.0, velocity=(0.2, 0.0),
                        angular_velocity=0.0, radius=r, a=(0.0, 0.0), b=(0.0, 0.0))


def wall(name, a, b):
    return ObstacleView(name=name, kind="segment", static=True, position=(0.0, 0.0), angle=0.0, velocity=(0.0, 0.0),
                        angular_velocity=0.0, radius=0.01, a=a, b=b)


def test_range_and_field_of_view_leave_out_exactly_the_obstacles_outside():
    """Robot at (1, 1) facing +y (heading pi/2), range 1.5 m to the closest point, field of view 90 deg."""
    d45 = math.radians(45.0)
    views = (
        wall("far wall behind", (-9.0, -9.0), (9.0, -9.0)),  # walls: always sensed
        circle("ahead", 1.0, 2.0),  # gap 0.9, bearing 0
        circle("range edge inside", 1.0, 2.0 + 0.6 - 1e-9),  # gap 1.5 - 1e-9
        circle("range edge outside", 1.0, 2.0 + 0.6 + 1e-9),  # gap 1.5 + 1e-9
        circle("left edge inside", 1.0 - math.sin(d45 - 1e-6), 1.0 + math.cos(d45 - 1e-6)),  # bearing 45 - eps deg
        circle("left edge outside", 1.0 - math.sin(d45 + 1e-6), 1.0 + math.cos(d45 + 1e-6)),
        circle("right edge inside", 1.0 + math.sin(d45 - 1e-6), 1.0 + math.cos(d45 - 1e-6)),
        circle("right edge outside", 1.0 + math.sin(d45 + 1e-6), 1.0 + math.cos(d45 + 1e-6)),
        circle("behind", 1.0, 0.5),
        circle("beside", 1.8, 1.0),
        circle("around the robot", 1.05, 0.95, r=0.2),  # the CoM inside it: always sensed
        # a rod across the view whose closest point (1, 1.5) is ahead though its ends are outside the view
        ObstacleView(name="rod ahead", kind="segment", static=False, position=(1.0, 1.5), angle=0.0,
                     velocity=(0.0, 0.0), angular_velocity=0.3, radius=0.01, a=(-3.0, 0.0), b=(3.0, 0.0)),
        # a rod beside whose far end is in view but whose closest point is not
        ObstacleView(name="rod beside", kind="segment", static=False, position=(2.0, 1.0), angle=math.pi / 2,
                     velocity=(0.0, 0.0), angular_velocity=0.0, radius=0.01, a=(0.0, 0.0), b=(2.0, 0.0)),
    )
    sensed = sense(views, (1.0, 1.0), math.pi / 2, 1.5, 90.0)
    assert [v.name for v in sensed] == ["far wall behind", "ahead", "range edge inside", "left edge inside",
                                        "right edge inside", "around the robot", "rod ahead"]
    assert all(v is w for v in sensed for w in views if w.name == v.name)  # no noise: the views themselves
    assert [v.name for v in sense(views, (1.0, 1.0), math.pi / 2, math.inf, 360.0)] == [v.name for v in views]
    everything_in_range = [v.name for v in views if v.name not in ("range edge outside",)]
    assert [v.name for v in sense(views, (1.0, 1.0), math.pi / 2, 1.5, 360.0)] == everything_in_range
    # heading -pi/2 (facing -y): only what is behind now, and the CoM's own shape
    assert [v.name for v in sense(views, (1.0, 1.0), -math.pi / 2, 1.5, 90.0)] == ["far wall behind", "behind",
                                                                                   "around the robot"]


def test_the_door_out_of_range_is_not_sensed_and_walls_still_are():
    env = gym.make("FootstepDoor-v0", sensing_max_range=0.05)
    obs, info = env.reset(seed=0)
    snap = env.unwrapped.sensing()
    walls = [v for v in env.unwrapped.world.views() if v.static]
    assert info["sensed_obstacles"] == 0
    assert snap.obstacles == tuple(walls)
    cfg = env.unwrapped.config
    assert obs[12:] == pytest.approx(slots_from_snapshot(snap, cfg), abs=2e-6)
    # facing away from the door with a narrow view: not sensed either, at any range
    env = gym.make("FootstepDoor-v0", sensing_fov=10.0, start_yaw=math.pi)
    _, info = env.reset(seed=0)
    assert info["sensed_obstacles"] == 0


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_range_and_fov_in_the_env_sense_what_the_truth_says_without_noise(env_id):
    """Without noise an obstacle is sensed iff its true closest point to the CoM is within range and view
    (World.nearest's closest points; the support foot's yaw as heading)."""
    env = gym.make(env_id, sensing_max_range=1.2, sensing_fov=100.0)
    counts = set()
    for seed in range(4):
        for *_, info, snap in steps_of(env, seed, 30, actions_seed=seed):
            world = env.unwrapped.world
            want = []
            for gap, cp, _, o in world.nearest(snap.com, 10**6, math.inf):
                if o.static:
                    continue
                dx, dy = cp[0] - snap.com[0], cp[1] - snap.com[1]
                bearing = math.atan2(dy, dx) - snap.support_foot[2]
                bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
                if gap <= 0 or (gap <= 1.2 and abs(math.degrees(bearing)) <= 50.0):
                    want.append(o.name)
            got = [v.name for v in snap.obstacles if not v.static]
            assert sorted(got) == sorted(want)
            assert info["sensed_obstacles"] == len(want)
            counts.add(len(want))
    assert len(counts) > 1  # some in, some out


# ------------------------------------------------------------------ replays
@pytest.mark.parametrize("env_id", ENV_IDS + ["FootstepMix-v0"])
def test_seeded_episodes_with_noise_replay_exactly(env_id):
    kw = {s: ALL_ON for s in ("door", "crossing", "crowd")} if "Mix" in env_id else ALL_ON
    env, again = gym.make(env_id, **kw), gym.make(env_id, **kw)
    a = episode(env, 11, 30)
    episode(env, 12, 5)  # the env's stream moves on, a reset with the seed starts it over
    for run in (episode(env, 11, 30), episode(again, 11, 30)):
        assert len(run) == len(a)
        for (o1, r1, t1, tr1, i1, s1), (o2, r2, t2, tr2, i2, s2) in zip(a, run):
            assert o1.tobytes() == o2.tobytes()
            assert (r1, t1, tr1, repr(i1)) == (r2, t2, tr2, repr(i2))
            assert s1 == s2
    other = episode(env, 13, 30)
    assert [o.tobytes() for o, *_ in other] != [o.tobytes() for o, *_ in a]


def test_noise_draws_only_when_on_and_leaves_the_world_as_it_was():
    """Without noise (a field of view only) the env's generator is where the default env's is; with noise the
    world's own draws (all at reset, before the noise's) are the same, so under the same commands the true
    world moves as in the noise-free episode."""
    plain_env, ranged = gym.make("FootstepCrowd-v0"), gym.make("FootstepCrowd-v0", sensing_fov=90.0)
    for env in (plain_env, ranged):
        env.reset(seed=4)
        env.step(NOMINAL)
    assert plain_env.unwrapped.np_random.random() == ranged.unwrapped.np_random.random()
    noisy = gym.make("FootstepCrowd-v0", **NOISE)
    for env in (plain_env, noisy):
        env.reset(seed=4)
    for _ in range(3):
        ended = [env.step(NOMINAL)[2] for env in (plain_env, noisy)]
        assert ended[0] == ended[1]
        truth = [(v.name, v.position, v.velocity) for v in plain_env.unwrapped.world.views()]
        assert [(v.name, v.position, v.velocity) for v in noisy.unwrapped.world.views()] == truth


# ------------------------------------------------------------------ the planners
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_the_period_aware_planner_runs_with_noisy_and_missing_obstacles(env_id):
    from footstep_gym import make_policy

    env = gym.make(env_id, **ALL_ON)
    policy = make_policy("period-aware", env.unwrapped.robot, seed=0)
    for seed in range(2):
        obs, _ = env.reset(seed=seed)
        policy.reset(seed)
        for _ in range(25):
            obs, _, terminated, truncated, info = env.step(policy.act(obs, env.unwrapped.sensing()))
            assert np.all(np.isfinite(obs)) and info["feasible"] in (True, False)
            if terminated or truncated:
                break
