"""ppo-jax: the Brax adapter of the JAX door, its config, a tiny training, shipping, and the shipped agents playing
through the reference env (the judge) as every other agent does."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import yaml
from brax.envs.base import Env as BraxEnv
from brax.envs.base import State as BraxState

import footstep_gym
from footstep_gym.errors import ConfigError
from footstep_gym.rl import ppo_jax as ppo
from footstep_gym.rl.brax_env import FootstepBraxEnv, action_to_command, rescaling, wrap_for_training
from footstep_gym.jax.env import FootstepJaxEnv
from footstep_gym.jax.scenes import SCENES
from footstep_gym.policy import Policy
from footstep_gym.rl import ZooAgent, agent_runs
from footstep_gym.robot import load_robot

REPO = Path(__file__).resolve().parent.parent
ENV_ID = "FootstepDoor-v0"


@pytest.fixture(scope="module")
def benv() -> FootstepBraxEnv:
    return FootstepBraxEnv(FootstepJaxEnv("door", tier="train"))


# ---------------------------------------------------------------- the action mapping
def test_the_action_maps_to_the_command_as_rescale_action_and_sb3_send_it(benv):
    """Gymnasium's RescaleAction(-1, 1) on the reference env is the oracle, bit for bit, clipping included."""
    ref = gym.wrappers.RescaleAction(gym.make(ENV_ID, tier="train"), np.full(5, -1.0, np.float32),
                                     np.full(5, 1.0, np.float32))
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1.3, 1.3, (2000, 5)).astype(np.float32)
    actions[:5] = [[-1] * 5, [1] * 5, [0] * 5, [-1.5] * 5, [2.0] * 5]
    clipped = np.clip(actions, -1, 1)  # what SB3 sends a Box env
    want = np.stack([ref.action(a) for a in clipped])
    gradient, intercept = rescaling(ref.unwrapped.action_space)
    got_np = action_to_command(actions, gradient, intercept, xp=np)
    got_jax = np.asarray(jax.jit(benv.command)(jnp.asarray(actions)))
    assert want.dtype == got_np.dtype == got_jax.dtype == np.float32
    np.testing.assert_array_equal(got_np, want)
    np.testing.assert_array_equal(got_jax, want)
    ref.close()


# ---------------------------------------------------------------- the adapter
def test_the_adapter_obeys_brax_env_and_matches_footstep_jax_env(benv):
    assert isinstance(benv, BraxEnv) and benv.observation_size == 42 and benv.action_size == 5
    jenv = benv.env
    key = jax.random.PRNGKey(3)
    state = jax.jit(benv.reset)(key)
    assert isinstance(state, BraxState) and state.obs.shape == (42,) and float(state.done) == 0.0
    # The footstep env itself, from the same key: the adapter's episode is its.
    p = jenv.default_params
    js, jobs = jenv.reset(key, p)
    np.testing.assert_allclose(np.asarray(state.obs), np.asarray(jobs), rtol=0, atol=1e-5)
    step = jax.jit(benv.step)

    @jax.jit
    def jstep(s, a):  # the adapter's step: its randomness split off the episode's stream
        key, k_step, _ = jax.random.split(s.key, 3)
        return jenv.step(k_step, s._replace(key=key), a, p)

    rng = np.random.default_rng(1)
    ended = False
    for i in range(40):
        a = jnp.asarray(rng.uniform(-0.2, 0.2, 5).astype(np.float32)).at[0].set(0.4)  # walk forward
        state = step(state, a)
        js, jobs, r, term, trunc, info = jstep(js, benv.command(a))
        # Two compiled functions may round a float an ulp apart (XLA fuses each its own way); endings exactly.
        np.testing.assert_allclose(np.asarray(state.obs), np.asarray(jobs), rtol=0, atol=1e-5)
        assert float(state.reward) == pytest.approx(float(r), abs=1e-5) and state.reward.dtype == jnp.float32
        assert float(state.done) == float(term | trunc)
        assert float(state.info["truncation"]) == float(trunc)
        assert int(state.info["termination"]) == int(info["termination"])
        assert float(state.info["episode_metrics"]["length"]) == i + 1
        if float(state.done):
            ended = True
            break
    assert ended, "a forward walk ends (goal, door or fall) within 40 footsteps"


def test_the_training_batch_resets_an_ended_episode_in_the_same_step_and_chunks_change_nothing(benv):
    n = 128
    keys = jax.random.split(jax.random.PRNGKey(0), n)
    chunked, plain = wrap_for_training(benv, chunk=64), wrap_for_training(benv, chunk=1024)
    state = jax.jit(chunked.reset)(keys)
    actions = jnp.asarray(np.random.default_rng(2).uniform(-1.2, 1.2, (n, 5)).astype(np.float32))
    a, b = jax.jit(chunked.step)(state, actions), jax.jit(plain.step)(state, actions)
    np.testing.assert_array_equal(np.asarray(a.done), np.asarray(b.done))
    np.testing.assert_allclose(np.asarray(a.obs), np.asarray(b.obs), rtol=0, atol=1e-5)
    done = np.asarray(a.done) > 0
    assert 0 < done.sum() < n  # random actions: some envs fall at once, some step on
    # An ended env holds a fresh episode drawn from its footstep state's key (the third of its split, the JAX env's
    # autoreset); one that goes on holds its stepped one.
    fresh = jax.vmap(benv.reset)(jax.vmap(lambda k: jax.random.split(k, 3))(state.pipeline_state.key)[:, 2])
    single = jax.vmap(benv.step)(state, actions)
    np.testing.assert_allclose(np.asarray(a.obs)[done], np.asarray(fresh.obs)[done], rtol=0, atol=1e-5)
    np.testing.assert_allclose(np.asarray(a.obs)[~done], np.asarray(single.obs)[~done], rtol=0, atol=1e-5)
    np.testing.assert_allclose(np.asarray(a.reward), np.asarray(single.reward), rtol=0, atol=1e-5)
    assert np.all(np.asarray(a.pipeline_state.steps)[done] == 0)
    with pytest.raises(ValueError, match="action_repeat must be 1"):
        wrap_for_training(benv, action_repeat=2)


# ---------------------------------------------------------------- the config
def raw_config() -> dict:
    return yaml.safe_load(ppo.default_config_path().read_text(encoding="utf-8"))[ENV_ID]


def test_the_shipped_config_loads():
    cfg = ppo.load_config(ENV_ID)
    assert cfg.env_kwargs == {"tier": "train"} and cfg.steps_per_update <= cfg.num_timesteps


@pytest.mark.parametrize("key, value, message", [
    ("num_envs", 0, "num_envs must be a whole number >= 1, got 0"),
    ("num_timesteps", 2.5, "num_timesteps must be a whole number >= 1"),
    ("learning_rate", -1e-3, "learning_rate must be a number > 0"),
    ("discounting", 1.5, "discounting must be in \\(0, 1\\]"),
    ("activation", "sigmoid", "activation must be one of tanh, relu, swish, elu"),
    ("policy_hidden_layer_sizes", [], "policy_hidden_layer_sizes must be a non-empty list"),
    ("normalize_observations", "yes", "normalize_observations must be true or false"),
    ("num_minibatches", 3, "must be a multiple of num_envs"),
    ("num_timesteps", 10, "less than one PPO update's env steps"),
    ("env_kwargs", [1], "env_kwargs must be a mapping"),
])
def test_a_bad_config_value_is_one_error_naming_the_key(key, value, message):
    with pytest.raises(ConfigError, match=message):
        ppo.parse_config(dict(raw_config(), **{key: value}), ENV_ID)


def test_unknown_and_missing_keys_and_entries_are_named(tmp_path):
    with pytest.raises(ConfigError, match="unknown key\\(s\\) lr"):
        ppo.parse_config(dict(raw_config(), lr=1.0), ENV_ID)
    raw = raw_config()
    del raw["chunk"]
    with pytest.raises(ConfigError, match="missing key\\(s\\) chunk"):
        ppo.parse_config(raw, ENV_ID)
    with pytest.raises(ConfigError, match="no entry for 'FootstepMix-v0'"):
        ppo.load_config("FootstepMix-v0")
    with pytest.raises(ConfigError, match="not found"):
        ppo.load_config(ENV_ID, tmp_path / "none.yml")


# ---------------------------------------------------------------- a tiny training, loaded and shipped
TINY = dict(num_timesteps=600, num_envs=16, unroll_length=4, batch_size=16, num_minibatches=2,
            num_updates_per_batch=1, num_evals=2, validation_episodes=2,
            policy_hidden_layer_sizes=[8], value_hidden_layer_sizes=[8], chunk=8)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    cfg = ppo.parse_config(dict(raw_config(), **TINY), ENV_ID)
    seen, patched = [], []

    def progress(*a):
        seen.append(a)
        patched.append(hasattr(jax, "device_put_replicated"))  # JAX 0.10 has none, and training adds none

    result = ppo.train(cfg, 7, progress=progress)
    assert patched == [False] * len(seen)
    run = ppo.write_run(result, tmp_path_factory.mktemp("runs"), "test")
    return result, run, seen


def test_a_tiny_training_writes_a_run_that_loads_as_an_agent(tiny_run):
    result, run, seen = tiny_run
    # 600 asked: Brax trains whole updates of 16 envs x 4 steps x 2 minibatches = 128 env steps, 5 of them; what is
    # trained, planned (and printed by train_jax.py) and recorded (config.yml, args.yml) is that one number.
    assert [s for s, _, _ in seen] == [0, result.timesteps] and result.timesteps == 640
    assert ppo.planned(ppo.parse_config(dict(raw_config(), **TINY), ENV_ID)).num_timesteps == 640
    assert result.config.num_timesteps == 640
    recorded = [yaml.safe_load((run / ENV_ID / name).read_text())["n_timesteps"] for name in ("config.yml", "args.yml")]
    assert recorded == [640, 640]
    assert all(0 <= rate <= 1 for _, _, rate in seen) and result.wall_time_s > 0 and result.cpu_time_s > 0
    assert run.name == f"{ENV_ID}_7" and (run / f"{ENV_ID}.zip").is_file()
    rows = (run / "validation.csv").read_text().splitlines()
    assert rows[0] == "timesteps,wall_time_s,success_rate,episodes,cpu_time_s" and len(rows) == 3
    model = ppo.BraxPPO.load(run / f"{ENV_ID}.zip")
    obs = np.random.default_rng(0).normal(size=(3, 42)).astype(np.float32)
    np.testing.assert_array_equal(model.predict(obs)[0], result.model.predict(obs)[0])  # saved as trained
    agent = footstep_gym.make_policy("ppo-jax", load_robot(), seed=0, run=run)
    assert isinstance(agent, ZooAgent) and agent.algo == "ppo_jax" and agent.normalizer is None
    command = agent.act(obs[0])
    gradient, intercept = rescaling(gym.make(ENV_ID).unwrapped.action_space)
    np.testing.assert_array_equal(command, action_to_command(model.predict(obs[0])[0], gradient, intercept, xp=np))


def test_shipping_copies_the_run_and_refuses_to_overwrite(tiny_run, tmp_path, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("train_jax", REPO / "baselines" / "train_jax.py")
    train_jax = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(train_jax)
    result, run, _ = tiny_run
    dest = ppo.ship(run, result, tmp_path)
    assert dest == tmp_path / "ppo-jax" / f"{ENV_ID}_7"
    m = json.loads((dest / "manifest.json").read_text())
    assert m["algorithm"] == "ppo_jax" and m["agent"] == "ppo-jax" and m["seed"] == 7 and m["versions"]["brax"]
    assert m["final_eval_on"] == "validation split" and m["wall_time_s"] > 0
    assert agent_runs("ppo-jax", ENV_ID, tmp_path) == [dest]
    paths = train_jax.write_report(tmp_path, tmp_path / "results", ENV_ID, "ppo")
    assert [p.name for p in paths] == ["ppo_jax_door.json", "ppo_jax_door.md", "ppo_jax_door_curves.png"]
    figures = json.loads(paths[0].read_text())
    assert [r["seed"] for r in figures["ppo-jax"]] == [7] and figures["ppo"] == []
    assert figures["ppo-jax"][0]["curve"]["success"] == [rate for _, _, rate, _ in result.curve]
    assert "| ppo-jax | 7 | " in paths[1].read_text()
    before = {p: p.stat().st_mtime_ns for p in dest.rglob("*")}
    # A second training of a shipped seed is refused before it trains, nothing touched.
    # The scene's name is taken as eval_planner.py takes it; the first line says what would be trained, rounded up.
    code = train_jax.main(["--env", "door", "--timesteps", "40000", "--seeds", "3", "7", "--ship", "--agents-dir",
                           str(tmp_path), "--runs-dir", str(tmp_path / "runs")])
    out = capsys.readouterr()
    assert code == 2 and "already shipped, not replaced (--force replaces them)" in out.err
    assert out.out.startswith(f"{ENV_ID}: 40,960 env steps (40,000 asked, rounded up): 10 PPO updates of 4,096 env "
                              "steps, 11 validation points, 256 envs on "), out.out
    assert {p: p.stat().st_mtime_ns for p in dest.rglob("*")} == before and not (tmp_path / "runs").exists()
    with pytest.raises(SystemExit):
        train_jax.main(["--force"])
    with pytest.raises(SystemExit):
        train_jax.main(["--env", "lift"])
    assert "--env: unknown env 'lift'; choose from door" in capsys.readouterr().err
    assert train_jax.build_parser().parse_args([]).seeds == [1]  # a quick try trains one seed


# ---------------------------------------------------------------- an agent judged in the reference env
def test_an_agent_plays_the_reference_env_and_its_episode_replays_in_the_jax_env(tiny_run):
    """The policy acts on the reference env's observation through the evaluation's factory; the JAX env it trained
    on, started where the reference episode started and fed the same commands, ends the same way at the same step
    with the same observations (the policy transfers)."""
    from footstep_gym.evaluation.splits import split_seeds
    from footstep_gym.jax import replay

    _, run, _ = tiny_run
    agent = footstep_gym.make_policy("ppo-jax", load_robot(), seed=0, run=run)
    assert isinstance(agent, Policy) and agent.name == "ppo-jax"
    env = gym.make(ENV_ID, tier="train")
    u = env.unwrapped
    seed = split_seeds("validation", 1)[0]
    obs, _ = env.reset(seed=seed)
    feet = np.array([u.feet[-1], u.feet[1]], dtype=np.float64)
    rod0 = SCENES["door"].reference_start(u)  # the door rod at reset, as the replays record it
    actions, observations, rewards, margins = [], [obs], [], []
    agent.reset(seed=seed)
    for _ in range(u.episode_config.max_steps):
        command = agent.act(obs, u.sensing())
        # RescaleAction's float32 arithmetic may land an ulp or two past the box at a=+-1 (the env clips it), as
        # for the SB3 agents.
        box = env.action_space
        assert command.dtype == np.float32 and np.all(command >= box.low - 1e-6) and np.all(command <= box.high + 1e-6)
        actions.append(command)
        obs, reward, terminated, truncated, info = env.step(command)
        observations.append(obs)
        rewards.append(reward)
        margins.append((np.inf if info["clearance"] is None else info["clearance"], info["zmp_margin"],
                        u._goal_dist - u.episode_config.goal_tolerance))
        if terminated or truncated:
            break
    outcome = info["termination"] if terminated else "truncated"
    episode = replay.Episode(ENV_ID, {"tier": "train"}, seed, "agent", feet, rod0, u.episode_config,
                             np.asarray(actions), np.asarray(observations, np.float32), np.asarray(rewards), outcome,
                             margins)
    env.close()
    agreement = replay.compare([episode], replay.replay(FootstepJaxEnv("door", tier="train"), [episode]))[0]
    assert agreement.same, agreement
    assert agreement.obs_error < 1e-4 and agreement.reward_error < 1e-4


# ---------------------------------------------------------------- the shipped agents
SHIPPED = REPO / "baselines" / "agents"


def test_five_seeds_are_shipped_and_one_reaches_the_goal_in_the_reference_env():
    """Each shipped seed's manifest; seed 1 (final validation success 1.0 on the validation split's first 20 seeds)
    plays the first of them in the reference env through the evaluation's factory and reaches the goal."""
    from footstep_gym.evaluation.splits import split_seeds

    runs = agent_runs("ppo-jax", ENV_ID, SHIPPED)
    assert [r.name for r in runs] == [f"{ENV_ID}_{s}" for s in range(1, 6)]
    for run in runs:
        m = json.loads((run / "manifest.json").read_text())
        assert m["algorithm"] == "ppo_jax" and m["env_kwargs"] == {"tier": "train"} and m["final_eval_success"] >= 0.95
    assert json.loads((runs[0] / "manifest.json").read_text())["final_eval_success"] == 1.0
    agent = footstep_gym.make_policy("ppo-jax", load_robot(), seed=0, run=runs[0])
    assert isinstance(agent, Policy)
    env = gym.make(ENV_ID, tier="train")
    obs, _ = env.reset(seed=split_seeds("validation", 1)[0])
    agent.reset(seed=0)
    for _ in range(env.unwrapped.episode_config.max_steps):
        obs, _, terminated, truncated, info = env.step(agent.act(obs, env.unwrapped.sensing()))
        if terminated or truncated:
            break
    env.close()
    assert info["is_success"] and info["termination"] == "goal"


def test_brax_is_imported_without_mujocos_warp_messages():
    """``import brax`` imports MuJoCo's MJX, which prints two lines about NVIDIA Warp when it is missing; the package
    imports Brax in one place that leaves those two lines out (the main job and train_jax.py print neither)."""
    import importlib.util
    import os
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=str(REPO))
    ours = subprocess.run([sys.executable, "-c", "import sys, footstep_gym.rl.ppo_jax; "
                           "print('mujoco.mjx.warp' in sys.modules)"], capture_output=True, text=True, timeout=300,
                          cwd=REPO, env=env)
    assert ours.returncode == 0, ours.stderr[-2000:]
    assert ours.stdout.splitlines() == ["True"] and "warp" not in ours.stderr, (ours.stdout, ours.stderr)
    if importlib.util.find_spec("warp") is None:  # the noise is there when Brax is imported directly
        direct = subprocess.run([sys.executable, "-c", "import brax"], capture_output=True, text=True, timeout=300,
                                cwd=REPO, env=env)
        assert "Failed to import mujoco_warp: No module named 'warp'" in direct.stdout, direct.stdout


def test_the_validation_clock_counts_training_and_leaves_the_validations_out(monkeypatch):
    """On a hand-driven clock: each point's wall and CPU time is the time before it less the earlier validations;
    the validations' own time is kept apart, and progress sees each point."""
    import types

    now = {"wall": 100.0, "cpu": 50.0}
    monkeypatch.setattr(ppo, "time", types.SimpleNamespace(perf_counter=lambda: now["wall"],
                                                           process_time=lambda: now["cpu"]))
    seen = []
    clock = ppo.ValidationClock(lambda *p: seen.append(p))

    def validation(wall: float, cpu: float, success: float):
        def rate() -> float:
            now["wall"] += wall
            now["cpu"] += cpu
            return success
        return rate

    now["wall"], now["cpu"] = 103.0, 51.0  # 3 s of training (1 s CPU)
    clock.measure(0, validation(10.0, 4.0, 0.25))
    now["wall"] += 5.0  # 5 s more training (2 s CPU)
    now["cpu"] += 2.0
    clock.measure(4096, validation(7.0, 1.0, 0.5))
    assert clock.curve == [(0, 3.0, 0.25, 1.0), (4096, 8.0, 0.5, 3.0)]
    assert seen == [(0, 3.0, 0.25), (4096, 8.0, 0.5)]
    assert (clock.validating, clock.validating_cpu) == (17.0, 5.0)
    now["wall"] += 2.0
    assert clock.training_time() == (10.0, 3.0)
