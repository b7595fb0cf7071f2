"""Gymnasium API conformance of the three registered envs (footstep_gym/env.py) over the registry.

Gymnasium's and SB3's checkers, ``make`` with a module prefix, vectorisation, pickling, seeded replay
and seeded resets, the info contract, the errors of a step before ``reset``, vector envs resetting
ended episodes by themselves, and the errors from a vector env's workers. References are the YAML
files read directly and hand-made commands, never the code under test.
"""

from __future__ import annotations

import copy
import math
import pickle
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env, data_equivalence

import footstep_gym
from env_helpers import ENV_IDS, NOMINAL, strides


def assert_identical(a, b, path="") -> None:
    """Bit-identical nested data (NaN equal to NaN), types included."""
    assert type(a) is type(b), (path, type(a), type(b))
    if isinstance(a, dict):
        assert list(a) == list(b), path
        for k in a:
            assert_identical(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_identical(x, y, f"{path}[{i}]")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, path
        assert a.tobytes() == b.tobytes(), path
    elif isinstance(a, float):
        assert (math.isnan(a) and math.isnan(b)) or a == b, (path, a, b)
    else:
        assert a == b, (path, a, b)


# ------------------------------------------------------------------ registry and checkers
def test_registry_holds_the_three_ids():
    assert sorted(footstep_gym.ENV_IDS.values()) == sorted(ENV_IDS)
    for env_id in ENV_IDS:
        assert env_id in gym.registry


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_check_env(env_id):
    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the SI action box and unbounded observation are by design
        check_env(env.unwrapped)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_check_env(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    env = gym.make(env_id)
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        # SB3 warns that the action box is not [-1, 1] (documented: SI units, RescaleAction
        # in the baselines); anything that is an error must raise.
        sb3_checker.check_env(env.unwrapped, warn=True)
    env.close()


def test_make_with_module_prefix_in_fresh_process(tmp_path):
    code = (
        "import sys, gymnasium as gym\n"
        "assert 'footstep_gym' not in sys.modules\n"
        "env = gym.make('footstep_gym:FootstepDoor-v0')\n"
        "obs, info = env.reset(seed=0)\n"
        "obs, r, term, trunc, info = env.step(env.action_space.sample())\n"
        "print(obs.shape, type(env.unwrapped).__name__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["(42,)", "FootstepEnv"]


@pytest.mark.parametrize("mode", ["sync", "async"])
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_make_vec(env_id, mode):
    envs = gym.make_vec(env_id, num_envs=4, vectorization_mode=mode)
    try:
        obs, info = envs.reset(seed=123)
        assert obs.shape == (4, 42) and obs.dtype == np.float32
        assert obs in envs.observation_space
        assert len({o.tobytes() for o in obs}) == 4  # seeds 123..126 draw four different episodes
        envs.action_space.seed(5)
        for _ in range(4):
            obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
            assert obs.shape == (4, 42) and reward.shape == (4,)
            assert terminated.dtype == bool and truncated.dtype == bool
            assert np.all(np.isfinite(obs)) and np.all(np.isfinite(reward))
    finally:
        envs.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
@pytest.mark.parametrize("clone", [lambda e: pickle.loads(pickle.dumps(e)), copy.deepcopy], ids=["pickle", "deepcopy"])
def test_pickle_and_deepcopy_after_reset(env_id, clone):
    env = gym.make(env_id)
    env.reset(seed=11)
    env.step(NOMINAL)
    twin = clone(env)
    # Gymnasium's own shape: the clone continues exactly as the original.
    assert data_equivalence(env.reset(), twin.reset())
    for action in [NOMINAL, *strides(0.03, 0.05)]:
        a, b = env.step(action), twin.step(action)
        assert data_equivalence(a, b)
    assert twin.unwrapped.world is not env.unwrapped.world
    env.close()
    twin.close()


# ------------------------------------------------------------------ seeding by replay
def rollout(env, seed, actions):
    trace = [env.reset(seed=seed)]
    for action in actions:
        obs, reward, terminated, truncated, info = env.step(action)
        trace.append((obs, reward, terminated, truncated, info))
        if terminated or truncated:
            trace.append(env.reset())  # no seed: the episode generator carries on
    return trace


def random_actions(space, n, seed):
    space = copy.deepcopy(space)
    space.seed(seed)
    return [space.sample() for _ in range(n)]


def near_nominal_actions(n, seed):
    rng = np.random.default_rng(seed)
    return [np.array([rng.uniform(0.0, 0.05), rng.uniform(0.075, 0.09), rng.uniform(-0.05, 0.05),
                      rng.uniform(0.5, 0.6), rng.uniform(0.18, 0.22)]) for _ in range(n)]


@pytest.mark.parametrize("kind", ["random", "near_nominal"])
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_same_seed_same_actions_replays_bit_identically(env_id, kind):
    env_a, env_b = gym.make(env_id), gym.make(env_id)
    actions = (random_actions(env_a.action_space, 40, seed=3) if kind == "random"
               else near_nominal_actions(40, seed=4))
    trace_a = rollout(env_a, 2024, actions)
    trace_b = rollout(env_b, 2024, actions)
    assert_identical(trace_a, trace_b)
    # The same env, reset again with the same seed, replays too.
    assert_identical(rollout(env_a, 2024, actions), trace_a)
    # And a different seed gives a different trace.
    trace_c = rollout(env_a, 2025, actions)
    assert any(not np.array_equal(x[0], y[0]) for x, y in zip(trace_a, trace_c))


def layout(env):
    """Every obstacle's pose and velocity after reset, and the robot's CoM."""
    snap = env.unwrapped.sensing()
    return [(o.name, o.position, o.angle, o.velocity, o.angular_velocity) for o in snap.obstacles], snap.com


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_seeded_reset_repeats_and_unseeded_reset_moves_on(env_id):
    env = gym.make(env_id)
    env.reset(seed=7)
    first = layout(env)
    env.reset()
    second = layout(env)
    env.reset(seed=7)
    assert layout(env) == first
    assert second != first
    env.reset(seed=8)
    assert layout(env) != first


# ------------------------------------------------------------------ the info contract
INFO_TYPES = {
    "is_success": bool, "feasible": bool, "collision": bool, "clipped": bool,
    "time": float, "period": float, "rewards": dict,
}


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_info_keys_on_every_step(env_id):
    env = gym.make(env_id)
    actions = near_nominal_actions(25, seed=1) + random_actions(env.action_space, 25, seed=2)
    _, info = env.reset(seed=5)
    assert len(info["com"]) == 2 and len(info["com_vel"]) == 2
    last_time = 0.0
    terminations = set()
    for action in actions:
        _, reward, terminated, truncated, info = env.step(action)
        for key, typ in INFO_TYPES.items():
            assert type(info[key]) is typ, (key, info[key])
        assert info["termination"] in {"goal", "collision", "fall", None}
        assert terminated == (info["termination"] is not None)
        assert info["is_success"] == (info["termination"] == "goal")
        assert info["collision"] == (info["termination"] == "collision")
        assert info["feasible"] == (info["termination"] != "fall")
        assert info["support_foot"] in {"left", "right"}
        assert len(info["foot_pose"]) == 3 and all(math.isfinite(v) for v in info["foot_pose"])
        for key in ("zmp", "com", "com_vel"):
            assert len(info[key]) == 2 and all(math.isfinite(v) for v in info[key]), key
        assert sum(info["rewards"].values()) == pytest.approx(reward, abs=1e-12)
        cmd = info["command"]
        assert info["period"] == pytest.approx(cmd[3] + cmd[4])
        assert info["time"] >= last_time
        assert info["time"] <= last_time + info["period"] + 1e-12
        last_time = info["time"]
        terminations.add(info["termination"])
        if terminated or truncated:
            _, info = env.reset()
            assert len(info["com"]) == 2 and len(info["com_vel"]) == 2
            last_time = 0.0
    assert None in terminations and "fall" in terminations  # both kinds of step were seen


# ------------------------------------------------------------------ errors before reset
def test_step_before_reset_raises():
    env = gym.make("FootstepDoor-v0").unwrapped
    with pytest.raises(gym.error.ResetNeeded):
        env.step(NOMINAL)
    with pytest.raises(gym.error.ResetNeeded):
        env.sensing()


# ------------------------------------------------------------------ vector envs after the end
@pytest.mark.parametrize("mode", ["sync", "async"])
@pytest.mark.parametrize("env_id", ["FootstepCrossing-v0", "FootstepMix-v0"])
def test_vector_envs_reset_ended_episodes_by_themselves(env_id, mode):
    """Gymnasium's NEXT_STEP autoreset: the step after an end resets that sub-env, so nothing raises."""
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode=mode,
                        vector_kwargs={"autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP})
    try:
        envs.reset(seed=0)
        envs.action_space.seed(0)
        ended = 0
        for _ in range(30):  # random commands fall within a few steps
            _, reward, terminated, truncated, _ = envs.step(envs.action_space.sample())
            ended += int(np.sum(terminated | truncated))
            assert np.all(np.isfinite(reward))
        assert ended >= 4
    finally:
        envs.close()


@pytest.mark.parametrize("vec", ["dummy", "subproc"])
def test_sb3_vec_envs_reset_ended_episodes_by_themselves(vec):
    sb3_vec = pytest.importorskip("stable_baselines3.common.vec_env")
    fns = [lambda: gym.make("FootstepDoor-v0") for _ in range(2)]
    envs = sb3_vec.DummyVecEnv(fns) if vec == "dummy" else sb3_vec.SubprocVecEnv(fns, start_method="fork")
    try:
        envs.seed(0)
        envs.reset()
        rng = np.random.default_rng(0)
        space = envs.action_space
        dones = 0
        for _ in range(30):
            actions = rng.uniform(space.low, space.high, (2, 5)).astype(np.float32)
            _, reward, done, _ = envs.step(actions)
            dones += int(done.sum())
            assert np.all(np.isfinite(reward))
        assert dones >= 4
    finally:
        envs.close()


# ------------------------------------------------------------------ errors from a vector env's workers
@pytest.mark.parametrize("env_id, name", [("FootstepDoor-v0", "FootstepDoor-v0"),
                                          ("FootstepMix-v0", r"FootstepMix-v0 \(scene '\w+'\)")])
def test_async_worker_error_names_the_env_and_the_error(env_id, name):
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="async")
    try:
        envs.reset(seed=0)
        actions = np.tile(NOMINAL.astype(np.float32), (2, 1))
        actions[1, 3] = np.nan
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with pytest.raises(footstep_gym.ActionError,
                               match=rf"^{name}: action has non-finite field\(s\): t_ss=nan$"):
                envs.step(actions)
    finally:
        envs.close(terminate=True)
    # Gymnasium reports (as warnings) which worker failed, with the worker's traceback.
    logged = "\n".join(str(w.message) for w in caught)
    assert "Worker-1" in logged and "footstep_gym.errors.ActionError" in logged
