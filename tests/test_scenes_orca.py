"""ORCA as array functions (footstep_gym/scenes/orca.py) against pyrvo (RVO2), the oracle.

- one ``doStep`` from the same agent states (positions, velocities, preferred velocities, radii, speeds): the new
  velocities and positions are pyrvo's bit for bit (RVO2 computes in float32), under numpy and under ``jax.jit``,
  on random crowds packed so that agents overlap (RVO2's collision case) and the 2-D program fails (the 3-D
  fallback), with padded inactive agents;
- footsteps of recorded crowds, every layout of the benchmark's ORCA cells and the ring with the robot seen:
  :func:`orca.advance` gives :meth:`OrcaCrowd.advance`'s start positions and chords exactly, footstep after
  footstep, in numpy (exactly) and in JAX (float64, as the reference's Python: ORCA's positions exactly, the chords
  within float64 rounding: JAX's ``hypot`` is not CPython's).
"""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pyrvo
import pytest

import footstep_gym  # noqa: F401
from footstep_gym.scenes import orca

N_MAX = 10


def pyrvo_step(a: orca.Agents, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """pyrvo's doStep from ``a``'s active agents: their new positions and velocities."""
    sim = pyrvo.RVOSimulator(float(dt), 1.0, 1, 1.0, 1.0, 0.1, 1.0)
    idx = np.flatnonzero(a.active)
    for i in idx:
        sim.add_agent(tuple(map(float, a.position[i])), float(a.neighbor_dist[i]), int(a.max_neighbors[i]),
                      float(a.time_horizon[i]), float(a.time_horizon[i]), float(a.radius[i]), float(a.max_speed[i]),
                      tuple(map(float, a.velocity[i])))
    for j, i in enumerate(idx):
        sim.set_agent_pref_velocity(j, tuple(map(float, a.pref_velocity[i])))
    sim.do_step()
    return (np.array([sim.get_agent_position(j).to_tuple() for j in range(len(idx))], np.float32),
            np.array([sim.get_agent_velocity(j).to_tuple() for j in range(len(idx))], np.float32))


def random_agents(rng: np.random.Generator) -> orca.Agents:
    """2 to 10 active agents packed into a square of 0.2-3 m (overlaps included), the rest inactive padding."""
    n = int(rng.integers(2, N_MAX + 1))
    f32 = np.float32
    pos = (rng.uniform(-1, 1, (N_MAX, 2)) * rng.uniform(0.1, 1.5)).astype(f32)
    pos[n:] = 1.0e6  # padding: parked, all at one place
    return orca.Agents(pos, rng.normal(0, 0.2, (N_MAX, 2)).astype(f32), rng.normal(0, 0.2, (N_MAX, 2)).astype(f32),
                       rng.uniform(0.05, 0.15, N_MAX).astype(f32), rng.uniform(0.1, 0.3, N_MAX).astype(f32),
                       rng.uniform(0.5, 2.5, N_MAX).astype(f32), rng.uniform(1.0, 6.0, N_MAX).astype(f32),
                       rng.integers(0, 11, N_MAX).astype(np.int32), np.arange(N_MAX) < n)


def test_one_orca_step_is_pyrvos_bit_for_bit_in_numpy_and_jax():
    import jax
    import jax.numpy as jnp

    rng = np.random.default_rng(0)
    step = jax.jit(lambda a, dt: orca.do_step(a, dt, N_MAX - 1, jnp))
    collisions = fallbacks = 0
    for _ in range(120):
        a = random_agents(rng)
        dt = float(rng.uniform(0.02, 0.1))
        ref_pos, ref_vel = pyrvo_step(a, dt)
        act = a.active
        with np.errstate(all="raise"):
            ours = orca.do_step(a, dt, N_MAX - 1)
        assert np.array_equal(ours.position[act], ref_pos) and np.array_equal(ours.velocity[act], ref_vel)
        assert np.array_equal(ours.position[~act], a.position[~act])  # padding stays
        jx = step(jax.tree.map(jnp.asarray, a), np.float32(dt))
        assert np.array_equal(np.asarray(jx.position)[act], ref_pos)
        assert np.array_equal(np.asarray(jx.velocity)[act], ref_vel)
        # What the states exercised: overlapping pairs (the collision case) and the 3-D program.
        order, valid = orca.neighbors(a, N_MAX - 1)
        p = a.position[act]
        r = a.radius[act]
        d2 = ((p[:, None] - p[None]) ** 2).sum(-1)
        collisions += int((d2 < (r[:, None] + r[None]) ** 2).sum() - act.sum()) // 2
        lines = orca.orca_lines(a, order, valid, np.float32(dt))
        failed = orca.linear_program2(lines, valid, a.max_speed, tuple(a.pref_velocity.T), False)[0]
        fallbacks += int(failed[act].sum())
    assert collisions > 50 and fallbacks > 50, (collisions, fallbacks)


CELLS = [("structure", "counter_flow", None), ("structure", "crossing_flows", None), ("structure", "closing_in", None),
         (None, "ring", True)]


def reference_crowd(tier, cell, visible, seed):
    """The reference env's OrcaCrowd for an episode of ``cell`` (a copy) and the robot's radius as ORCA sees it."""
    if tier is None:
        env = gym.make("FootstepCrowd-v0", crowd_model="orca", crowd_layout=cell, robot_visible=visible).unwrapped
    else:
        env = gym.make("FootstepCrowd-v0", tier=tier, tier_cell=cell).unwrapped
    env.reset(seed=seed)
    return copy.deepcopy(env.scenario.orca)


def crowd_from(oc, xp=np) -> orca.Crowd:
    """:class:`orca.Crowd` holding ``oc``'s state (its simulator's agents, goals, origins)."""
    sim, p = oc._sim, oc.params
    m = sim.get_num_agents()
    n = len(oc.radii)
    robot = oc.robot_radius is not None
    crowd = orca.crowd_of(oc.positions, oc.goals, oc.radii, oc.speeds, p.neighbor_dist, p.max_neighbors,
                          p.time_horizon, p.safety_space, oc.robot_radius, xp=xp)
    agents = crowd.agents._replace(
        position=xp.asarray([sim.get_agent_position(i).to_tuple() for i in range(m)], dtype=xp.float32),
        velocity=xp.asarray([sim.get_agent_velocity(i).to_tuple() for i in range(m)], dtype=xp.float32))
    assert m == n + int(robot)
    return crowd._replace(agents=agents, origin=xp.asarray(oc.origins, dtype=xp.float64))


@pytest.mark.parametrize("tier,cell,visible", CELLS)
def test_footsteps_of_recorded_crowds_are_the_references(x64, tier, cell, visible):
    import jax
    import jax.numpy as jnp

    rng = np.random.default_rng(7)
    oc = reference_crowd(tier, cell, visible, seed=11)
    p = oc.params
    ours = crowd_from(oc)
    k = orca.neighbor_slots(ours.agents.max_neighbors, ours.agents.position.shape[0])
    jstep = jax.jit(lambda c, d, r: orca.advance(c, d, p.time_step, 9, r, k, jnp))
    jours = jax.tree.map(jnp.asarray, ours)
    closest = np.inf
    for step in range(60):
        duration = float(rng.uniform(0.2, 0.9))
        robot = None
        if visible:
            robot = ((float(rng.uniform(-0.2, 3.0)), float(rng.uniform(-0.4, 0.4))),
                     (float(rng.normal(0, 0.15)), float(rng.normal(0, 0.05))))
            start, chords = oc.advance(duration, *robot)
        else:
            start, chords = oc.advance(duration)
        ours, s, c = orca.advance(ours, duration, p.time_step, 9, robot, k)
        assert np.array_equal(s, np.asarray(start)) and np.array_equal(c, np.asarray(chords)), (cell, step)
        jrobot = None if robot is None else jax.tree.map(jnp.asarray, robot)
        jours, js, jc = jstep(jours, jnp.asarray(duration), jrobot)
        # JAX's float64 hypot is not CPython's math.hypot (correctly rounded): chords within float64 rounding.
        assert np.array_equal(np.asarray(js), s), (cell, step)
        assert np.abs(np.asarray(jc) - c).max() <= 4 * np.finfo(np.float64).eps, (cell, step)
        assert np.array_equal(np.asarray(jours.agents.position), ours.agents.position), (cell, step)
        n = len(oc.radii)
        pos = np.asarray(oc.positions)
        gaps = np.hypot(*(pos[:, None] - pos[None]).transpose(2, 0, 1)) - (np.add.outer(oc.radii, oc.radii))
        closest = min(closest, float(gaps[~np.eye(n, dtype=bool)].min()))
    assert np.array_equal(ours.agents.position[:len(oc.radii)], np.asarray(oc.positions, np.float32))
    assert closest < 0.1  # the crowd came near contact (ORCA keeps its safety space of 1 cm per agent)


def _programs(seed: int, crowds: int, n: int = 12, k: int = 8):
    """Random ORCA lines of ``crowds`` crowds (unit directions, up to 3 lines each, so that the
    2-D program fails for some agents) and where each agent's 3-D program begins (``k``: its 2-D program did not fail)."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(-np.pi, np.pi, (crowds, n, k))
    lines = tuple(a.astype(np.float32) for a in (rng.normal(0, 0.5, (crowds, n, k)), rng.normal(0, 0.5, (crowds, n, k)),
                                                np.cos(theta), np.sin(theta)))
    valid = np.arange(k) < rng.integers(0, 4, (crowds, n, 1))  # the first count slots, as neighbours fill them
    radius = rng.uniform(0.05, 0.6, (crowds, n)).astype(np.float32)
    opt = tuple(rng.normal(0, 0.5, (crowds, n)).astype(np.float32) for _ in range(2))
    out = [orca.linear_program2(tuple(a[c] for a in lines), valid[c], radius[c], (opt[0][c], opt[1][c]), False)
           for c in range(crowds)]
    failed = np.stack([o[0] for o in out])
    begin = np.where(failed, np.stack([o[1] for o in out]), k).astype(np.int32)
    x, y = np.stack([o[2] for o in out]), np.stack([o[3] for o in out])
    return lines, valid, begin, radius, x, y


@pytest.mark.parametrize("slots", [None, 1])  # the gathered rows, and more failing agents than rows
def test_the_batched_3d_program_runs_on_the_failing_agents_with_each_ones_own_result(monkeypatch, slots):
    import jax

    if slots is not None:
        monkeypatch.setattr(orca, "_failing_slots", lambda agents: slots)
        monkeypatch.setattr(orca, "_PROGRAM3", [])  # traced afresh with the patched rows
    lines, valid, begin, radius, x, y = _programs(7, crowds=16)
    failing = int(np.sum(begin < valid.shape[2]))
    assert 1 < failing < begin.size // 2  # some crowds' agents fail, most do not
    got = jax.jit(jax.vmap(orca.program3(jax.numpy)))(lines, valid, begin, radius, x, y)
    for c in range(begin.shape[0]):  # each crowd alone, in numpy
        want = orca.linear_program3(tuple(a[c] for a in lines), valid[c], begin[c], radius[c], x[c], y[c])
        np.testing.assert_array_equal(np.asarray(got[0][c]), want[0])
        np.testing.assert_array_equal(np.asarray(got[1][c]), want[1])
    moved = (np.asarray(got[0]) != x) | (np.asarray(got[1]) != y)
    assert moved.any() and not moved[begin == valid.shape[2]].any()  # only failing agents move


@pytest.mark.parametrize("slots", [None, 1])  # the gathered rows (rows 12), and more violating agents than rows
def test_the_batched_2d_program_runs_each_line_on_its_violating_agents_with_each_ones_own_result(monkeypatch, slots):
    import jax

    if slots is not None:
        monkeypatch.setattr(orca, "_violating_slots", lambda agents: slots)
    monkeypatch.setattr(orca, "_PROGRAM2", [])  # traced afresh with the patched rows
    crowds, n, k = 16, 12, 8
    rng = np.random.default_rng(0)
    theta = rng.uniform(-np.pi, np.pi, (crowds, n, k))
    lines = tuple(a.astype(np.float32) for a in (rng.normal(0, 0.5, (crowds, n, k)), rng.normal(0, 0.5, (crowds, n, k)),
                                                np.cos(theta), np.sin(theta)))
    valid = np.arange(k) < rng.integers(0, k + 1, (crowds, n, 1))  # the first count slots, as neighbours fill them
    radius = rng.uniform(0.05, 0.6, (crowds, n)).astype(np.float32)
    opt = tuple(rng.normal(0, 0.3, (crowds, n)).astype(np.float32) for _ in range(2))
    violating = np.zeros(k, int)  # per line, the batch's agents that violate it (numpy, crowd by crowd)

    def counted(violated, *args):
        violating[args[2]] += np.sum(violated)
        return orca.linear_program1(*args)

    want = [orca.linear_program2(tuple(a[c] for a in lines), valid[c], radius[c], (opt[0][c], opt[1][c]), False, np,
                                 counted) for c in range(crowds)]
    rows = orca._violating_slots(crowds * n)
    # Lines no agent violates, lines within the rows, lines over them; 2-D programs failing and not.
    assert (violating == 0).any() and ((0 < violating) & (violating <= rows)).any() and (violating > rows).any()
    assert 0 < sum(int(w[0].sum()) for w in want) < crowds * n
    got = jax.jit(jax.vmap(orca.program2(jax.numpy)))(lines, valid, radius, opt)
    for c in range(crowds):
        for g, w in zip(got, want[c]):
            np.testing.assert_array_equal(np.asarray(g[c]), w)


def test_the_nearest_neighbours_are_a_stable_sorts_first_columns_ties_and_infinities_included():
    """``orca._nearest`` (ranks by comparison) against numpy's stable argsort, in numpy and under JAX's ``vmap``, on
    rows with repeated values (ties broken by index, as RVO2 visits a leaf's agents) and ``inf`` (no candidate)."""
    import jax
    import jax.numpy as jnp

    rng = np.random.default_rng(3)
    keys = rng.integers(0, 4, (50, 10, 10)).astype(np.float32)  # many ties
    keys[rng.random(keys.shape) < 0.3] = np.inf
    keys[:, :, 0] = np.inf  # a column of equal infinities
    k = 9
    want = np.argsort(keys, axis=-1, kind="stable")[..., :k]
    got_np = np.stack([orca._nearest(np, row, k) for row in keys])
    got_jax = np.asarray(jax.jit(jax.vmap(lambda r: orca._nearest(jnp, r, k)))(keys))
    np.testing.assert_array_equal(got_np, want)
    np.testing.assert_array_equal(got_jax, want)
