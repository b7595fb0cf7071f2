"""Replay reference-env episodes in the JAX backend and print how well they agree.

    python baselines/jax_replay.py                                    # the door: 1000 walk + 1000 fuzz + 100 planner
    python baselines/jax_replay.py --scene crowd --walk 3000 --fuzz 3000 --planner 300
    python baselines/jax_replay.py --scene crowd --tier structure --tier-cell dense
    python baselines/jax_replay.py --dtype float32                    # the float32 path

Episodes are recorded in the reference env (``gymnasium.make("FootstepDoor-v0", tier=...)``, or the scene's id) on
train-split seeds (``configs/eval.yaml``: from ``--first-seed``), then replayed in batches in the JAX env
(``footstep_gym/jax/replay.py``). Per policy kind it prints: episodes, how they ended in the reference env,
the share that ended the same way at the same step, the disagreements (near-ties, whose reference margin at
the step is below ``NEAR_TIE`` m in float64, ``NEAR_TIE_32`` in float32, and others, listed), and the largest
observation, reward and clearance differences over the steps both envs took. Exit status 1 if agreement is below
99.5 % or a disagreement is not a near-tie.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import sys
from pathlib import Path


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--walk", type=int, default=1000, help="episodes of open-loop random walks (float32 actions)")
    p.add_argument("--fuzz", type=int, default=1000, help="episodes of fuzzed float32 actions")
    p.add_argument("--planner", type=int, default=100, help="episodes of the period-aware planner")
    p.add_argument("--first-seed", type=int, default=0, help="first train-split seed (default 0)")
    p.add_argument("--scene", default="door", help="door, crossing or crowd (footstep_gym.jax.scenes.SCENES)")
    p.add_argument("--tier", default="train")
    p.add_argument("--tier-cell", default=None, help="one cell of the tier (default: a cell drawn per episode)")
    p.add_argument("--dtype", default="float64", choices=("float32", "float64"))
    p.add_argument("--batch", type=int, default=256, help="episodes replayed per compiled batch")
    p.add_argument("--out", type=Path, default=None, help="write the figures as JSON here")
    args = p.parse_args(argv)
    if min(args.walk, args.fuzz, args.planner) < 0 or args.batch < 1:
        p.error("episode counts must be >= 0 and --batch >= 1")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.dtype == "float64":
        os.environ["JAX_ENABLE_X64"] = "1"
    from tqdm import tqdm

    from footstep_gym.errors import ConfigError
    from footstep_gym.jax import replay as R
    from footstep_gym.jax.env import FootstepJaxEnv
    from footstep_gym.scenarios import SCENARIOS

    kw = {"tier": args.tier} if args.tier_cell is None else {"tier": args.tier, "tier_cell": args.tier_cell}
    try:
        jenv = FootstepJaxEnv(args.scene, dtype=args.dtype, **kw)
    except ConfigError as exc:
        print(f"jax_replay.py: {exc}", file=sys.stderr)
        return 2
    env_id = SCENARIOS[args.scene].env_id
    tol = {"float64": (1e-6, 1e-9), "float32": (1e-4, 1e-4)}[args.dtype]
    near_tie = {"float64": R.NEAR_TIE, "float32": R.NEAR_TIE_32}[args.dtype]
    report, ok = {}, True
    for kind, count in (("walk", args.walk), ("fuzz", args.fuzz), ("planner", args.planner)):
        if not count:
            continue
        seeds = range(args.first_seed, args.first_seed + count)
        agreements = []
        with tqdm(total=count, desc=f"{kind}", file=sys.stderr) as bar:
            for start in range(0, count, args.batch):
                chunk = seeds[start:start + args.batch]
                episodes = []
                for s in chunk:
                    episodes.append(R.record(env_id, s, kind, kw))
                    bar.update(1)
                agreements += R.compare(episodes, R.replay(jenv, episodes, pad_to=R.max_steps(episodes)),
                                        near_tie)
        same = sum(a.same for a in agreements)
        ties = [a for a in agreements if not a.same and a.near_tie]
        others = [a for a in agreements if not a.same and not a.near_tie]
        obs_err = max(a.obs_error for a in agreements)
        rew_err = max(a.reward_error for a in agreements)
        clear_err = max(a.clearance_error for a in agreements)
        outcomes = collections.Counter(a.reference[0] for a in agreements)
        share = same / len(agreements)
        ok &= share >= 0.995 and not others
        report[kind] = {"episodes": len(agreements), "outcomes": dict(outcomes), "same_ending": share,
                        "near_ties": len(ties), "other_disagreements": len(others),
                        "max_obs_error": obs_err, "max_reward_error": rew_err, "max_clearance_error": clear_err,
                        "steps": sum(a.reference[1] for a in agreements),
                        "obs_within_tolerance": sum(a.obs_error <= tol[0] for a in agreements) / len(agreements),
                        "reward_within_tolerance": sum(a.reward_error <= tol[1] for a in agreements)
                        / len(agreements)}
        print(f"{kind}: {len(agreements)} episodes ({report[kind]['steps']} steps; reference endings "
              f"{dict(outcomes)}): same ending at the same step {100 * share:.2f} %; near-ties {len(ties)}, "
              f"other disagreements {len(others)}; max |obs diff| {obs_err:.3g}, max |reward diff| {rew_err:.3g}, "
              f"max |clearance diff| {clear_err:.3g} m "
              f"(within {tol[0]:g} / {tol[1]:g}: {100 * report[kind]['obs_within_tolerance']:.2f} % / "
              f"{100 * report[kind]['reward_within_tolerance']:.2f} % of episodes)", flush=True)
        for a in ties + others:
            print(f"  seed {a.seed}: reference {a.reference}, jax {a.jax}, reference margin {a.margin:.3g} m"
                  f"{' (near-tie)' if a.near_tie else ''}")
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"scene": args.scene, "dtype": args.dtype, "tier": args.tier,
                                             "tier_cell": args.tier_cell, "first_seed": args.first_seed,
                                             "kinds": report}, indent=1))
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
