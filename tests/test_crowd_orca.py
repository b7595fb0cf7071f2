"""The crowd scene's ORCA pedestrians (``crowd_model: orca``; footstep_gym/scenarios/orca.py, crowd.py).

- the adapter against a bare ``pyrvo`` simulator run by hand on a two-agent head-on case, and the
  behaviour ORCA promises there (they pass each other without overlapping);
- every layout makes, resets, steps and replays bit for bit from its seed (also after a pickle);
- ``robot_visible``: seen, the robot bends the pedestrians' paths when in their way; unseen (or out of
  their sight) it changes nothing;
- unknown ``crowd_model`` / ``crowd_layout`` values, speeds above ``max_crowd_speed`` and overlapping
  layouts are rejected by name; gymnasium's ``check_env`` passes.

The scripted crowd's episodes are held bit for bit by tests/test_replay_golden.py.

``python tests/test_crowd_orca.py`` measures env steps/s of the ORCA crowd against the scripted one
(one long-lived env each, random float32 actions in the box, reset at episode end, after warm-up;
the median of 3 interleaved runs).
"""

from __future__ import annotations

import copy
import math
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pyrvo
import pytest
from gymnasium.utils.env_checker import check_env

import footstep_gym  # noqa: F401
from footstep_gym.errors import ConfigError
from footstep_gym.scenarios.orca import OrcaCrowd, OrcaParams

LAYOUTS = ["ring", "counter_flow", "crossing_flows", "closing_in"]
IN_PLACE = np.array([0.0, 0.08, 0.0, 0.6, 0.2])  # stepping in place at the nominal period
F32_ULP = float(np.spacing(np.float32(2.0)))  # one float32 ulp at 2 m


def orca_env(layout="ring", **kw):
    return gym.make("FootstepCrowd-v0", crowd_model="orca", crowd_layout=layout, **kw).unwrapped


def pedestrians(env):
    return [(tuple(m.body.position), tuple(m.body.velocity)) for m in env.scenario.members]


# ====================================================================== the adapter against pyrvo itself
PARAMS = OrcaParams(time_step=0.1, neighbor_dist=2.0, max_neighbors=10, time_horizon=5.0, safety_space=0.01)
HEAD_ON = dict(starts=[(-1.5, 0.01), (1.5, -0.01)], goals=[(1.5, 0.01), (-1.5, -0.01)], radii=[0.08, 0.07],
               speeds=[0.15, 0.2])
#: Footstep durations [s] over 12 s (the env's T ranges from 0.2 to 0.9 s): neither agent reaches its goal.
DURATIONS = [0.8, 0.35, 0.9, 0.2, 0.55, 0.8, 0.4] * 3


def bare_pyrvo_head_on():
    """The two agents of HEAD_ON in a pyrvo simulator driven by hand: per footstep of T, equal steps no longer
    than 0.1 s; before each, the preferred velocity (goal - position) capped at the agent's speed.
    Returns the positions after each footstep and those after every ORCA step."""
    p = PARAMS
    sim = pyrvo.RVOSimulator(p.time_step, p.neighbor_dist, p.max_neighbors, p.time_horizon, p.time_horizon, 0.1, 0.2)
    for start, r, v in zip(HEAD_ON["starts"], HEAD_ON["radii"], HEAD_ON["speeds"]):
        sim.add_agent(start, p.neighbor_dist, p.max_neighbors, p.time_horizon, p.time_horizon, r + p.safety_space, v,
                      (0.0, 0.0))
    per_footstep, per_step = [], []
    for duration in DURATIONS:
        k = math.ceil(round(duration / p.time_step, 9))
        sim.set_time_step(duration / k)
        for _ in range(k):
            for i, ((gx, gy), v) in enumerate(zip(HEAD_ON["goals"], HEAD_ON["speeds"])):
                x, y = sim.get_agent_position(i).to_tuple()
                d = np.hypot(gx - x, gy - y)
                scale = v / d if d > v else 1.0
                sim.set_agent_pref_velocity(i, ((gx - x) * scale, (gy - y) * scale))
            sim.do_step()
            per_step.append([sim.get_agent_position(i).to_tuple() for i in range(2)])
        per_footstep.append(per_step[-1])
    return np.array(per_footstep), np.array(per_step)


def test_adapter_matches_bare_pyrvo_on_two_agents_head_on():
    crowd = OrcaCrowd(HEAD_ON["starts"], HEAD_ON["goals"], HEAD_ON["radii"], HEAD_ON["speeds"], PARAMS)
    mine, chords = [], []
    for duration in DURATIONS:
        start, chord = crowd.advance(duration)
        mine.append(crowd.positions)
        chords.append(chord)
        # The chord carries the body from the footstep's start to ORCA's position at its end (to ORCA's float32
        # rounding: a chord a hair above the agent's speed is clamped to it).
        for (x0, y0), (vx, vy), (x1, y1) in zip(start, chord, crowd.positions):
            assert x0 + vx * duration == pytest.approx(x1, abs=1e-6)
            assert y0 + vy * duration == pytest.approx(y1, abs=1e-6)
    want, _ = bare_pyrvo_head_on()
    np.testing.assert_allclose(np.array(mine), want, rtol=0, atol=4 * F32_ULP)
    # Never faster than the agent's own speed.
    speeds = np.hypot(*np.array(chords).transpose(2, 0, 1))
    assert np.all(speeds <= np.array(HEAD_ON["speeds"]) + 1e-12)


def test_two_agents_head_on_pass_each_other_without_overlapping():
    _, steps = bare_pyrvo_head_on()
    gap = np.hypot(*(steps[:, 0] - steps[:, 1]).T)
    assert gap.min() >= sum(HEAD_ON["radii"])  # ORCA keeps radius + safety apart: the bodies never touch
    x0, x1 = steps[:, 0, 0], steps[:, 1, 0]
    assert x0[0] < x1[0] and x0[-1] > x1[-1] + 0.5  # they passed each other ...
    sideways = np.abs(steps[:, :, 1]).max()
    assert sideways > 0.05  # ... by stepping aside
    crowd = OrcaCrowd(HEAD_ON["starts"], HEAD_ON["goals"], HEAD_ON["radii"], HEAD_ON["speeds"], PARAMS)
    for duration in DURATIONS:
        crowd.advance(duration)
    (a, _), (b, _) = crowd.positions
    assert a > b + 0.5


def test_adapter_survives_pickle_and_deepcopy_exactly():
    crowd = OrcaCrowd(HEAD_ON["starts"], HEAD_ON["goals"], HEAD_ON["radii"], HEAD_ON["speeds"], PARAMS,
                      robot_radius=0.1)
    for duration in DURATIONS[:10]:
        crowd.advance(duration, (0.0, 0.3), (0.05, -0.02))
    clones = [pickle.loads(pickle.dumps(crowd)), copy.deepcopy(crowd)]
    for duration in DURATIONS[10:]:
        want = crowd.advance(duration, (0.0, 0.3), (0.05, -0.02))
        for clone in clones:
            assert clone.advance(duration, (0.0, 0.3), (0.05, -0.02)) == want


# ====================================================================== the env: layouts, replay, visibility
def episode_trace(env, seed, n_steps=60):
    """Everything an episode from ``seed`` shows, step by step: observation bits, reward, info, the bodies.

    Actions: strides forward at varying periods (so episodes last), from a generator of their own.
    """
    actions = np.random.default_rng(seed + 1000)
    obs, info = env.reset(seed=seed)
    trace = [(obs.tobytes(), repr(sorted(info.items())), pedestrians(env))]
    for _ in range(n_steps):
        t_ss = float(actions.uniform(0.2, 0.6))
        a = np.array([actions.uniform(0.0, 0.1), 0.08, 0.0, t_ss, float(actions.uniform(0.1, 0.3))], dtype=np.float32)
        obs, r, term, trunc, info = env.step(a)
        trace.append((obs.tobytes(), r, term, trunc, repr(sorted(info.items())), pedestrians(env)))
        if term or trunc:
            break
    return trace


@pytest.mark.parametrize("visible", [False, True], ids=["unseen", "seen"])
@pytest.mark.parametrize("layout", LAYOUTS)
def test_each_layout_makes_resets_steps_and_replays_bit_for_bit(layout, visible):
    env = orca_env(layout, robot_visible=visible)
    cfg = env.scenario_config
    first = [episode_trace(env, seed) for seed in (0, 1)]
    # The same seeds on the same env (after other episodes), and on a new env: the same bits.
    again = [episode_trace(env, seed) for seed in (0, 1)]
    fresh = orca_env(layout, robot_visible=visible)
    assert first == again == [episode_trace(fresh, seed) for seed in (0, 1)]
    assert first[0][0] != first[1][0]  # other seed, other draws
    # Each pedestrian draws its own radius and speed; they walk, never faster than the range allows.
    env.reset(seed=0)
    members = env.scenario.members
    assert len(members) == cfg.crowd_size
    radii = [m.shape.radius for m in members]
    assert len(set(radii)) == len(radii) and all(cfg.pedestrian_radius[0] <= r <= cfg.pedestrian_radius[1] for r in radii)
    speeds = []
    for _ in range(10):
        env.step(IN_PLACE)
        speeds += [math.hypot(*m.body.velocity) for m in members]
        if env.ended:
            break
    assert max(speeds) > 0.5 * cfg.pedestrian_speed[0]
    assert max(speeds) <= cfg.pedestrian_speed[1] <= cfg.max_crowd_speed


@pytest.mark.parametrize("layout", LAYOUTS)
def test_an_episode_replays_exactly_from_a_pickled_or_deepcopied_env(layout):
    # Cloned after reset (the ORCA simulator is rebuilt from its agents; mid-run: the adapter's test above).
    env = orca_env(layout, robot_visible=True)
    env.reset(seed=4)
    clones = [pickle.loads(pickle.dumps(env)), copy.deepcopy(env)]
    for _ in range(8):
        want = env.step(IN_PLACE)
        for clone in clones:
            got = clone.step(IN_PLACE)
            assert got[0].tobytes() == want[0].tobytes() and got[1:4] == want[1:4]
            assert pedestrians(clone) == pedestrians(env)
        if want[2] or want[3]:
            break


#: One pedestrian walking down the robot's path at it, from 1 m ahead to 1 m behind the start.
HEAD_ON_ENV = dict(crowd_size=1, flow_lanes=1, flow_jitter=0.0, flow_ahead=1.0, flow_behind=1.0,
                   pedestrian_speed=[0.15, 0.15], time_limit=60.0)


def walk_at_robot(visible, action, n_steps=25, **kw):
    env = orca_env("counter_flow", robot_visible=visible, **{**HEAD_ON_ENV, **kw})
    env.reset(seed=0)
    path, ends = [], None
    for _ in range(n_steps):
        _, _, term, trunc, info = env.step(action)
        if term or trunc:  # (a collision stops the world mid-footstep: not a footstep's end)
            ends = info["termination"]
            break
        path.append(pedestrians(env)[0][0])
    return np.array(path), ends


def test_a_seen_robot_in_the_way_bends_the_pedestrians_path():
    unseen, unseen_end = walk_at_robot(False, IN_PLACE)
    seen, seen_end = walk_at_robot(True, IN_PLACE)
    assert unseen_end == "collision"  # it walks straight through where the robot stands ...
    assert np.abs(unseen[:, 1]).max() < 1e-6
    assert np.abs(seen[:, 1]).max() > 0.05  # ... unless it sees the robot: then it steps aside
    assert seen_end != "collision"
    assert seen[:, 0].min() < -0.5  # and walks on past it


def test_an_unseen_robot_or_one_out_of_sight_changes_nothing():
    forward = np.array([0.05, 0.08, 0.0, 0.6, 0.2])  # walking at the pedestrian, at the same period as IN_PLACE
    # Unseen: wherever the robot goes, the pedestrian's path is the same, bit for bit (until the episode ends).
    a, _ = walk_at_robot(False, IN_PLACE)
    b, _ = walk_at_robot(False, forward)
    k = min(len(a), len(b))
    assert k >= 3 and len(a) > k  # (walking at it, the robot meets it sooner)
    np.testing.assert_array_equal(a[:k], b[:k])
    # Seen: the robot's own motion shows in the pedestrian's path.
    seen_a, _ = walk_at_robot(True, IN_PLACE)
    seen_b, _ = walk_at_robot(True, forward)
    k = min(len(seen_a), len(seen_b))
    assert k >= 5 and not np.array_equal(seen_a[:k], seen_b[:k])
    # Out of sight: a lane 1.5 m beside the robot and an ORCA neighbourhood of 1 m; seen or not, the same bits.
    off = dict(flow_lanes=2, lane_width=3.0, orca_neighbor_dist=1.0)
    far_seen, _ = walk_at_robot(True, IN_PLACE, n_steps=20, **off)
    far_unseen, _ = walk_at_robot(False, IN_PLACE, n_steps=20, **off)
    assert len(far_seen) == 20 and np.ptp(far_seen[:, 0]) > 1.0  # it walked past the robot
    np.testing.assert_array_equal(far_seen, far_unseen)


def test_the_orca_crowd_advances_footstep_by_footstep():
    env = orca_env(robot_visible=True)
    env.reset(seed=0)
    with pytest.raises(RuntimeError, match="footstep by footstep"):
        env.scenario.before_step(env.world, 1.0, 0.8)  # not where the last footstep ended (0 s)
    env.scenario.before_step(env.world, 0.0, 0.8)  # no RobotMotion: the robot is not seen this footstep
    env.scenario.before_step(env.world, 0.8, 0.4)


# ====================================================================== config: rejected by name; check_env
@pytest.mark.parametrize("kwargs, names", [
    (dict(crowd_model="social_force"), ["crowd_model", "social_force", "scripted", "orca"]),
    (dict(crowd_model="orca", crowd_layout="spiral"),
     ["crowd_layout", "spiral", "ring", "counter_flow", "crossing_flows", "closing_in"]),
    (dict(crowd_layout="counter_flow"), ["crowd_layout", "counter_flow", "orca"]),  # the scripted crowd is the ring
    (dict(crowd_model="orca", pedestrian_speed=[0.1, 2.5]), ["pedestrian_speed", "max_crowd_speed"]),
    (dict(crowd_model="orca", pedestrian_speed=[-0.1, 0.2]), ["pedestrian_speed"]),
    (dict(crowd_model="orca", pedestrian_radius=[0.0, 0.1]), ["pedestrian_radius"]),
    (dict(crowd_model="orca", crowd_size=12), ["ring_radius", "crowd_size"]),  # members overlap on the ring
    (dict(crowd_model="orca", crowd_layout="closing_in", closing_radius=0.05), ["closing_radius"]),
    (dict(crowd_model="orca", crowd_layout="counter_flow", flow_spacing=0.2), ["flow_spacing"]),
    (dict(crowd_model="orca", crowd_layout="crossing_flows", lane_width=0.1), ["lane_width"]),
    (dict(crowd_model="orca", crowd_layout="counter_flow", flow_ahead=0.2), ["flow_ahead"]),
    (dict(crowd_model="orca", orca_max_neighbors=0), ["orca_max_neighbors"]),
    (dict(crowd_model="orca", orca_time_step=0.0), ["orca_time_step"]),
    (dict(crowd_model="orca", robot_visible="yes"), ["robot_visible"]),
])
def test_bad_crowd_settings_are_rejected_by_name(kwargs, names):
    with pytest.raises(ConfigError) as err:
        gym.make("FootstepCrowd-v0", **kwargs)
    for name in names:
        assert name in str(err.value), (name, str(err.value))


def test_the_scripted_crowd_is_the_default_and_unchanged_by_the_new_keys():
    default = gym.make("FootstepCrowd-v0").unwrapped
    assert default.scenario_config.crowd_model == "scripted"
    explicit = gym.make("FootstepCrowd-v0", crowd_model="scripted", robot_visible=True,
                        pedestrian_speed=[0.1, 0.3], orca_time_step=0.05).unwrapped
    assert episode_trace(default, 3) == episode_trace(explicit, 3)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_gymnasium_check_env_on_the_orca_crowd(layout):
    env = orca_env(layout, robot_visible=layout in ("ring", "crossing_flows"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the SI action box and unbounded observation are by design
        check_env(env)


# ====================================================================== steps/s: python tests/test_crowd_orca.py
def _benchmark(n_steps=3000, repeats=3, warm_up=500):
    import statistics
    import time

    cases = {"scripted": {}, "orca ring, robot unseen": dict(crowd_model="orca", robot_visible=False),
             "orca ring, robot seen": dict(crowd_model="orca", robot_visible=True)}
    for layout in LAYOUTS[1:]:
        cases[f"orca {layout}, robot seen"] = dict(crowd_model="orca", crowd_layout=layout, robot_visible=True)
    envs = {}
    for name, kw in cases.items():
        env = gym.make("FootstepCrowd-v0", **kw).unwrapped
        env.reset(seed=0)
        envs[name] = (env, np.random.default_rng(0))

    def run(name, n):
        env, rng = envs[name]
        lo, hi = env.action_space.low, env.action_space.high
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(n):
            _, _, term, trunc, _ = env.step(rng.uniform(lo, hi).astype(np.float32))
            if term or trunc:
                env.reset()
        return n / (time.perf_counter() - t0), n / (time.process_time() - c0)

    for name in cases:
        run(name, warm_up)
    rates = {name: [] for name in cases}
    for _ in range(repeats):  # interleaved, so a busy machine slows every case alike
        for name in cases:
            rates[name].append(run(name, n_steps))
    # Wall-clock rates, and rates per CPU second of this process (steadier on a shared machine).
    for k, clock in enumerate(("wall", "cpu")):
        base = statistics.median(r[k] for r in rates["scripted"])
        for name, r in rates.items():
            med = statistics.median(x[k] for x in r)
            print(f"{clock:4s} {name:34s} {med:7.0f} steps/s (median of {repeats}: "
                  f"{', '.join(f'{x[k]:.0f}' for x in r)})  {med / base:.2f} x scripted")


if __name__ == "__main__":
    _benchmark()
