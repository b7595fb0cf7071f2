"""The JAX crowd (footstep_gym.jax.scenes.CrowdScene: the scripted ring and ORCA's pedestrians) against the reference
env: replays of reference episodes (the tiers' crowd sizes and rings, the structure tier's ORCA cells), the sweep's first check against pymunk's cached shapes, the
schedule against ``Crowd.positions``, seeding, unsupported cells (make_vec of the crowd: tests/test_jax_vector.py).

JAX compiles each distinct function once per process: the episodes here are few and short.
"""

from __future__ import annotations


import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import footstep_gym  # noqa: F401
from jax_helpers import check_replays
from footstep_gym import lipm
from footstep_gym.errors import ConfigError
from footstep_gym.jax import replay as R
from footstep_gym.jax import shapes, walker
from footstep_gym.jax.env import FootstepJaxEnv
from footstep_gym.robot import load_robot
from footstep_gym.scenes import crowd as crowd_scene
from footstep_gym.scenes.crowd import State as CrowdState
from footstep_gym.world import World

CROWD = "FootstepCrowd-v0"
TRAIN = {"tier": "train"}
DENSE = {"tier": "structure", "tier_cell": "dense"}


@pytest.fixture(scope="module")
def dense64(x64):
    """A float64 env of the structure tier's dense cell: 10 members, so 8-member episodes run with 2 padded."""
    return FootstepJaxEnv("crowd", dtype="float64", **DENSE)


def test_replayed_episodes_end_alike(dense64):
    """Reference episodes (period-aware planner, open-loop walks, fuzzed float32 actions; train-split seeds) of
    the train tier (8 members) and the dense cell (10) replayed in float64 in one env: the same ending at the
    same step, observations, rewards and the sweep's clearances within the stated tolerances."""
    outcomes: set[str] = set()
    walks = R.record_many(CROWD, range(200, 204), "walk", TRAIN, max_steps=30)
    fuzz = R.record_many(CROWD, range(200, 203), "fuzz", TRAIN, max_steps=30)
    dense = R.record_many(CROWD, range(210, 213), "walk", DENSE, max_steps=30)
    check_replays(R.compare(walks + fuzz + dense, R.replay(dense64, walks + fuzz + dense, pad_to=30)), outcomes)
    planned = R.record_many(CROWD, [200], "planner", TRAIN, max_steps=30)
    check_replays(R.compare(planned, R.replay(dense64, planned, pad_to=30)), outcomes)
    assert {"collision", "fall"} <= outcomes and outcomes & {"goal", "cut"}


def test_schedule_is_the_reference_crowds(x64):
    """``CrowdScene.positions`` and ``before_step`` against ``Crowd.positions`` and ``Crowd.before_step`` on a
    reference episode's draws, through the acceleration and after it."""
    env = gym.make(CROWD, tier="train")
    env.reset(seed=7)
    u = env.unwrapped
    jenv = FootstepJaxEnv("crowd", dtype="float64", **TRAIN)
    rods, scene = R.episode_start(jenv, u.episode_config, jenv.scene.reference_start(u))
    for t in (0.0, 0.37, 3.9, 4.0, 11.3):
        got = np.asarray(crowd_scene.positions(jnp, scene, jnp.asarray(t)))
        assert np.allclose(got, u.scenario.positions(t), rtol=0, atol=1e-14)
    moved, _ = jenv.scene.before_step(scene, rods, jnp.asarray(2.5), jnp.asarray(0.8))
    u.scenario.before_step(u.world, 2.5, 0.8)
    for body, p, v in zip((m.body for m in u.scenario.members), np.asarray(moved.position), np.asarray(moved.velocity)):
        assert np.allclose(p, tuple(body.position), rtol=0, atol=1e-14)
        assert np.allclose(v, tuple(body.velocity), rtol=0, atol=1e-13)
    env.close()


def test_first_check_sees_pymunks_cached_shapes(x64):
    """A member put elsewhere between two sweeps (as the crowd's schedule does before each footstep): pymunk's
    first check still sees it where its shape was cached, later checks where it moves from; the JAX sweep given
    ``cached`` makes the same checks (their count, clearance, contact), and without it does not."""
    robot = load_robot()
    rng = np.random.default_rng(4)
    radius = robot.body_radius
    differs = collided = 0
    fn = jax.jit(lambda path, dur, bound, rods, cached: shapes.sweep(
        path, dur, bound, jnp.zeros((0, 8)), rods, radius, 0.02, 0.25, 2000, 8, cached=cached))
    for _ in range(16):
        world = World(radius, 0.001, 0.02, 0.25, 2000, compiled=True)
        centres = rng.uniform(-0.35, 0.35, (4, 2)) + np.array([0.35, 0.0])
        members = [world.add_circle(f"m{i}", tuple(c), 0.08, tuple(rng.uniform(-0.1, 0.1, 2)))
                   for i, c in enumerate(centres)]
        com, vel = lipm.steady_state(robot, robot.nominal_command, -1)
        cmd = np.array([rng.uniform(0.0, 0.1), 0.08, 0.0, rng.uniform(0.2, 0.6), rng.uniform(0.1, 0.3)])
        kin, zmp, p, *_ = lipm.check_step(robot, com, vel, tuple(cmd), -1)
        traj = lipm.StepTrajectory(robot.omega, com, vel, p, complex(cmd[0], cmd[1]), cmd[3], cmd[4])
        world.sweep(traj.world_path(-0.4 + 0j, 1 + 0j), 0.05, traj.speed_bound())  # pymunk caches the shapes
        cached = np.array([tuple(m.body.position) for m in members])
        jump = cached + rng.uniform(-0.06, 0.06, (4, 2))  # the schedule's places: elsewhere
        velocity = rng.uniform(-0.3, 0.3, (4, 2))
        for m, q, v in zip(members, jump, velocity):
            m.body.position = tuple(q)
            m.body.velocity = tuple(v)
        origin = complex(rng.uniform(-0.1, 0.2), rng.uniform(-0.1, 0.1))
        ref = world.sweep(traj.world_path(origin, 1 + 0j), cmd[3] + cmd[4], traj.speed_bound())
        v = walker.verdict(robot, jnp.asarray(com), jnp.asarray(vel), jnp.asarray(cmd), jnp.asarray(-1))
        path, bound = walker.path_of(robot, v, jnp.asarray(cmd), jnp.asarray(-1), jnp.asarray(origin),
                                     jnp.asarray(1 + 0j))
        zeros = jnp.zeros((4, 2))
        rods = shapes.Rods(jnp.asarray(jump), jnp.zeros(4), jnp.asarray(velocity), jnp.zeros(4), zeros, zeros,
                           jnp.full(4, 0.08))
        got = fn(path, jnp.asarray(cmd[3] + cmd[4]), bound, rods, jnp.asarray(cached))
        assert bool(got.collided) == ref.collided and int(got.checks) == ref.checks
        assert float(got.clearance) == pytest.approx(ref.clearance, abs=1e-12)
        assert float(got.time) == pytest.approx(ref.time, abs=1e-12)
        assert np.allclose(np.asarray(got.rods.position), [tuple(m.body.position) for m in members], atol=1e-12)
        naive = fn(path, jnp.asarray(cmd[3] + cmd[4]), bound, rods, jnp.asarray(jump))
        differs += int(naive.checks) != ref.checks or float(naive.clearance) != pytest.approx(ref.clearance, abs=1e-12)
        collided += ref.collided
    assert differs >= 3  # the cached places matter in these sweeps
    assert 1 <= collided <= 15


def test_reset_is_seeded_and_draws_the_ring():
    env = FootstepJaxEnv("crowd", **TRAIN)
    reset = jax.jit(jax.vmap(lambda k: env.reset(k, env.default_params)))
    keys = jax.random.split(jax.random.key(5), 6)
    s1, o1 = reset(keys)
    s2, o2 = reset(keys)
    assert o1.shape == (6, env.obs_size) and np.array_equal(np.asarray(o1), np.asarray(o2))
    scene: CrowdState = s1.scene
    speeds = np.asarray(scene.speed)
    assert len(set(speeds.tolist())) == 6 and np.all((speeds >= 0.12 - 1e-6) & (speeds <= 0.22 + 1e-6))
    centre = np.asarray(s1.com)[:, None, :]
    gap = np.linalg.norm(np.asarray(s1.rods.position) - centre, axis=-1)
    assert np.all(np.abs(gap - 0.36) <= 0.04 + 0.03)  # members on the ring around the start (CoM sway ~3 cm)
    assert np.all(np.asarray(s1.rods.velocity) == 0.0)  # at rest at reset, as the reference's bodies
    assert all(env.observation_space.contains(np.asarray(o)) for o in o1)


def test_dense_cell_holds_its_members():
    env = FootstepJaxEnv("crowd", **DENSE)
    state, _ = env.reset(jax.random.key(1), env.default_params)
    assert env.scene.size == 10 and bool(jnp.all(state.scene.active))


@pytest.mark.parametrize("kwargs, named", [
    ({"crowd_model": "orca"}, "crowd_model='orca' with robot_visible=True"),
    ({"crowd_model": "orca", "crowd_layout": "closing_in"}, "robot_visible=True"),
    ({"randomize": {"member_radius": [0.06, 0.1]}}, "randomize of member_radius"),
])
def test_unsupported_crowd_cells_raise_one_line(kwargs, named):
    with pytest.raises(ConfigError) as err:
        FootstepJaxEnv("crowd", **kwargs)
    assert named in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ConfigError, match="vectorization_mode='sync'"):
        gym.make_vec(CROWD, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)


STRUCTURE = {"tier": "structure"}
ORCA_CELLS = ("counter_flow", "crossing_flows", "closing_in")


@pytest.fixture(scope="module")
def structure64(x64):
    """A float64 env of the whole structure tier: ORCA cells (6 or 8 pedestrians) and rings (9, 10 members)."""
    return FootstepJaxEnv("crowd", dtype="float64", **STRUCTURE)


def test_replayed_orca_episodes_end_alike(structure64):
    """Reference episodes of the ORCA cells (walks, fuzz; pyrvo moving the pedestrians) and a ring cell replayed in
    float64 in one structure-tier env (ORCA in scenes/orca.py, every pedestrian padded to 10 bodies):
    the same ending at the same step, observations, rewards and clearances within the float64 tolerances (the
    planner's episodes: baselines/jax_replay.py, whose figures are committed)."""
    outcomes: set[str] = set()
    walks = [e for cell in ORCA_CELLS for e in R.record_many(CROWD, range(300, 302), "walk",
                                                            {**STRUCTURE, "tier_cell": cell}, max_steps=30)]
    fuzz = R.record_many(CROWD, [300], "fuzz", {**STRUCTURE, "tier_cell": "counter_flow"}, max_steps=30)
    ring = R.record_many(CROWD, [301], "walk", {**STRUCTURE, "tier_cell": "tight"}, max_steps=30)
    episodes = walks + fuzz + ring
    check_replays(R.compare(episodes, R.replay(structure64, episodes, pad_to=30)), outcomes)
    assert {"collision", "fall"} <= outcomes


def test_orca_before_step_is_the_references(structure64):
    """The pedestrians put before each footstep (where they stand, their chords) against the reference's pyrvo
    crowd over footsteps of differing lengths, and the scene state carried on between them."""
    env = gym.make(CROWD, tier="structure", tier_cell="crossing_flows")
    env.reset(seed=9)
    u = env.unwrapped
    rods, scene = R.episode_start(structure64, u.episode_config, structure64.scene.reference_start(u))
    before = jax.jit(structure64.scene.before_step)
    n = u.episode_config.crowd_size
    t = 0.0
    for duration in (0.8, 0.35, 1.3, 0.62, 0.8):
        rods, scene = before(scene, rods, jnp.asarray(t), jnp.asarray(duration))
        u.scenario.before_step(u.world, t, duration)
        t += duration
        bodies = [m.body for m in u.scenario.members]
        assert np.array_equal(np.asarray(rods.position)[:n], [tuple(b.position) for b in bodies])
        assert np.allclose(np.asarray(rods.velocity)[:n], [tuple(b.velocity) for b in bodies], rtol=0, atol=1e-15)
        assert np.all(np.asarray(rods.position)[n:] == crowd_scene.PARKED)
    assert np.array_equal(np.asarray(rods.r)[:n], u.scenario.radii)
    env.close()


def test_orca_cells_reset_their_layouts():
    """JAX-drawn episodes of each ORCA cell: the cell's pedestrians (no two overlapping, radii and speeds in their
    ranges, those past the cell's count parked), at rest, and reset seeded."""
    env = FootstepJaxEnv("crowd", **STRUCTURE)
    reset = jax.jit(jax.vmap(lambda k: env.reset(k, env.default_params)))
    state, obs = reset(jax.random.split(jax.random.key(2), 24))
    again, _ = reset(jax.random.split(jax.random.key(2), 24))
    assert np.array_equal(np.asarray(state.rods.position), np.asarray(again.rods.position))
    cells = np.asarray(state.cell)
    assert set(cells.tolist()) == set(range(len(env.cells)))
    for i, c in enumerate(cells):
        cfg = env.cell_configs[c][0]
        n = cfg.crowd_size
        pos, r = np.asarray(state.rods.position[i]), np.asarray(state.rods.r[i])
        assert bool(state.scene.orca[i]) == (cfg.crowd_model == "orca")
        assert np.all(pos[n:] == crowd_scene.PARKED) and np.all(np.abs(pos[:n]) < 10)
        if cfg.crowd_model == "orca":
            gap = np.hypot(*(pos[:n, None] - pos[None, :n]).transpose(2, 0, 1)) - np.add.outer(r[:n], r[:n])
            assert gap[~np.eye(n, dtype=bool)].min() > 0
            lo, hi = cfg.pedestrian_radius
            assert np.all((r[:n] >= lo - 1e-6) & (r[:n] <= hi + 1e-6))
            speeds = np.asarray(state.scene.pedestrians.crowd.speed[i])[:n]
            assert np.all((speeds >= cfg.pedestrian_speed[0] - 1e-6) & (speeds <= cfg.pedestrian_speed[1] + 1e-6))
    assert np.all(np.asarray(state.rods.velocity) == 0.0)
    assert all(env.observation_space.contains(np.asarray(o)) for o in obs)


@pytest.mark.parametrize("scene", ["door", "crossing", "crowd"])
def test_every_cell_of_every_tier_is_batched(scene):
    """Every tier of every scene, whole and cell by cell, makes a JAX env (its cells built, none refused)."""
    from footstep_gym import tiers

    for name in tiers.tier_names():
        env = FootstepJaxEnv(scene, tier=name)
        for cell in env.cells:
            FootstepJaxEnv(scene, tier=name, tier_cell=cell)





def test_a_batch_runs_orca_on_its_orca_envs_with_each_ones_own_pedestrians(monkeypatch):
    """``before_step`` over batches of 8 envs of which none, 3, 4 (a bucket's edge) or all are ORCA episodes (the
    rest rings), over three footsteps of 3-13 ORCA steps each, against the same batch with ORCA run on every env
    (``crowd.orca_before_step`` under plain ``vmap``): the same obstacles, and for an ORCA env the same crowd,
    whichever of :func:`footstep_gym.jax.scenes._orca_envs`'s slices (here halves) its steps run in; a ring env
    keeps its pedestrians."""
    from footstep_gym.jax import scenes as jax_scenes

    monkeypatch.setattr(jax_scenes, "ORCA_BUCKETS", 2)
    monkeypatch.setattr(jax_scenes, "_ORCA_ENVS", {})  # traced afresh with the patched buckets
    env = FootstepJaxEnv("crowd", **STRUCTURE)
    pool, _ = jax.jit(jax.vmap(lambda k: env.reset(k, env.default_params)))(jax.random.split(jax.random.key(5), 40))
    orca = np.asarray(pool.scene.orca)
    gathered = jax.jit(jax.vmap(env.scene.before_step))
    with monkeypatch.context() as m:  # ORCA on every env
        m.setattr(jax_scenes, "_orca_envs", lambda k: lambda model, peds, d: crowd_scene.orca_before_step(
            jnp, peds, d, k))
        everywhere = jax.jit(jax.vmap(env.scene.before_step))
    rng = np.random.default_rng(0)
    for orca_envs in (0, 3, 4, 8):
        pick = np.r_[np.flatnonzero(orca)[:orca_envs], np.flatnonzero(~orca)[:8 - orca_envs]]
        pick = pick[rng.permutation(8)]  # ORCA envs anywhere in the batch
        rods, scene = jax.tree.map(lambda a: a[pick], (pool.rods, pool.scene))
        is_orca = orca[pick]
        want_rods, want_scene = rods, scene
        t = jnp.zeros(8)
        for step in range(3):
            d = jnp.asarray(rng.uniform(0.3, 1.3, 8))
            new_rods, new_scene = gathered(scene, rods, t, d)
            want_rods, want_scene = everywhere(want_scene, want_rods, t, d)
            where = f"{orca_envs} ORCA envs, footstep {step}"
            for a, b in zip(jax.tree.leaves(new_rods), jax.tree.leaves(want_rods)):
                np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=where)
            for a, b, before in zip(jax.tree.leaves(new_scene.pedestrians), jax.tree.leaves(want_scene.pedestrians),
                                    jax.tree.leaves(scene.pedestrians)):
                a, b, before = np.asarray(a), np.asarray(b), np.asarray(before)
                np.testing.assert_array_equal(a[is_orca], b[is_orca], err_msg=where)
                np.testing.assert_array_equal(a[~is_orca], before[~is_orca], err_msg=where)
            walking = np.any(np.asarray(new_rods.velocity) != 0, axis=(1, 2))
            assert np.array_equal(walking & is_orca, is_orca), where  # every ORCA env's pedestrians walk
            rods, scene, t = new_rods, new_scene, t + d
