"""The JAX door (footstep_gym.jax) against the reference env and its pieces: the LIPM verdict and path, the
collision sweep (pymunk's World.sweep as the oracle), replays of reference episodes, seeding, bad settings.

JAX compiles each distinct function once per process: the episodes here are few and short, and the float64
checks share one compiled replay.
"""

from __future__ import annotations

import math

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jax_helpers import OBS_TOL_64, REWARD_TOL_64
from footstep_gym import lipm
from footstep_gym.errors import ConfigError
from footstep_gym.jax import replay as R
from footstep_gym.jax import shapes, walker
from footstep_gym.jax.env import FootstepJaxEnv
from footstep_gym.robot import load_robot
from footstep_gym.world import World

TRAIN = {"tier": "train"}


@pytest.fixture(scope="module")
def env64(x64):
    return FootstepJaxEnv("door", dtype="float64", **TRAIN)


def _random_state(rng, robot):
    """A CoM state near stepping in place and a command in the box, both complex/np as lipm takes them."""
    com, vel = lipm.steady_state(robot, robot.nominal_command, -1)
    com += complex(*rng.normal(0, 0.005, 2))
    vel += complex(*rng.normal(0, 0.03, 2))
    cmd = rng.uniform(robot.command_low, robot.command_high)
    return com, vel, cmd


def test_verdict_and_path_match_the_scalar_lipm(x64):
    robot = load_robot()
    rng = np.random.default_rng(3)
    for _ in range(40):
        com, vel, cmd = _random_state(rng, robot)
        side = int(rng.choice([-1, 1]))
        kin, zmp, p, c_end, v_end = lipm.check_step(robot, com, vel, tuple(cmd), side)
        v = walker.verdict(robot, jnp.asarray(com), jnp.asarray(vel), jnp.asarray(cmd), jnp.asarray(side))
        assert bool(v.kinematic_ok) == kin and bool(v.zmp_ok) == zmp
        assert abs(complex(v.p) - p) < 1e-15 and abs(complex(v.end_com) - c_end) < 1e-14
        assert abs(complex(v.end_vel) - v_end) < 1e-13
        q = complex(cmd[0], -side * cmd[1])
        traj = lipm.StepTrajectory(robot.omega, com, vel, p, q, cmd[3], cmd[4])
        origin, rot = complex(0.3, -0.2), complex(math.cos(0.4), math.sin(0.4))
        path, bound = walker.path_of(robot, v, jnp.asarray(cmd), jnp.asarray(side), jnp.asarray(origin),
                                     jnp.asarray(rot))
        assert float(bound) == pytest.approx(traj.speed_bound(), rel=1e-14)
        world_path = traj.world_path(origin, rot)
        ts = np.linspace(0.0, cmd[3] + cmd[4], 9)
        x, y = path(jnp.asarray(ts))
        for t, xi, yi in zip(ts, np.asarray(x), np.asarray(y)):
            assert np.allclose((xi, yi), world_path(t), rtol=0, atol=1e-14)
            c_ref, v_ref = traj.state(t)
            c, vv = path.state(jnp.asarray(t))
            assert abs(complex(c) - c_ref) < 1e-14 and abs(complex(vv) - v_ref) < 1e-13


def _door_world(angle, speed_deg, robot):
    world = World(robot.body_radius, 0.001, 0.02, 0.25, 2000, compiled=False)
    world.add_wall("wall", (-1.8, -0.66), (1.8, -0.66), 0.02)
    world.add_wall("top", (-1.8, 0.0), (-0.54, 0.0), 0.02)
    world.add_rod("door", (0.0, 0.0), (-0.5, 0.0), (0.5, 0.0), 0.02, angle=angle,
                  angular_velocity=-math.radians(speed_deg))
    return world


@pytest.mark.parametrize("block", [1, 2, 8])
def test_sweep_matches_pymunk(x64, block):
    """The sweep's contact, its instant, the number of checks and the door's angle at the end equal pymunk's
    (``World.sweep_pymunk``, which asks pymunk at every check), for robots walking at the door."""
    robot = load_robot()
    rng = np.random.default_rng(11)
    collided = 0
    fn = jax.jit(lambda path, dur, bound, table, rods: shapes.sweep(
        path, dur, bound, table, rods, robot.body_radius, 0.02, 0.25, 2000, block))
    for _ in range(24):
        angle, speed = rng.uniform(0, math.pi), rng.uniform(5, 40)
        world = _door_world(angle, speed, robot)
        com, vel, _ = _random_state(rng, robot)
        cmd = np.array([rng.uniform(0.0, 0.1), 0.08, 0.0, rng.uniform(0.1, 0.6), rng.uniform(0.1, 0.3)])
        kin, zmp, p, *_ = lipm.check_step(robot, com, vel, tuple(cmd), -1)
        origin = complex(rng.uniform(-0.7, 0.2), rng.uniform(-0.5, -0.2))
        traj = lipm.StepTrajectory(robot.omega, com, vel, p, complex(cmd[0], cmd[1]), cmd[3], cmd[4])
        ref = world.sweep_pymunk(traj.world_path(origin, 1 + 0j), cmd[3] + cmd[4], traj.speed_bound())
        v = walker.verdict(robot, jnp.asarray(com), jnp.asarray(vel), jnp.asarray(cmd), jnp.asarray(-1))
        path, bound = walker.path_of(robot, v, jnp.asarray(cmd), jnp.asarray(-1), jnp.asarray(origin),
                                     jnp.asarray(1 + 0j))
        walls = shapes.walls_of(world, jnp.float64)
        rods = shapes.Rods(jnp.zeros((1, 2)), jnp.asarray([angle]), jnp.zeros((1, 2)),
                           jnp.asarray([-math.radians(speed)]), jnp.asarray([[-0.5, 0.0]]),
                           jnp.asarray([[0.5, 0.0]]), jnp.asarray([0.01]))
        got = fn(path, jnp.asarray(cmd[3] + cmd[4]), bound, shapes.wall_table(walls), rods)
        assert bool(got.collided) == ref.collided
        assert int(got.checks) == ref.checks
        assert float(got.time) == pytest.approx(ref.time, abs=1e-12)
        assert float(got.clearance) == pytest.approx(ref.clearance, abs=1e-12)
        door = world.obstacles[-1].body
        assert float(got.rods.angle[0]) == pytest.approx(door.angle, abs=1e-12)
        if ref.collided:
            collided += 1
            assert [o.name for o in world.obstacles][int(got.obstacle)] == ref.obstacle
    assert 3 <= collided <= 21  # both outcomes were exercised


def test_replayed_episodes_end_alike(env64):
    """Reference episodes (period-aware planner, open-loop walks, fuzzed float32 actions; train-split seeds,
    train tier) replayed in float64: the same ending at the same step, observations and rewards within the
    stated tolerances."""
    walks = R.record_many("FootstepDoor-v0", range(100, 104), "walk", TRAIN, max_steps=40)
    fuzz = R.record_many("FootstepDoor-v0", range(100, 104), "fuzz", TRAIN, max_steps=40)
    planned = R.record_many("FootstepDoor-v0", [100], "planner", TRAIN, max_steps=40)
    outcomes = set()
    for episodes in (walks + fuzz, planned):
        for a in R.compare(episodes, R.replay(env64, episodes)):
            assert a.same or a.near_tie, a
            assert a.obs_error <= OBS_TOL_64 and a.reward_error <= REWARD_TOL_64, a
            outcomes.add(a.reference[0])
    assert {"fall", "goal"} <= outcomes and outcomes & {"collision", "cut"}


STRUCTURE = {"tier": "structure"}


@pytest.fixture(scope="module")
def structure64(x64):
    return FootstepJaxEnv("door", dtype="float64", **STRUCTURE)


def _reference_hit(episode):
    """The shape the reference env's episode ended on (``info["obstacle"]``), its actions sent again."""
    env = gym.make(episode.env_id, **episode.env_kwargs)
    env.reset(seed=episode.seed)
    for action in episode.actions:
        *_, info = env.step(action)
    env.close()
    return info["obstacle"]


def test_one_door_and_two_replay_in_one_env_each_cell_with_its_walls(structure64):
    """The structure tier's cells (two doors, 20 walls; one door from any phase, 11) in one float64 env, each with
    its own walls: reference episodes of both cells (walks, fuzzed actions, the planner through both doors) end
    alike, within the tolerances, and a collision names the reference's shape (wall, door or door_2)."""
    env = structure64
    assert env.per_cell_walls and [len(w) for w in env.wall_names] == [20, 11] and env.scene.size == 2
    seeds = range(100, 110)
    episodes = [R.record_many("FootstepDoor-v0", seeds, kind, STRUCTURE, max_steps=60) for kind in ("walk", "fuzz")]
    episodes.append(R.record_many("FootstepDoor-v0", [100, 101], "planner", dict(STRUCTURE, tier_cell="two_doors")))
    cells, outcomes, hits = set(), set(), set()
    for batch in episodes:
        replayed = R.replay(env, batch)
        for i, a in enumerate(R.compare(batch, replayed)):
            assert a.same or a.near_tie, a
            assert a.obs_error <= OBS_TOL_64 and a.reward_error <= REWARD_TOL_64, a
            cell = batch[i].tier_cell
            cells.add(cell)
            outcomes.add((cell, a.reference[0]))
            if a.same and a.reference[0] == "collision":
                names = env.wall_names[R.cell_index(env, cell)] + ["door", "door_2"]
                got = names[int(replayed.obstacle[i, a.reference[1] - 1])]
                assert got == _reference_hit(batch[i]), (a, got)
                hits.add(got)
    assert cells == {"two_doors", "any_phase"}
    assert ("two_doors", "goal") in outcomes and hits & {"door", "door_2"}


def test_a_one_door_cell_parks_the_second_rod_and_two_doors_draw_theirs(x64):
    """Resets of the structure tier: both cells drawn; the second door at its centre, its speed and phase in the
    cell's ranges; a one-door cell's second rod parked and still."""
    env = FootstepJaxEnv("door", dtype="float64", **STRUCTURE)
    state, _ = jax.jit(jax.vmap(lambda k: env.reset(k, env.default_params)))(jax.random.split(jax.random.key(4), 200))
    cell = np.asarray(state.cell)
    two = cell == env.cells.index("two_doors")
    assert 0 < two.sum() < 200
    pos, w = np.asarray(state.rods.position), np.asarray(state.rods.angular_velocity)
    angle = np.degrees(np.asarray(state.rods.angle))
    assert np.allclose(pos[two, 1], (3.5, 0.0)) and np.all(pos[~two, 1] == 1.0e6) and np.all(w[~two, 1] == 0.0)
    speed2 = -np.degrees(w[two, 1])
    assert np.all((speed2 >= 5.0 - 1e-9) & (speed2 <= 20.0 + 1e-9)) and np.ptp(speed2) > 10.0
    assert np.all((angle[two, 1] >= -10.0 - 1e-9) & (angle[two, 1] <= 190.0 + 1e-9)) and np.ptp(angle[two, 1]) > 150
    assert np.all(np.abs(angle[~two, 0] - 90.0) <= 90.0 + 1e-9)  # any_phase: 90 +- 90


def test_float32_action_at_a_rounded_limit_is_the_limit(env64):
    state, _ = env64.reset(jax.random.key(0), env64.default_params)
    action = np.array([0.0, 0.08, -0.2, 0.6, 0.2], dtype=np.float32)  # theta and T_SS at float32-rounded limits
    cmd, clipped = env64.command(jnp.asarray(action))
    assert not bool(clipped)
    assert np.asarray(cmd).tolist() == [0.0, float(np.float32(0.08)), -0.2, 0.6, float(np.float32(0.2))]
    cmd, clipped = env64.command(jnp.asarray([0.2, 0.08, 0.0, 0.6, 0.2]))
    assert bool(clipped) and float(cmd[0]) == 0.1


def test_reset_is_seeded_jittable_and_vmappable():
    env = FootstepJaxEnv("door", **TRAIN)
    reset = jax.jit(jax.vmap(lambda k: env.reset(k, env.default_params)))
    keys = jax.random.split(jax.random.key(5), 4)
    s1, o1 = reset(keys)
    s2, o2 = reset(keys)
    assert o1.shape == (4, env.obs_size) and o1.dtype == jnp.float32
    assert np.array_equal(np.asarray(o1), np.asarray(o2))
    assert len({float(w) for w in np.asarray(s1.rods.angular_velocity[:, 0])}) == 4  # speeds differ per key
    speeds = -np.degrees(np.asarray(s1.rods.angular_velocity[:, 0]))
    assert np.all((speeds >= 5.0 - 1e-4) & (speeds <= 20.0 + 1e-4))  # the train tier's range
    assert env.observation_space.contains(np.asarray(o1[0]))


@pytest.mark.parametrize("kwargs, named", [
    ({"scenario": "mix"}, "scene 'mix'"),
    ({"scenario": "crowd", "crowd_model": "orca", "crowd_layout": "counter_flow"},
     "crowd_model='orca' with robot_visible=True"),
    ({"fixed_period": True}, "fixed_period"),
    ({"randomize": {"door_radius": [0.4, 0.5]}}, "randomize of door_radius"),
    ({"dtype": "float16"}, "dtype must be"),
])
def test_unsupported_settings_raise_one_line(kwargs, named):
    with pytest.raises(ConfigError) as err:
        FootstepJaxEnv(**kwargs)
    assert named in str(err.value) and "\n" not in str(err.value)


def test_float64_without_x64_says_how():
    with jax.enable_x64(False), pytest.raises(ConfigError, match="JAX_ENABLE_X64"):
        FootstepJaxEnv("door", dtype="float64")


def test_chunked_batch_step_is_vmap():
    env = FootstepJaxEnv("door", **TRAIN)
    n = 8
    state, _ = jax.vmap(lambda k: env.reset(k, env.default_params))(jax.random.split(jax.random.key(2), n))
    actions = jax.random.uniform(jax.random.key(3), (n, 5), jnp.float32, env.action_space.low, env.action_space.high)
    actions = actions.at[:4].set(jnp.asarray([0.05, 0.08, 0.0, 0.6, 0.2], jnp.float32))  # half walk, half random
    p, keys = env.default_params, jax.random.split(jax.random.key(6), n)
    chunked = jax.jit(lambda k, s, a: env.step_batch(k, s, a, p, chunk=4))(keys, state, actions)
    plain = jax.jit(jax.vmap(lambda k, s, a: env.step(k, s, a, p)))(keys, state, actions)
    # Discrete values exactly; floats within a few float32 ulps (XLA may contract or vectorise the two layouts'
    # arithmetic differently).
    for x, y in zip(jax.tree.leaves(chunked), jax.tree.leaves(plain)):
        if jnp.issubdtype(x.dtype, jax.dtypes.prng_key):
            x, y = jax.random.key_data(x), jax.random.key_data(y)
        x, y = np.asarray(x), np.asarray(y)
        if x.dtype.kind == "f":
            assert np.allclose(x, y, rtol=1e-5, atol=1e-6, equal_nan=True)
        else:
            assert np.array_equal(x, y)
    assert np.asarray(plain[5]["termination"]).tolist().count(0) < n  # some step ended an episode


def test_building_the_env_builds_no_pymunk_world_and_its_params_are_the_references(x64, monkeypatch):
    """``FootstepJaxEnv`` reads its cells' configs and walls from the scene layer: no reference env and no pymunk
    world is built (both raise here). Its per-cell walls are those the reference's world holds for each cell."""
    import footstep_gym.env as env_module
    import footstep_gym.world as world_module

    def refuse(*args, **kwargs):
        raise AssertionError("FootstepJaxEnv built a reference env or a pymunk world")

    with monkeypatch.context() as m:
        m.setattr(env_module.FootstepEnv, "__init__", refuse)
        m.setattr(world_module.World, "__init__", refuse)
        env = FootstepJaxEnv("door", dtype="float64", **STRUCTURE)
    params = env.default_params
    assert params.walls.r.shape[0] == len(env.cells) == params.max_steps.shape[0]
    for i, cell in enumerate(env.cells):
        ref = gym.make("FootstepDoor-v0", tier_cell=cell, **STRUCTURE).unwrapped
        ref.reset(seed=0)
        walls = [o for o in ref.world.obstacles if o.static]
        n = int(params.wall_counts[i])
        assert [o.name for o in walls] == env.wall_names[i] and n == len(walls)
        assert np.array_equal(np.asarray(params.walls.a[i, :n]), [o.local_a for o in walls])
        assert np.array_equal(np.asarray(params.walls.b[i, :n]), [o.local_b for o in walls])
        assert np.array_equal(np.asarray(params.walls.r[i, :n]), [o.radius for o in walls])
        ref.close()
