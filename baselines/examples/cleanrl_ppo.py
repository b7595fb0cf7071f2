"""A CleanRL-style PPO in one file, from training to a benchmark submission (docs/benchmark.md §3).

CleanRL's ``ppo_continuous_action.py`` (Huang et al.), written for the Gymnasium this repository locks: the same
network, rollout, GAE and clipped update, with these changes, each of which the original needs here:

* the wrappers are Gymnasium's vector wrappers on one vector env, so the observation normaliser is **one** running
  mean and variance, which is saved with the network and applied again at submission (CleanRL keeps one per
  sub-env and saves none of them);
* ``TransformObservation`` is given its observation space (Gymnasium 1.x requires it);
* episode returns are read from ``RecordEpisodeStatistics``' ``info["episode"]`` where ``info["_episode"]`` is set
  (Gymnasium 1.x sends no ``final_info``);
* the action is rescaled to [-1, 1] for the Gaussian policy (the footstep command's bounds span 0.1 m to 1 s), and
  mapped back to the command box at submission, as the zoo's agents are.

Usage (from the repository root)::

    python baselines/examples/cleanrl_ppo.py --env door --total-timesteps 200000   # train, save, submit a try
    python baselines/examples/cleanrl_ppo.py --env door --total-timesteps 2048 --episodes 2   # a quick check

It trains on the scene's ``train`` tier (``gym.make(id, tier="train")``, train-split seeds), saves
``OUT/model.pt`` (the network, the observation statistics, the command box), loads it again into a fresh network
and submits it through :func:`footstep_gym.benchmark.evaluate` on the scene's ``paper`` tier with **validation**
seeds: a try while developing, never a leaderboard row. For a row: one model per scene (``make_policy_fn`` is told
the scene), every tier, ``release=True`` (the test split, from committed code, logged) and the committed rows'
episodes per cell.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn
from torch.distributions.normal import Normal

import footstep_gym
from footstep_gym.benchmark import evaluate
from footstep_gym.evaluation.splits import train_seed_stream

OBS_CLIP = 10.0


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--env", default="door", choices=sorted(footstep_gym.ENV_IDS), help="the scene to train on")
    p.add_argument("--seed", type=int, default=1, help="training seed (torch, the train-split seed stream)")
    p.add_argument("--total-timesteps", type=int, default=200_000, help="env steps (footsteps) of training")
    p.add_argument("--num-envs", type=int, default=4)
    p.add_argument("--num-steps", type=int, default=256, help="steps per env per rollout")
    p.add_argument("--learning-rate", type=float, default=3e-4)
    p.add_argument("--gamma", type=float, default=0.99)
    p.add_argument("--gae-lambda", type=float, default=0.95)
    p.add_argument("--num-minibatches", type=int, default=8)
    p.add_argument("--update-epochs", type=int, default=10)
    p.add_argument("--clip-coef", type=float, default=0.2)
    p.add_argument("--ent-coef", type=float, default=0.0)
    p.add_argument("--vf-coef", type=float, default=0.5)
    p.add_argument("--max-grad-norm", type=float, default=0.5)
    p.add_argument("--episodes", type=int, default=20, help="validation seeds per cell of the submitted try")
    p.add_argument("--workers", type=int, default=1, help="processes of the submitted try")
    p.add_argument("--out", type=Path, default=Path("runs/cleanrl_ppo"), help="model.pt and the try's benchmark")
    args = p.parse_args(argv)
    if min(args.total_timesteps, args.num_envs, args.num_steps, args.episodes, args.workers) < 1:
        p.error("--total-timesteps, --num-envs, --num-steps, --episodes and --workers must be at least 1")
    return args


def layer_init(layer: nn.Linear, std: float = np.sqrt(2), bias_const: float = 0.0) -> nn.Linear:
    torch.nn.init.orthogonal_(layer.weight, std)
    torch.nn.init.constant_(layer.bias, bias_const)
    return layer


class Agent(nn.Module):
    """CleanRL's actor-critic: two tanh MLPs of 64 units and a state-independent log std."""

    def __init__(self, obs_dim: int, act_dim: int):
        super().__init__()
        self.critic = nn.Sequential(layer_init(nn.Linear(obs_dim, 64)), nn.Tanh(), layer_init(nn.Linear(64, 64)),
                                    nn.Tanh(), layer_init(nn.Linear(64, 1), std=1.0))
        self.actor_mean = nn.Sequential(layer_init(nn.Linear(obs_dim, 64)), nn.Tanh(), layer_init(nn.Linear(64, 64)),
                                        nn.Tanh(), layer_init(nn.Linear(64, act_dim), std=0.01))
        self.actor_logstd = nn.Parameter(torch.zeros(1, act_dim))

    def get_value(self, x: torch.Tensor) -> torch.Tensor:
        return self.critic(x)

    def get_action_and_value(self, x: torch.Tensor, action: torch.Tensor | None = None):
        mean = self.actor_mean(x)
        probs = Normal(mean, torch.exp(self.actor_logstd.expand_as(mean)))
        if action is None:
            action = probs.sample()
        return action, probs.log_prob(action).sum(1), probs.entropy().sum(1), self.critic(x)


def make_envs(env_id: str, num_envs: int, gamma: float) -> gym.vector.VectorEnv:
    """The training envs: the scene's train tier, actions in [-1, 1], CleanRL's wrappers as vector wrappers."""
    envs = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="sync", tier="train",
                        wrappers=[lambda env: gym.wrappers.RescaleAction(env, np.float32(-1.0), np.float32(1.0))])
    envs = gym.wrappers.vector.RecordEpisodeStatistics(envs)
    envs = gym.wrappers.vector.ClipAction(envs)
    envs = gym.wrappers.vector.NormalizeObservation(envs)
    envs = gym.wrappers.vector.TransformObservation(envs, lambda obs: np.clip(obs, -OBS_CLIP, OBS_CLIP),
                                                    envs.observation_space)
    envs = gym.wrappers.vector.NormalizeReward(envs, gamma=gamma)
    return gym.wrappers.vector.TransformReward(envs, lambda r: np.clip(r, -10, 10))


def train(args: argparse.Namespace) -> dict:
    """PPO as CleanRL's ``ppo_continuous_action.py`` runs it; returns what :func:`save` writes."""
    torch.manual_seed(args.seed)
    env_id = footstep_gym.ENV_IDS[args.env]
    envs = make_envs(env_id, args.num_envs, args.gamma)
    box = gym.make(env_id).action_space
    obs_dim, act_dim = envs.single_observation_space.shape[0], envs.single_action_space.shape[0]
    agent = Agent(obs_dim, act_dim)
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)
    batch = args.num_envs * args.num_steps
    minibatch = max(1, batch // args.num_minibatches)
    iterations = max(1, args.total_timesteps // batch)
    obs_buf = torch.zeros((args.num_steps, args.num_envs, obs_dim))
    act_buf = torch.zeros((args.num_steps, args.num_envs, act_dim))
    logp_buf, rew_buf, done_buf, val_buf = (torch.zeros((args.num_steps, args.num_envs)) for _ in range(4))
    seeds = train_seed_stream(args.seed)
    next_obs = torch.tensor(envs.reset(seed=next(seeds))[0], dtype=torch.float32)
    next_done = torch.zeros(args.num_envs)
    returns: list[float] = []
    t0 = time.perf_counter()
    for it in range(iterations):
        optimizer.param_groups[0]["lr"] = (1.0 - it / iterations) * args.learning_rate
        for step in range(args.num_steps):
            obs_buf[step], done_buf[step] = next_obs, next_done
            with torch.no_grad():
                action, logp, _, value = agent.get_action_and_value(next_obs)
            act_buf[step], logp_buf[step], val_buf[step] = action, logp, value.flatten()
            obs, reward, terminated, truncated, info = envs.step(action.numpy())
            rew_buf[step] = torch.tensor(reward, dtype=torch.float32)
            next_obs = torch.tensor(obs, dtype=torch.float32)
            next_done = torch.tensor(np.logical_or(terminated, truncated), dtype=torch.float32)
            if "_episode" in info:  # Gymnasium 1.x: the finished episodes' statistics, no final_info
                returns += [float(r) for r in info["episode"]["r"][info["_episode"]]]
        with torch.no_grad():  # generalised advantage estimation
            next_value = agent.get_value(next_obs).reshape(1, -1)
            adv = torch.zeros_like(rew_buf)
            last = torch.zeros(args.num_envs)
            for t in reversed(range(args.num_steps)):
                nonterminal = 1.0 - (next_done if t == args.num_steps - 1 else done_buf[t + 1])
                nxt = next_value if t == args.num_steps - 1 else val_buf[t + 1]
                delta = rew_buf[t] + args.gamma * nxt * nonterminal - val_buf[t]
                adv[t] = last = delta + args.gamma * args.gae_lambda * nonterminal * last
            ret = adv + val_buf
        b_obs, b_act = obs_buf.reshape(-1, obs_dim), act_buf.reshape(-1, act_dim)
        b_logp, b_adv, b_ret = logp_buf.reshape(-1), adv.reshape(-1), ret.reshape(-1)
        for _ in range(args.update_epochs):
            for idx in torch.randperm(batch).split(minibatch):
                _, logp, entropy, value = agent.get_action_and_value(b_obs[idx], b_act[idx])
                ratio = (logp - b_logp[idx]).exp()
                mb_adv = (b_adv[idx] - b_adv[idx].mean()) / (b_adv[idx].std(unbiased=False) + 1e-8)
                pg_loss = torch.max(-mb_adv * ratio,
                                    -mb_adv * torch.clamp(ratio, 1 - args.clip_coef, 1 + args.clip_coef)).mean()
                v_loss = 0.5 * ((value.view(-1) - b_ret[idx]) ** 2).mean()
                loss = pg_loss - args.ent_coef * entropy.mean() + args.vf_coef * v_loss
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
                optimizer.step()
        recent = f"{np.mean(returns[-20:]):.2f}" if returns else "-"
        print(f"iteration {it + 1}/{iterations}: {(it + 1) * batch} steps, {len(returns)} episodes, "
              f"mean return of the last 20 {recent}, {time.perf_counter() - t0:.0f} s", flush=True)
    rms = _obs_rms(envs)
    envs.close()
    return {"agent": agent.state_dict(), "obs_dim": obs_dim, "act_dim": act_dim, "env_id": env_id,
            "obs_mean": rms.mean.astype(np.float64), "obs_var": rms.var.astype(np.float64),
            "action_low": box.low.astype(np.float64), "action_high": box.high.astype(np.float64)}


def _obs_rms(envs: gym.vector.VectorEnv):
    """The running statistics of the one vector ``NormalizeObservation`` in the wrapper stack."""
    env = envs
    while not isinstance(env, gym.wrappers.vector.NormalizeObservation):
        env = env.env
    return env.obs_rms


def save(checkpoint: dict, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(checkpoint, path)


def load_policy(path: Path):
    """The saved model as the benchmark's callable ``observation -> footstep command``: the training's observation
    statistics applied, the deterministic action (the Gaussian's mean) mapped from [-1, 1] to the command box."""
    ckpt = torch.load(path, weights_only=False)
    agent = Agent(ckpt["obs_dim"], ckpt["act_dim"])
    agent.load_state_dict(ckpt["agent"])
    agent.eval()
    mean, std = ckpt["obs_mean"], np.sqrt(ckpt["obs_var"] + 1e-8)
    low, high = ckpt["action_low"], ckpt["action_high"]

    def act(observation: np.ndarray) -> np.ndarray:
        x = np.clip((np.asarray(observation, dtype=np.float64) - mean) / std, -OBS_CLIP, OBS_CLIP)
        with torch.no_grad():
            a = agent.actor_mean(torch.as_tensor(x, dtype=torch.float32)).numpy().astype(np.float64)
        return low + (np.clip(a, -1.0, 1.0) + 1.0) * 0.5 * (high - low)

    return act


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    model = args.out / "model.pt"
    save(train(args), model)
    print(f"saved {model}")
    act = load_policy(model)  # what a submission does: a fresh network from the file

    def make_policy_fn(scene: str, seed: int):
        return act

    doc = evaluate(make_policy_fn, name="cleanrl-ppo", out=args.out / "bench", episodes=args.episodes,
                   scenes=[args.env], tiers=["paper"], split="validation", workers=args.workers)
    for a in doc["aggregates"]:
        print(f"{a['tier']} ({args.env}), validation seeds {doc['protocol']['seeds'][0]}..."
              f"{doc['protocol']['seeds'][-1]}: success {a['success']:.2f} [{a['success_ci95'][0]:.2f}, "
              f"{a['success_ci95'][1]:.2f}]")
    print(f"wrote {args.out / 'bench'}/benchmark.json (a try on validation seeds: not a leaderboard row)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
