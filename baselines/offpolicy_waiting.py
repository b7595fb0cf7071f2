"""Why the off-policy agents wait where a blind walker crosses: their critics against the returns they earn.

On the paper's crossing (the timed car, where a blind constant walker succeeds) most SAC and TD3 crossing runs
trained on that car timed out, stepping in place. This plays each shipped run on validation seeds of a crossing
tier's cell (``--tier``: ``paper``, the timed car, or ``train``, the car stream the runs now train on) and, per
footstep, reads the agent's own critic (sbx: the minimum over its Q-networks, ``qf.apply``) at the command it
chose and at the nominal walking command, beside the discounted return the episode then earned. An episode
that times out is *truncated* (Gymnasium: not a terminal state), so the learner bootstraps through it: the
value of waiting is learned only through a chain of one-step backups of a small per-footstep cost, at the
run's own discount. The table shows whether the critic prices waiting above what waiting earns, and
walking below it.

    python baselines/offpolicy_waiting.py --episodes 20 --out baselines/results/offpolicy_waiting
    python baselines/offpolicy_waiting.py --tier train --episodes 20 --out baselines/results/offpolicy_waiting/train
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pandas as pd
from tqdm import tqdm

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym.evaluation.splits import split_seeds
from footstep_gym.evaluation.tables import markdown
from footstep_gym.rl.agents import ZooAgent
from footstep_gym.rl.registry import agent_runs
from footstep_gym.robot import load_robot

ENV_ID = "FootstepCrossing-v0"
#: The crossing's cells this can play: the tier and how the table names it.
TIERS = {"paper": "the paper's crossing (the timed car)", "train": "the crossing's train cell (the car stream)"}


def critic(agent: ZooAgent, obs: np.ndarray, command: np.ndarray) -> float:
    """The agent's Q(obs, command): the minimum over its critics (SAC's and TD3's target), in the model's
    normalised observation and [-1, 1] action."""
    policy = agent.model.policy
    x = np.asarray(obs, np.float32).reshape(1, -1)
    if agent.normalizer is not None:
        x = agent.normalizer.normalize_obs(x)
    low, high = agent.model.action_space.low, agent.model.action_space.high
    box = load_robot(None)
    a = (np.asarray(command, np.float64) - box.command_low) / (box.command_high - box.command_low)
    a = (low + a * (high - low)).astype(np.float32).reshape(1, -1)
    return float(np.min(np.asarray(policy.qf.apply(policy.qf_state.params, x, a))))


def play(agent: ZooAgent, seed: int, gamma: float, tier: str = "paper") -> dict:
    """One episode of the crossing's ``tier`` cell: its ending, its commands and, per footstep, Q at the chosen and at
    the nominal command and the discounted return-to-go."""
    env = gym.make(ENV_ID, tier=tier)
    obs, _ = env.reset(seed=seed)
    agent.reset(seed)
    nominal = load_robot(None).nominal_command
    q_chosen, q_walk, rewards, strides = [], [], [], []
    while True:
        command = agent.act(obs)
        q_chosen.append(critic(agent, obs, command))
        q_walk.append(critic(agent, obs, nominal))
        strides.append(float(command[0]))
        obs, reward, terminated, truncated, info = env.step(command)
        rewards.append(float(reward))
        if terminated or truncated:
            break
    returns = np.zeros(len(rewards))
    g = 0.0
    for k in range(len(rewards) - 1, -1, -1):
        g = rewards[k] + gamma * g
        returns[k] = g
    ending = "goal" if info.get("is_success") else ("timeout" if truncated else info.get("termination", "end"))
    return {"ending": ending, "steps": len(rewards), "mean_stride_m": float(np.mean(strides)),
            "q_chosen": float(np.mean(q_chosen)), "q_walk": float(np.mean(q_walk)),
            "return_to_go": float(np.mean(returns)), "reward_per_step": float(np.mean(rewards))}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=20, help="validation seeds per run (default 20)")
    parser.add_argument("--out", type=Path, default=Path("runs/offpolicy_waiting"), help="folder for the tables")
    parser.add_argument("--tier", choices=TIERS, default="paper",
                        help="the crossing's cell: paper (the timed car, default) or train (the car stream)")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1, got {args.episodes}")
    rows = []
    runs = [(name, run) for name in ("sac", "td3") for run in agent_runs(name, ENV_ID)]
    if not runs:
        parser.error("no shipped sac or td3 crossing run (run from the repository root)")
    for name, run in tqdm(runs, desc="runs", file=sys.stderr):
        agent = ZooAgent(run, load_robot(None))
        gamma = float(agent.model.gamma)
        for seed in split_seeds("validation", args.episodes):
            rows.append({"agent": name, "run": run.name, "gamma": gamma, "seed": seed,
                         **play(agent, seed, gamma, args.tier)})
    df = pd.DataFrame(rows)
    summary = (df.groupby(["agent", "run", "ending"], sort=False)
               .agg(episodes=("seed", "size"), steps=("steps", "mean"), stride_m=("mean_stride_m", "mean"),
                    reward_per_step=("reward_per_step", "mean"), q_chosen=("q_chosen", "mean"),
                    q_walk=("q_walk", "mean"), return_to_go=("return_to_go", "mean"), gamma=("gamma", "first"))
               .reset_index())
    # What waiting for ever is worth at the run's discount, at the per-footstep reward the waiting episodes earned.
    summary["waiting_forever"] = (summary["reward_per_step"] / (1.0 - summary["gamma"])).where(
        summary["ending"] == "timeout")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "episodes.json").write_text(json.dumps(rows, indent=1) + "\n", encoding="utf-8")
    shown = summary.copy()
    for col in ("steps", "stride_m", "reward_per_step", "q_chosen", "q_walk", "return_to_go", "waiting_forever"):
        shown[col] = shown[col].map(lambda v: "–" if pd.isna(v) else f"{v:.3f}" if abs(v) < 10 else f"{v:.1f}")
    text = (f"# Off-policy agents on {TIERS[args.tier]}: critic against return\n\n"
            f"`python baselines/offpolicy_waiting.py --tier {args.tier} --episodes {args.episodes}`: each shipped sac "
            f"and td3 crossing run on validation seeds {split_seeds('validation', 1)[0]}.. of {TIERS[args.tier]}; "
            "per ending, means "
            "over its episodes of: footsteps, stride S [m], reward per footstep, the run's critic (min over its "
            "Q-networks) at the chosen command and at the nominal walking command, the discounted return-to-go "
            "earned, and for the episodes that timed out what waiting for ever is worth at that reward per footstep "
            "(reward / (1 - gamma), what the critic should converge to if the agent keeps waiting).\n\n"
            + markdown(shown, left=3))
    (args.out / "offpolicy_waiting.md").write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
