"""ppo-jax-gru: the recurrent PPO in JAX (footstep_gym/rl/ppo_jax_rnn.py): its config, its state reset at episode
starts (against a fresh state), the sequence the loss backpropagates through (against step-by-step acting), GAE and
the loss (against a hand computation), and a tiny training shipped and played through the evaluation's factory."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import yaml

import footstep_gym
from footstep_gym.errors import ConfigError
from footstep_gym.rl import ZooAgent, agent_runs
from footstep_gym.rl import ppo_jax as ppo
from footstep_gym.rl import ppo_jax_rnn as rnn
from footstep_gym.rl.brax_env import action_to_command, rescaling
from footstep_gym.robot import load_robot

REPO = Path(__file__).resolve().parent.parent
ENV_ID = "FootstepDoor-v0"
SCENE_IDS = ("FootstepDoor-v0", "FootstepCrowd-v0", "FootstepCrossing-v0")


def raw_config() -> dict:
    return yaml.safe_load(rnn.default_config_path().read_text())[ENV_ID]


def network(cell: str = "gru") -> dict:
    cfg = dataclasses.replace(rnn.parse_config(raw_config(), ENV_ID), rnn_cell=cell, rnn_hidden_size=8,
                              policy_hidden_layer_sizes=(16,), value_hidden_layer_sizes=(16,))
    return rnn.network_of(cfg, 42, 5)


def random_model(cell: str, seed: int = 0) -> rnn.RecurrentPPOJax:
    """A policy with random weights (and a non-trivial normaliser), so that its state matters."""
    net = network(cell)
    norm, params = rnn.init_params(net, jax.random.PRNGKey(seed))
    leaves, tree = jax.tree.flatten(params)
    keys = jax.random.split(jax.random.PRNGKey(seed + 1), len(leaves))
    params = jax.tree.unflatten(tree, [x + 0.5 * jax.random.normal(k, x.shape) for x, k in zip(leaves, keys)])
    return rnn.RecurrentPPOJax((norm, params), net)


# ---------------------------------------------------------------- the config
def test_the_config_has_each_scene_on_the_noise_tier_at_the_2e7_budget_with_ppo_jax_2e7s_values():
    twin = yaml.safe_load((REPO / "configs" / "rl" / "ppo-jax-2e7.yml").read_text())
    for env_id in SCENE_IDS:
        cfg = rnn.load_config(env_id)
        assert isinstance(cfg, rnn.RecurrentConfig) and cfg.rnn_cell == "gru" and cfg.rnn_hidden_size == 64
        assert cfg.env_kwargs == {"tier": "noise"} and cfg.num_timesteps == 20_000_000
        base = ppo.parse_config(dict(twin[env_id], env_kwargs={"tier": "noise"}), env_id)
        assert {k: v for k, v in dataclasses.asdict(cfg).items() if not k.startswith("rnn_")} == dataclasses.asdict(base)


@pytest.mark.parametrize("change, message", [
    ({"rnn_cell": "rnn"}, r"rnn_cell must be one of gru, lstm, got 'rnn'"),
    ({"rnn_hidden_size": 0}, r"rnn_hidden_size must be a whole number >= 1, got 0"),
    ({"rnn_hidden_size": 8.0}, r"rnn_hidden_size must be a whole number >= 1, got 8.0"),
    ({"rnn_cell": None}, r"missing key\(s\) rnn_cell"),
    ({"lstm_size": 3}, r"unknown key\(s\) lstm_size"),
    ({"gae_lambda": 1.5}, r"gae_lambda must be in \(0, 1\]"),
])
def test_a_bad_config_is_refused_naming_the_key(change, message):
    entry = dict(raw_config(), **change)
    entry = {k: v for k, v in entry.items() if v is not None}
    with pytest.raises(ConfigError, match=message):
        rnn.parse_config(entry, ENV_ID)


# ---------------------------------------------------------------- the recurrent state
@pytest.mark.parametrize("cell", rnn.CELLS)
def test_the_state_is_carried_and_restarts_at_an_episode_start_as_a_fresh_state(cell):
    model = random_model(cell)
    obs = np.random.default_rng(0).normal(0, 2, (6, 2, 42)).astype(np.float32)
    state, first = None, np.ones(2, bool)
    actions = []
    for t in range(6):
        start = first if t == 0 else np.array([t == 3, False])  # env 0 starts a new episode at step 3
        a, state = model.predict(obs[t], state, start)
        actions.append(a)
        assert state.shape == (2, model.carry_size) and a.dtype == np.float32 and np.all(np.abs(a) <= 1)
    fresh = None
    for t in range(3, 6):  # env 0 from step 3: what a fresh state gives on the same observations
        b, fresh = model.predict(obs[t, :1], fresh, np.array([t == 3]))
        np.testing.assert_allclose(actions[t][:1], b, rtol=1e-6, atol=1e-6)  # a batch of 1 against one of 2: ulps
    # The state matters (not a memoryless policy): env 1 at step 3 differs from a fresh start's action.
    c, _ = model.predict(obs[3, 1:], None, np.ones(1, bool))
    assert np.max(np.abs(actions[3][1:] - c)) > 1e-3
    # A single observation acts as a batch of one; no state means the initial one.
    np.testing.assert_allclose(model.predict(obs[0, 0])[0], actions[0][0], rtol=1e-6, atol=1e-6)


def test_the_loss_backpropagates_through_the_sequence_the_policy_acted_on():
    """The module run over a sequence with its start flags (the loss's truncated BPTT) gives the actions and states
    of the policy stepped one observation at a time with the same episode starts."""
    model = random_model("lstm", seed=3)
    norm, params = model.params
    rng = np.random.default_rng(1)
    obs = rng.normal(0, 2, (7, 3, 42)).astype(np.float32)
    start = rng.random((7, 3)) < 0.3
    carry0 = rng.normal(0, 0.5, (3, model.carry_size)).astype(np.float32)
    carry, mean, _, _ = rnn._module(model.network).apply(params, jnp.asarray(carry0),
                                                         rnn._normalize(norm, jnp.asarray(obs), model.network),
                                                         jnp.asarray(start))
    state = carry0
    for t in range(7):
        a, state = model.predict(obs[t], state, start[t])
        np.testing.assert_allclose(a, np.clip(np.asarray(mean[t]), -1, 1), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(state, np.asarray(carry), rtol=1e-5, atol=1e-6)


# ---------------------------------------------------------------- GAE and the loss
def test_gae_of_a_hand_worked_segment():
    """gamma 0.9, lambda 0.8; rewards 1, 0, 2, 1; values 0.5, 0.2, 0.1, 0.4; bootstrap 0.3; the episode terminates at
    step 1 (no bootstrap across it) and is truncated at step 3 (masked out). The value targets are the lambda-returns
    (value + GAE); the policy's advantages, Brax's, are reward + gamma * next target - value."""
    from brax.training.agents.ppo.losses import compute_gae

    r, v, boot = np.array([1.0, 0.0, 2.0, 1.0]), np.array([0.5, 0.2, 0.1, 0.4]), 0.3
    g, lam = 0.9, 0.8
    d2 = 2.0 + g * 0.4 - 0.1  # step 2: next value is step 3's
    d1 = 0.0 - 0.2  # terminated: no next value
    d0 = 1.0 + g * 0.2 - 0.5
    gae = np.array([d0 + g * lam * d1, d1, d2, 0.0])  # step 3 truncated: masked; step 2 does not see past it
    vs = v + gae
    adv = [1.0 + g * vs[1] - 0.5, 0.0 - 0.2, 2.0 + g * vs[3] - 0.1, 0.0]
    got_vs, got = compute_gae(truncation=jnp.array([0.0, 0, 0, 1])[:, None],
                              termination=jnp.array([0.0, 1, 0, 0])[:, None], rewards=jnp.asarray(r)[:, None],
                              values=jnp.asarray(v)[:, None], bootstrap_value=jnp.array([boot]), lambda_=lam,
                              discount=g)
    np.testing.assert_allclose(np.asarray(got_vs)[:, 0], vs, rtol=1e-6)
    np.testing.assert_allclose(np.asarray(got)[:, 0], adv, rtol=1e-6)


def test_the_loss_is_ppos_clipped_objective_computed_by_hand():
    model = random_model("gru", seed=5)
    norm, params = model.params
    cfg = dataclasses.replace(rnn.parse_config(raw_config(), ENV_ID), discounting=0.9, gae_lambda=0.8,
                              clipping_epsilon=0.2, entropy_cost=0.01, reward_scaling=2.0)
    rng = np.random.default_rng(2)
    t, b = 4, 3
    obs = rng.normal(0, 2, (t + 1, b, 42)).astype(np.float32)
    start = np.zeros((t + 1, b), bool)
    start[2, 1] = True
    carry = rng.normal(0, 0.5, (b, model.carry_size)).astype(np.float32)
    apply = rnn._module(model.network).apply
    _, mean, log_std, values = (np.asarray(x, np.float64) for x in apply(
        params, carry, rnn._normalize(norm, jnp.asarray(obs), model.network), jnp.asarray(start)))
    action = mean[:-1] + rng.normal(0, 0.5, (t, b, 5))
    std = np.exp(log_std)
    logp_now = np.sum(-0.5 * ((action - mean[:-1]) / std) ** 2 - np.log(std * math.sqrt(2 * math.pi)), axis=-1)
    old = logp_now + rng.normal(0, 0.4, (t, b))  # behaviour log-probs: ratios inside and outside the clip
    reward = rng.normal(0, 1, (t, b))
    term = np.zeros((t, b))
    term[1, 1] = 1.0
    trunc = np.zeros((t, b))
    trunc[3, 0] = 1.0
    data = rnn.Segments(*(jnp.asarray(x, jnp.float32) for x in (obs,)), jnp.asarray(start),
                        *(jnp.asarray(x, jnp.float32) for x in (action, old, reward, term, trunc, carry)))
    loss, parts = rnn.ppo_loss(params, norm, data, apply, model.network, cfg)
    # By hand: GAE backwards, a termination cutting the bootstrap, a truncation masking its step.
    v, nxt = values[:-1], np.concatenate([values[1:-1], values[-1:]])
    adv, acc = np.zeros((t, b)), np.zeros(b)
    for i in reversed(range(t)):
        delta = (2.0 * reward[i] + 0.9 * (1 - term[i]) * nxt[i] - v[i]) * (1 - trunc[i])
        acc = delta + 0.9 * 0.8 * (1 - term[i]) * (1 - trunc[i]) * acc
        adv[i] = acc
    vs = adv + v
    vs_next = np.concatenate([vs[1:], values[-1:]])
    a = (2.0 * reward + 0.9 * (1 - term) * vs_next - v) * (1 - trunc)
    a = (a - a.mean()) / (a.std() + 1e-8)
    ratio = np.exp(logp_now - old)
    assert np.any(np.abs(ratio - 1) > 0.2) and np.any(np.abs(ratio - 1) < 0.2)
    policy = -np.mean(np.minimum(ratio * a, np.clip(ratio, 0.8, 1.2) * a))
    value = 0.25 * np.mean((vs - v) ** 2)
    entropy = -0.01 * np.sum(log_std + 0.5 * math.log(2 * math.pi * math.e))
    np.testing.assert_allclose(float(parts["policy_loss"]), policy, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(float(parts["v_loss"]), value, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(float(parts["entropy_loss"]), entropy, rtol=1e-5)
    np.testing.assert_allclose(float(loss), policy + value + entropy, rtol=2e-4, atol=1e-6)


# ---------------------------------------------------------------- a tiny training, shipped and played
TINY = {"num_timesteps": 256, "num_envs": 16, "unroll_length": 4, "batch_size": 8, "num_minibatches": 2,
        "num_updates_per_batch": 2, "num_evals": 3, "validation_episodes": 2, "chunk": 16, "rnn_hidden_size": 8,
        "policy_hidden_layer_sizes": [16], "value_hidden_layer_sizes": [16]}


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    cfg = rnn.parse_config(dict(raw_config(), **TINY), ENV_ID)
    seen = []
    result = rnn.train(cfg, 7, progress=lambda s, w, r: seen.append((s, w, r)))
    run = ppo.write_run(result, tmp_path_factory.mktemp("runs"), "python baselines/train_jax.py --recurrent")
    return result, run, seen


def test_a_tiny_training_writes_a_run_that_the_evaluation_plays_with_its_state(tiny_run, tmp_path):
    result, run, seen = tiny_run
    # 256 env steps asked: updates of 8 segments x 4 steps x 2 minibatches = 64 env steps, 2 per validation chunk.
    assert [s for s, _, _ in seen] == [0, 128, 256] and result.timesteps == 256
    assert all(0 <= r <= 1 for _, _, r in seen) and result.wall_time_s > 0 and result.cpu_time_s > 0
    args = yaml.safe_load((run / ENV_ID / "args.yml").read_text())
    assert args["algo"] == "ppo_jax_rnn" and args["n_timesteps"] == 256
    assert yaml.safe_load((run / ENV_ID / "config.yml").read_text())["rnn_cell"] == "gru"
    assert len((run / "validation.csv").read_text().splitlines()) == 4
    # The parameters trained differ from the initial ones, and are saved as trained.
    net = result.model.network
    trained = jax.tree.leaves(result.model.params[1])
    assert any(np.max(np.abs(np.asarray(x) - np.asarray(y))) > 0
               for x, y in zip(trained, jax.tree.leaves(rnn.init_params(net, jax.random.PRNGKey(7))[1])))
    model = rnn.RecurrentPPOJax.load(run / f"{ENV_ID}.zip")
    obs = np.random.default_rng(0).normal(size=(3, 42)).astype(np.float32)
    a1, s1 = model.predict(obs, None, np.ones(3, bool))
    b1, t1 = result.model.predict(obs, None, np.ones(3, bool))
    np.testing.assert_array_equal(a1, b1)
    np.testing.assert_array_equal(model.predict(obs, s1, np.zeros(3, bool))[0],
                                  result.model.predict(obs, t1, np.zeros(3, bool))[0])
    # Shipped as the registered agent and played through the evaluation's factory on the noise tier.
    dest = ppo.ship(run, result, tmp_path, "ppo-jax-gru-noise")
    m = json.loads((dest / "manifest.json").read_text())
    assert m["algorithm"] == "ppo_jax_rnn" and m["library"] == rnn.RecurrentPPOJax.library
    assert m["env_kwargs"] == {"tier": "noise"} and m["timesteps"] == 256
    assert agent_runs("ppo-jax-gru-noise", ENV_ID, tmp_path) == [dest]
    agent = footstep_gym.make_policy("ppo-jax-gru-noise", load_robot(), seed=0, run=dest)
    assert isinstance(agent, ZooAgent) and agent.algo == "ppo_jax_rnn" and agent.normalizer is None
    env = gym.make(ENV_ID, tier="noise")
    o, _ = env.reset(seed=3)
    agent.reset(seed=0)
    commands, state = [], None
    for i in range(3):
        commands.append(agent.act(o))
        assert agent._state is not None and agent._state.shape == (1, 8)
        a, state = model.predict(o[None], state, np.array([i == 0]))
        np.testing.assert_array_equal(commands[-1], action_to_command(a[0], *rescaling(env.unwrapped.action_space), xp=np))
        o, *_ = env.step(commands[-1])
    agent.reset(seed=0)
    assert agent._state is None
    env.close()



def test_train_jax_takes_the_recurrent_config_and_refuses_several_devices(capsys, tmp_path):
    import importlib.util

    spec = importlib.util.spec_from_file_location("train_jax", REPO / "baselines" / "train_jax.py")
    train_jax = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(train_jax)
    with pytest.raises(SystemExit):
        train_jax.main(["--recurrent", "--devices", "2"])
    assert "--devices: the recurrent trainer runs on one device" in capsys.readouterr().err
    # The MLP's config has no recurrent cell: refused before anything is trained or written.
    code = train_jax.main(["--recurrent", "--config", str(REPO / "configs" / "rl" / "ppo-jax.yml"),
                           "--runs-dir", str(tmp_path / "runs")])
    assert code == 2 and "missing key(s) rnn_cell" in capsys.readouterr().err and not (tmp_path / "runs").exists()
