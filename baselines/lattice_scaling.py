"""How the discrete footstep search grows with its transition set (the paper's §2.4 claim, measured).

Runs the ``lattice`` planner with transition sets of growing size (strides x turns x periods)
on the three scenes' paper cells, validation seeds, and writes per set: success, planning time
per footstep (median, p99), nodes expanded and generated per footstep (median), and how often
the search reached the goal within its budget. The continuous ``period-aware`` planner runs on
the same episodes for comparison.

    python baselines/lattice_scaling.py --episodes 10 --out runs/lattice_scaling
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import ENV_IDS, make_policy
from footstep_gym.evaluation.splits import split_seeds

#: The transition sets, smallest first: (label, strides [m], turns [rad], periods [s]); L is the nominal 0.08 m.
SETS = (
    ("3x1x1", [0.0, 0.045, 0.09], [0.0], [0.8]),
    ("5x3x1", [-0.02, 0.0, 0.03, 0.06, 0.09], [-0.15, 0.0, 0.15], [0.8]),
    ("5x3x3", [-0.02, 0.0, 0.03, 0.06, 0.09], [-0.15, 0.0, 0.15], [0.4, 0.6, 0.8]),
    ("7x5x5", [-0.04, -0.02, 0.0, 0.025, 0.05, 0.075, 0.1], [-0.3, -0.15, 0.0, 0.15, 0.3],
     [0.3, 0.425, 0.55, 0.675, 0.8]),
)


def episode(env: gym.Env, policy, seed: int) -> tuple[str, list[dict]]:
    """One episode's end and the planner's report at every footstep."""
    obs, _ = env.reset(seed=seed)
    policy.reset(seed=seed)
    steps = []
    while True:
        action = policy.act(obs, env.unwrapped.sensing())
        steps.append(dict(policy.last_info))
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            return info["termination"], steps


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=10, help="validation seeds per scene (default 10)")
    parser.add_argument("--budget", type=int, default=None, help="lattice.max_expansions (default: the YAML's)")
    parser.add_argument("--out", type=Path, default=Path("runs/lattice_scaling"), help="folder for the results")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1, got {args.episodes}")
    if args.budget is not None and args.budget < 1:
        parser.error(f"--budget must be >= 1, got {args.budget}")
    seeds = split_seeds("validation", args.episodes)
    rows = []
    runs = [(label, {"lattice": {"strides": s, "turns": th, "periods": t,
                                 **({"max_expansions": args.budget} if args.budget else {})}})
            for label, s, th, t in SETS] + [("period-aware", None)]
    with tqdm(total=len(runs) * len(ENV_IDS) * len(seeds), unit="ep") as bar:
        for label, overrides in runs:
            for scene, env_id in ENV_IDS.items():
                env = gym.make(env_id)
                name = "period-aware" if overrides is None else "lattice"
                policy = make_policy(name, env.unwrapped.robot, seed=0, **(overrides or {}))
                ends, steps = [], []
                for seed in seeds:
                    end, info = episode(env, policy, seed)
                    ends.append(end)
                    steps += info
                    bar.update()
                env.close()
                ms = np.array([s["plan_time_ms"] for s in steps])
                row = {"set": label, "transitions": steps[0].get("lattice_transitions"), "scene": scene,
                       "episodes": len(seeds), "success": float(np.mean([e == "goal" for e in ends])),
                       "plan_ms_median": float(np.median(ms)), "plan_ms_p99": float(np.percentile(ms, 99))}
                if overrides is not None:
                    row.update(expanded_median=float(np.median([s["lattice_expanded"] for s in steps])),
                               generated_median=float(np.median([s["lattice_generated"] for s in steps])),
                               goal_reached=float(np.mean([s["lattice_reached_goal"] for s in steps])))
                rows.append(row)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "lattice_scaling.json").write_text(json.dumps({"seeds": seeds, "rows": rows}, indent=1))
    header = ("| set (S x θ x T) | transitions | scene | success | plan ms median | plan ms p99 | expanded | "
              "generated | goal in plan |")
    lines = [header, "|" + "---|" * 9]
    for r in rows:
        lines.append(f"| {r['set']} | {r['transitions'] or '–'} | {r['scene']} | {r['success']:.2f} | "
                     f"{r['plan_ms_median']:.1f} | {r['plan_ms_p99']:.1f} | {r.get('expanded_median', '–')} | "
                     f"{r.get('generated_median', '–')} | "
                     f"{'–' if 'goal_reached' not in r else format(r['goal_reached'], '.2f')} |")
    (args.out / "lattice_scaling.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
