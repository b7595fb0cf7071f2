"""The pymunk world (footstep_gym/world.py) and its collision sweep, against analytic geometry.

References are worked out by hand in each test: the time at which a circle moving at a
known speed first touches another shape and the angle at which a rotating rod reaches a
point. (The instant a revolving-door wing meets a robot stepping in place, through the env,
and the door's half drum are tested in test_scenario_door.py.)

The tests named "bit for bit" compare the compiled sweep (:mod:`footstep_gym.kernels.sweep`, numba without
fast-math: no fused multiply-adds) with pymunk's (Chipmunk's C) and CPython's arithmetic exactly, on any CPU:
both do the same IEEE operations and call the same libm in one process (``sin``, ``cos``, ``exp``, ``sqrt``);
numpy's SIMD kernels, chosen per CPU at run time, do not enter. (Checked with numpy's AVX2/AVX-512 kernels
disabled, ``NPY_DISABLE_CPU_FEATURES``, and with glibc's code path for CPUs without FMA,
``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA``.)
"""

from __future__ import annotations

import math
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
import yaml

import footstep_gym  # noqa: F401  (registers the envs)
from env_helpers import ENV_IDS
from footstep_gym.config import config_dir
from footstep_gym.world import World

R = 0.10  # [m] robot radius used by the direct World tests
MAX_CHECK = 0.02  # [s]
FRACTION = 0.25
NOMINAL = np.array([0.0, 0.08, 0.0, 0.6, 0.2])


def make_world(radius: float = R, max_checks: int = 10**9) -> World:
    return World(radius, collision_slop=0.001, max_check_interval=MAX_CHECK, motion_fraction=FRACTION,
                 max_checks=max_checks)


def standing(x: float = 0.0, y: float = 0.0):
    return lambda t: (x, y)


def assert_detected(result, t_true: float, closing_speed: float, radius: float = R) -> None:
    """Contact reported no earlier than it happens, no later than one check, shallowly."""
    assert result.collided
    assert result.time >= t_true - 1e-9, (result.time, t_true)
    assert result.time <= t_true + MAX_CHECK + 1e-9, (result.time, t_true)
    # No obstacle moves more than FRACTION x radius between two checks: the overlap
    # found at detection is at most that deep.
    assert closing_speed * (result.time - t_true) <= FRACTION * radius + 1e-9


# ------------------------------------------------------------------ direct sweeps
def test_world_uses_metric_collision_slop():
    world = make_world()
    assert world.space.collision_slop == pytest.approx(0.001)


@pytest.mark.parametrize("speed", [0.05, 0.5, 3.0, 10.0])
def test_circle_approaching_standing_robot_hits_at_gap_over_speed(speed):
    world = make_world()
    start_x, radius = 1.0, 0.05
    world.add_circle("ball", (start_x, 0.0), radius, velocity=(-speed, 0.0))
    gap = start_x - radius - R
    t_true = gap / speed
    result = world.sweep(standing(), duration=t_true + 1.0, robot_speed_bound=0.0)
    assert_detected(result, t_true, speed)
    assert result.obstacle == "ball"
    # The world is left at the time of contact, the robot at its place on the path.
    assert world.time == pytest.approx(result.time, abs=1e-12)
    ball = world.obstacles[0].body
    assert ball.position.x == pytest.approx(start_x - speed * result.time, abs=1e-9)
    assert tuple(world.robot_body.position) == pytest.approx((0.0, 0.0))


@pytest.mark.parametrize("speed", [0.1, 0.4])
def test_robot_walking_into_static_wall(speed):
    world = make_world()
    thickness = 0.02
    world.add_wall("wall", (1.0, -1.0), (1.0, 1.0), thickness)
    t_true = (1.0 - 0.5 * thickness - R) / speed
    result = world.sweep(lambda t: (speed * t, 0.0), duration=t_true + 0.5, robot_speed_bound=speed)
    assert_detected(result, t_true, speed)
    assert result.obstacle == "wall"
    assert tuple(world.robot_body.position) == pytest.approx((speed * result.time, 0.0), abs=1e-12)


def test_fast_thin_obstacle_does_not_tunnel_through():
    """A 2 cm ball at 10 m/s crosses the whole robot in 24 ms: a check at the ends would miss it."""
    world = make_world()
    speed, radius = 10.0, 0.01
    world.add_circle("bullet", (-1.0, 0.0), radius, velocity=(speed, 0.0))
    duration = 0.3  # at the end the bullet is 2 m past the robot
    t_true = (1.0 - radius - R) / speed
    result = world.sweep(standing(), duration, robot_speed_bound=0.0)
    assert_detected(result, t_true, speed)


@pytest.mark.parametrize("omega_deg", [8.0, 17.0, 90.0])
def test_rotating_rod_reaches_standing_robot_at_predicted_angle(omega_deg):
    """A rod turning clockwise about the origin towards a robot at (d, 0).

    The rod's half-line at angle a is at distance d sin(a) from the robot's centre, so the
    surfaces touch when d sin(a) = R + h.
    """
    world = make_world()
    d, half_length, h = 0.35, 0.5, 0.01
    a0 = math.radians(50.0)
    omega = math.radians(omega_deg)
    world.add_rod("door", (0.0, 0.0), (-half_length, 0.0), (half_length, 0.0), 2 * h, angle=a0,
                  angular_velocity=-omega)
    t_true = (a0 - math.asin((R + h) / d)) / omega
    result = world.sweep(standing(d, 0.0), duration=t_true + 2.0, robot_speed_bound=0.0)
    assert_detected(result, t_true, omega * (half_length + h))
    assert world.obstacles[0].body.angle == pytest.approx(a0 - omega * result.time, abs=1e-9)


@pytest.mark.parametrize("miss", [0.002, -0.002])
def test_near_miss_is_clear_and_graze_is_a_hit(miss):
    """A ball passing the robot with its surface `miss` metres from the robot's circle."""
    world = make_world()
    radius, speed = 0.05, 0.5
    lateral = R + radius + miss
    world.add_circle("ball", (-1.0, lateral), radius, velocity=(speed, 0.0))
    result = world.sweep(standing(), duration=4.0, robot_speed_bound=0.0)
    if miss > 0:
        assert not result.collided and result.time == 4.0 and result.obstacle is None
    else:
        # First contact where the centre distance equals R + radius.
        t_true = (1.0 - math.sqrt((R + radius) ** 2 - lateral ** 2)) / speed
        assert_detected(result, t_true, speed)


def test_obstacle_moving_away_never_collides_and_world_advances_by_duration():
    world = make_world()
    world.add_circle("ball", (0.3, 0.0), 0.05, velocity=(0.7, 0.0))
    world.add_wall("wall", (-5.0, 1.0), (5.0, 1.0), 0.02)
    duration = 2.5
    result = world.sweep(lambda t: (-0.05 * t, 0.0), duration, robot_speed_bound=0.05)
    assert not result.collided
    assert result.time == duration and result.obstacle is None
    assert world.time == pytest.approx(duration, abs=1e-12)
    assert world.obstacles[0].body.position.x == pytest.approx(0.3 + 0.7 * duration, abs=1e-9)
    assert tuple(world.robot_body.position) == pytest.approx((-0.05 * duration, 0.0))
    # A second sweep continues from there.
    world.sweep(standing(), 0.5, 0.0)
    assert world.time == pytest.approx(duration + 0.5, abs=1e-12)
    assert world.obstacles[0].body.position.x == pytest.approx(0.3 + 0.7 * (duration + 0.5), abs=1e-9)


def test_far_obstacles_need_few_checks():
    """Conservative advancement: with 10 m of clearance a 1 s sweep needs no fine checks."""
    world = make_world()
    world.add_circle("far", (10.0, 0.0), 0.05, velocity=(-0.3, 0.0))
    result = world.sweep(lambda t: (0.1 * t, 0.0), 1.0, robot_speed_bound=0.1)
    assert not result.collided
    assert result.checks <= 3


def test_empty_world_sweep():
    world = make_world()
    result = world.sweep(lambda t: (t, 0.0), 1.0, robot_speed_bound=1.0)
    assert not result.collided and result.time == 1.0


def test_clearance_and_nearest_match_geometry():
    world = make_world()
    world.add_circle("ball", (1.0, 0.0), 0.1, velocity=(0.0, 0.2))
    world.add_wall("wall", (-3.0, -0.5), (3.0, -0.5), 0.02)  # surface at y = -0.49
    omega = 0.5
    world.add_rod("rod", (0.0, 2.0), (-0.5, 0.0), (0.5, 0.0), 0.02, angular_velocity=omega)
    dist, hit = world.clearance((0.0, 0.0), horizon=5.0)
    assert hit.name == "wall" and dist == pytest.approx(0.49, abs=1e-9)
    dist, hit = world.clearance((0.0, 0.0), horizon=0.3)  # nothing within the horizon
    assert hit is None

    near = world.nearest((0.0, 0.0), k=5, max_distance=3.0)
    names = [o.name for _, _, _, o in near]
    assert names == ["wall", "ball", "rod"]  # 0.49, 0.9, 1.99
    dists = [d for d, _, _, _ in near]
    assert dists == pytest.approx([0.49, 0.9, 1.99], abs=1e-9)
    # Closest points and the velocities of those points.
    _, p_ball, v_ball, _ = near[1]
    assert p_ball == pytest.approx((0.9, 0.0), abs=1e-9)
    assert v_ball == pytest.approx((0.0, 0.2), abs=1e-12)
    _, p_rod, v_rod, _ = near[2]
    assert p_rod == pytest.approx((0.0, 1.99), abs=1e-9)
    # A point (0, -0.01) from the rod's centre turning at omega moves at omega x r = (0.01 omega, 0).
    assert v_rod == pytest.approx((0.01 * omega, 0.0), abs=1e-9)
    assert near[0][2] == (0.0, 0.0)  # static wall
    assert len(world.nearest((0.0, 0.0), k=2, max_distance=3.0)) == 2
    assert len(world.nearest((0.0, 0.0), k=5, max_distance=1.0)) == 2


def test_max_obstacle_speed_counts_rotation():
    world = make_world()
    world.add_circle("ball", (1.0, 0.0), 0.1, velocity=(0.3, 0.4))
    world.add_rod("rod", (0.0, 2.0), (-0.5, 0.0), (0.5, 0.0), 0.02, angular_velocity=-2.0)
    # Fastest point: the rod's tip surface, 0.51 m from its centre at 2 rad/s.
    assert world.max_obstacle_speed() == pytest.approx(max(0.5, 2.0 * 0.51))


# ------------------------------------------------------------------ the cap on checks per footstep
def test_sweep_checks_are_capped_whatever_the_speed():
    """A ball at 1e6 m/s would need 0.025 m / 1e6 m/s = 25 ns between checks: 4e7 for a 1 s step."""
    cap = 200
    world = make_world(max_checks=cap)
    world.add_circle("ball", (5.0, 3.0), 0.05, velocity=(1e6, 0.0))  # far away, moving further
    world.add_wall("wall", (-5.0, 0.5), (5.0, 0.5), 0.02)  # 0.39 m of clearance: contact "possible"
    with pytest.warns(RuntimeWarning, match=r"max_sweep_checks=200.*spaced 0.005 s apart"):
        result = world.sweep(standing(), duration=1.0, robot_speed_bound=0.0)
    assert result.capped and not result.collided and result.time == 1.0
    assert cap // 2 < result.checks <= cap + 1
    assert world.time == pytest.approx(1.0, abs=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # warned once per world
        again = world.sweep(standing(), duration=0.5, robot_speed_bound=0.0)
    assert again.capped and again.checks <= cap + 1


def test_sweep_below_the_cap_is_exactly_the_uncapped_sweep():
    """The cap changes nothing while the rule's spacing needs fewer checks than it allows."""
    results = []
    for cap in (10**9, 101):
        world = make_world(max_checks=cap)
        world.add_circle("ball", (2.0, 0.0), 0.05, velocity=(-2.0, 0.0))
        # speed 2 m/s: checks 0.025 / 2 = 12.5 ms apart near contact: <= 80 in a 1 s step
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            results.append((world.sweep(standing(), duration=1.0, robot_speed_bound=0.0), world.time))
    assert results[0] == results[1] and not results[0][0].capped
    assert results[0][0].collided and results[0][0].checks <= 101


def test_non_finite_speed_is_an_error_not_a_hang():
    world = make_world()
    with pytest.raises(ValueError, match="not finite"):
        world.sweep(standing(), duration=1.0, robot_speed_bound=float("inf"))


def _spy_on_sweeps(monkeypatch) -> list:
    from footstep_gym import world as world_module

    seen = []
    original = world_module.World.sweep

    def spy(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        seen.append(result)
        return result

    monkeypatch.setattr(world_module.World, "sweep", spy)
    return seen


AT_THE_BOUNDS = {  # every speed at its YAML bound; geometry moved where a bigger door needs it
    "FootstepDoor-v0": lambda c: dict(door_speed=c["max_door_speed"], door_radius=c["max_door_radius"],
                                      corridor_y=[-c["max_door_radius"] - 0.1, 0.0], drum_segments=40,
                                      start=[-0.6, -0.2], goal=[1.3, -0.2]),
    "FootstepCrossing-v0": lambda c: dict(obstacle_speed=c["max_obstacle_speed"], arrival_speed=c["max_arrival_speed"],
                                          crossing_x=0.4, timing_jitter=0.5),
    "FootstepCrowd-v0": lambda c: dict(crowd_speed=c["max_crowd_speed"], ring_radius=0.5, breathing_period=[2.0, 3.0],
                                       breathing_amplitude=c["max_breathing_speed"] * 2.0 / (2 * math.pi)),
}


@pytest.mark.parametrize("env_id", list(AT_THE_BOUNDS))
def test_at_the_speed_bounds_the_cap_is_never_reached(env_id, monkeypatch):
    """Exact collision semantics within the bounds: random and nominal-ish steps, never capped, and the
    same trace as with no cap at all."""
    name = {"FootstepDoor-v0": "door", "FootstepCrossing-v0": "crossing", "FootstepCrowd-v0": "crowd"}[env_id]
    kwargs = AT_THE_BOUNDS[env_id](_yaml(f"scenarios/{name}.yaml"))
    seen = _spy_on_sweeps(monkeypatch)
    rng = np.random.default_rng(0)
    traces = []
    for cap in (_yaml("env.yaml")["max_sweep_checks"], 10**9):
        env = gym.make(env_id, max_sweep_checks=cap, **kwargs)
        low, high = env.action_space.low.astype(float), env.action_space.high.astype(float)
        rng = np.random.default_rng(0)
        env.reset(seed=0)
        trace = []
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            for i in range(300):
                action = rng.uniform(low, high) if i % 2 else NOMINAL + rng.uniform(-0.01, 0.01, 5)
                obs, reward, terminated, truncated, info = env.step(action)
                trace.append((obs.tobytes(), reward, info["time"], info["termination"]))
                if terminated or truncated:
                    env.reset()
        traces.append(trace)
    assert traces[0] == traces[1]
    assert len(seen) > 100 and not any(r.capped for r in seen)
    assert max(r.checks for r in seen) > 10  # the fast obstacles did come close


def test_door_speed_past_its_bound_steps_in_bounded_time(monkeypatch):
    """door_speed=1e9 deg/s with the bound raised past it: the first step returns, capped."""
    cap = _yaml("env.yaml")["max_sweep_checks"]
    seen = _spy_on_sweeps(monkeypatch)
    env = gym.make("FootstepDoor-v0", door_speed=1e9, max_door_speed=1e12)
    env.reset(seed=0)
    with pytest.warns(RuntimeWarning, match=f"max_sweep_checks={cap}"):
        env.step(NOMINAL)
    assert seen[0].capped and seen[0].checks <= cap + 1


# ------------------------------------------------------------------ the sweep inside the env
def _yaml(name: str) -> dict:
    with open(config_dir() / name, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def test_robot_walking_clear_of_every_obstacle_never_collides():
    """Crossing env with the car 5 m ahead and timed to arrive after 40 s: 40 nominal strides."""
    env = gym.make("FootstepCrossing-v0", crossing_x=5.0, timing_jitter=0.0, goal=[20.0, 0.0],
                   max_steps=500, time_limit=500.0)
    env.reset(seed=1)
    ramp = [0.02, 0.04, 0.06, 0.08] + [0.10] * 36  # reach a 10 cm stride gradually
    xs = []
    for stride in ramp:
        _, _, terminated, truncated, info = env.step(np.array([stride, 0.08, 0.0, 0.6, 0.2]))
        assert not terminated and not truncated
        assert not info["collision"] and info["termination"] is None and info["feasible"]
        xs.append(info["com"][0])
    assert xs[-1] > 3.0  # it really walked (about 3.6 m)
    assert info["time"] == pytest.approx(0.8 * len(ramp))


@pytest.mark.parametrize("env_id", ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"])
def test_nearest_agrees_with_pymunk_point_query(env_id):
    """``World.nearest`` (plain arithmetic) gives pymunk's own ``Space.point_query`` answer."""
    import pymunk

    from footstep_gym.world import _OBSTACLE_FILTER

    env = gym.make(env_id)
    env.reset(seed=1)
    for _ in range(3):  # obstacles moved and turned
        env.step(env.unwrapped.robot.nominal_command)
    world = env.unwrapped.world
    rng = np.random.default_rng(0)
    for _ in range(200):
        p = tuple(rng.uniform(-2.0, 2.0, 2))
        mine = world.nearest(p, 50, 1.5)
        assert [e[0] for e in mine] == sorted(e[0] for e in mine)
        ref = {}
        for info in world.space.point_query(p, 1.5, _OBSTACLE_FILTER):
            body = info.shape.body
            v = body.velocity_at_world_point(info.point) if body.body_type != pymunk.Body.STATIC else (0.0, 0.0)
            ref[info.shape] = (info.distance, tuple(info.point), tuple(v))
        assert {e[3].shape for e in mine} == set(ref)
        for dist, point, vel, obstacle in mine:
            np.testing.assert_allclose([dist, *point, *vel], [ref[obstacle.shape][0], *ref[obstacle.shape][1],
                                                              *ref[obstacle.shape][2]], atol=1e-9)
        assert len(world.nearest(p, 2, 1.5)) == min(2, len(ref))


# ------------------------------------------------------------------ the compiled sweep against pymunk's
def _random_world(seed: int, radius: float = R) -> World:
    """Static walls, a turning rod, a translating capsule and a few moving circles around the origin."""
    rng = np.random.default_rng(seed)
    world = make_world(radius, max_checks=2000)
    for i in range(int(rng.integers(0, 6))):
        a = rng.uniform(-1.5, 1.5, 2)
        b = a + rng.uniform(-1.0, 1.0, 2) * (rng.random() < 0.9)  # now and then a zero-length wall
        world.add_wall(f"wall_{i}", tuple(a), tuple(b), rng.uniform(0.0, 0.05))
    for i in range(int(rng.integers(0, 3))):
        half = rng.uniform(0.0, 0.6)
        world.add_rod(f"rod_{i}", tuple(rng.uniform(-1.0, 1.0, 2)), (-half, 0.0), (half, 0.0), rng.uniform(0.005, 0.1),
                      angle=rng.uniform(-4, 4), velocity=tuple(rng.uniform(-0.3, 0.3, 2) * (rng.random() < 0.5)),
                      angular_velocity=rng.uniform(-2.0, 2.0) * (rng.random() < 0.8))
    for i in range(int(rng.integers(0, 5))):
        world.add_circle(f"ball_{i}", tuple(rng.uniform(-1.2, 1.2, 2)), rng.uniform(0.02, 0.15),
                         velocity=tuple(rng.uniform(-0.5, 0.5, 2)))
    return world


def _random_path(rng: np.random.Generator):
    """A LIPM footstep path through the world around the origin (what the env sweeps) and its speed bound."""
    from footstep_gym.lipm import StepTrajectory

    omega = math.sqrt(9.81 / rng.uniform(0.2, 0.3))
    com, vel = complex(*rng.uniform(-0.05, 0.05, 2)), complex(*rng.uniform(-0.3, 0.3, 2))
    p, q = complex(*rng.uniform(-0.03, 0.03, 2)), complex(rng.uniform(-0.04, 0.1), rng.uniform(-0.12, 0.12))
    traj = StepTrajectory(omega, com, vel, p, q, rng.uniform(0.1, 0.6), rng.uniform(0.1, 0.3))
    origin, rot = complex(*rng.uniform(-0.8, 0.8, 2)), complex(math.cos(a := rng.uniform(-3, 3)), math.sin(a))
    return traj, traj.world_path(origin, rot), traj.speed_bound()


def _state(world: World) -> list:
    bodies = [o.body for o in world.obstacles if not o.static] + [world.robot_body]
    return [world.time] + [(tuple(b.position), b.angle) for b in bodies]


@pytest.mark.filterwarnings("ignore:World.sweep")  # a few random paths are fast enough to reach the cap
@pytest.mark.parametrize("seed", range(40))
def test_compiled_sweep_equals_pymunk_sweep_bit_for_bit(seed):
    """Random worlds and LIPM paths, several footsteps in a row (contacts, stale shapes, carried bounds):
    the compiled sweep gives pymunk's own sweep's every number and leaves the world in the same state."""
    rng = np.random.default_rng(1000 + seed)
    fast, slow = _random_world(seed), _random_world(seed)
    for step in range(6):
        traj, path, bound = _random_path(rng)
        if rng.random() < 0.3:  # move a body between footsteps without stepping (the crowd does)
            for w in (fast, slow):
                movers = [o for o in w.obstacles if not o.static]
                if movers:
                    movers[step % len(movers)].body.position = (0.3 * step - 0.5, -0.4)
        duration = traj.t_ss + traj.t_ds
        a = fast.sweep(path, duration, bound)
        b = slow.sweep_pymunk(path, duration, bound)
        assert a == b, (step, a, b)
        assert _state(fast) == _state(slow)
        clear = lambda w: w.clearance((0.05 * step, 0.1), 5.0)  # noqa: E731 - pymunk's caches agree too
        assert (clear(fast)[0], getattr(clear(fast)[1], "name", None)) == \
               (clear(slow)[0], getattr(clear(slow)[1], "name", None))


@pytest.mark.filterwarnings("ignore:World.sweep")
def test_compiled_sweep_covers_contacts_and_far_footsteps():
    """The random cases above include contacts and contact-free steps (so both ways out are compared)."""
    outcomes = set()
    for seed in range(40):
        rng = np.random.default_rng(1000 + seed)
        world = _random_world(seed)
        for _ in range(6):
            traj, path, bound = _random_path(rng)
            outcomes.add(world.sweep(path, traj.t_ss + traj.t_ds, bound).collided)
    assert outcomes == {True, False}


def test_shape_distance_is_pymunks_point_query_bit_for_bit():
    """The distance to a static segment, a turned and moved segment and a circle (``footstep_gym.collision``, compiled
    in the kernel and run on Python numbers), at random points (and at points on the segment's line and ends),
    against pymunk's ``Shape.point_query``."""
    from footstep_gym.kernels import sweep as kernel

    rng = np.random.default_rng(7)
    world = _random_world(3)
    world.add_wall("flat", (-1.0, 0.3), (1.0, 0.3), 0.02)
    world.add_rod("turned", (0.2, -0.1), (-0.5, 0.0), (0.5, 0.0), 0.02, angle=2.1)
    world.add_circle("ball", (0.4, 0.7), 0.1)
    table, _ = world._table()
    states = np.array([[*o.body.position, o.body.angle, 0.0, 0.0, 0.0, 0.0] for o in world.obstacles if not o.static])
    points = [tuple(rng.uniform(-2, 2, 2)) for _ in range(3000)]
    points += [(x, 0.3) for x in (-1.0, -0.5, 0.0, 1.0, 1.5)] + [(-1.0, 0.31), (1.0, 0.3 + 1e-17)]
    for j, o in enumerate(world.obstacles):
        for q in points:
            want = o.shape.point_query(q).distance
            for got in (kernel._shape_distance(j, q[0], q[1], table, states),
                        kernel._shape_distance_py(j, q[0], q[1], table, states)):
                assert got == want or (math.isnan(got) and math.isnan(want)), (o.name, q, got, want)


def test_world_path_is_the_trajectory_bit_for_bit():
    """``WorldPath`` (Python) and the kernel's path give ``origin + state(t)[0] * rot`` exactly."""
    from footstep_gym.kernels import sweep as kernel

    rng = np.random.default_rng(3)
    for _ in range(50):
        traj, path, _ = _random_path(rng)
        prm = np.zeros(kernel.N_PARAMS)
        prm[:21] = path.sweep_params
        for t in [0.0, traj.t_ss, traj.t_ss + traj.t_ds, 2.0, *rng.uniform(0, traj.t_ss + traj.t_ds, 20)]:
            z = path.path.origin + traj.state(t)[0] * path.path.rot
            assert path(t) == (z.real, z.imag)
            assert kernel._path(t, prm) == (z.real, z.imag)
            assert kernel._path_py(t, prm) == (z.real, z.imag)


# ------------------------------------------------------------------ the compiled sweep switched off in the env

@pytest.mark.parametrize("env_id", ENV_IDS)
def test_compiled_sweep_off_gives_the_same_episodes(env_id):
    """``compiled_sweep=False`` (pymunk at every check, no numba) changes the cost of a step, not its outcome."""
    rng = np.random.default_rng(5)
    actions = [NOMINAL + rng.normal(0.0, 0.01, 5) * [1, 0.3, 1, 1, 0.5] for _ in range(60)]
    runs = []
    for compiled in (True, False):
        env = gym.make(env_id, compiled_sweep=compiled)
        assert env.unwrapped.config.compiled_sweep is compiled
        out = [env.reset(seed=2)[0]]
        for a in actions:
            obs, reward, terminated, truncated, info = env.step(a)
            out.append((obs.tolist(), reward, terminated, truncated, info["time"], info["clearance"], info["obstacle"]))
            if terminated or truncated:
                out.append(env.reset()[0])
        runs.append(out)
    assert str(runs[0]) == str(runs[1])
    code = ("import sys, gymnasium as gym, footstep_gym; e = gym.make(%r, compiled_sweep=False); e.reset(seed=0); "
            "[e.step(e.unwrapped.robot.nominal_command) for _ in range(3)]; print('numba' in sys.modules)" % env_id)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"  # such an env process never loads numba


# ------------------------------------------------------------------ copies of an env mid-episode
@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_a_copy_made_mid_episode_steps_as_the_original(env_id, how):
    """``copy.deepcopy(env)`` (or a pickle) after some steps, then both stepped alike: the same results.

    The world carries state from one sweep to the next (its shape table, each shape's row); a copy
    has new obstacle objects, so that state must not be keyed by the originals' ``id()`` (it was:
    the copy's first sweep that asked pymunk, every crowd step, raised ``KeyError``).
    """
    import copy
    import pickle

    rng = np.random.default_rng(11)
    actions = [NOMINAL + rng.normal(0.0, 0.01, 5) * [1, 0.3, 1, 1, 0.5] for _ in range(40)]
    env = gym.make(env_id)
    env.reset(seed=4)
    for a in actions[:3]:
        env.step(a)
    clone = copy.deepcopy(env) if how == "deepcopy" else pickle.loads(pickle.dumps(env))
    runs = []
    for e in (env, clone):
        out = []
        for a in actions[3:]:
            obs, reward, terminated, truncated, info = e.step(a)
            out.append((obs.tolist(), reward, terminated, truncated, info["time"], info["clearance"],
                        info["obstacle"], info.get("termination")))
            if terminated or truncated:
                out.append(e.reset(seed=5)[0].tolist())
        runs.append(out)
    assert str(runs[0]) == str(runs[1])
