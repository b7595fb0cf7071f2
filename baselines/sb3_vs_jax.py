"""The same learner across trainers: SB3 PPO and ppo-jax (Brax's PPO), matched hyperparameters, on one scene.

Usage::

    python baselines/sb3_vs_jax.py --trainer sb3 --seeds 1 2 3     # one curve per seed: runs/sb3_vs_jax/*.json
    python baselines/sb3_vs_jax.py --trainer jax --seeds 1 2 3
    python baselines/sb3_vs_jax.py --report                        # the figure, json and md from those curves

SB3 PPO's values are the shipped ``ppo`` agents' (``configs/rl/ppo.yml``'s entry of the env), over their budget
(its ``n_timesteps``, rounded up to whole updates between validations); ppo-jax gets the same values
(:func:`footstep_gym.rl.matched.matched_jax_config`; what Brax does otherwise: ``matched.DIFFERENCES``). Both train on
the JAX scene of the env at ``--tier`` and are validated after the same PPO updates on the same validation seeds
in the reference env (footstep_gym/rl/matched.py). Runs go to ``--runs-dir``, never to the shipped agents.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path
from typing import Sequence

REPO = Path(__file__).resolve().parent.parent
TRAINERS = {"sb3": "SB3 PPO", "jax": "ppo-jax (Brax PPO)"}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--trainer", choices=sorted(TRAINERS), help="train this trainer's seeds")
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3], help="training seeds (default 1 2 3)")
    p.add_argument("--env", default="FootstepDoor-v0", help="env id (default FootstepDoor-v0)")
    p.add_argument("--tier", default="train", help="the benchmark tier both train on (default train)")
    p.add_argument("--timesteps", type=int, default=None, help="env steps (default: configs/rl/ppo.yml's)")
    p.add_argument("--points", type=int, default=13, help="validation points, the first at 0 steps (default 13)")
    p.add_argument("--episodes", type=int, default=40, help="validation episodes per point (default 40)")
    p.add_argument("--unroll", type=int, default=32, help="Brax's unroll_length (default 32)")
    p.add_argument("--runs-dir", type=Path, default=REPO / "runs" / "sb3_vs_jax", help="where the curves go")
    p.add_argument("--results", type=Path, default=REPO / "baselines" / "results" / "learning_curves",
                   help="where sb3_vs_jax_<scene>.{json,md,png} go (--report)")
    p.add_argument("--report", action="store_true", help="write the comparison from the curves in --runs-dir")
    p.add_argument("--force", action="store_true", help="with --trainer: replace curves already in --runs-dir")
    return p


def run_path(runs_dir: Path, trainer: str, env_id: str, seed: int) -> Path:
    return runs_dir / f"{trainer}_{env_id}_{seed}.json"


def row(point: Sequence[float]) -> list:
    """A curve point as the run file keeps it: env steps, wall [s] and CPU [s] to 0.1 s (CPU None: not measured)."""
    steps, wall, rate, cpu = point
    return [int(steps), round(wall, 1), rate, None if cpu is None else round(cpu, 1)]


def train(args: argparse.Namespace) -> None:
    from footstep_gym.evaluation.splits import split_seeds
    from footstep_gym.rl import matched

    sb3 = matched.sb3_hyperparameters(args.env)
    timesteps = args.timesteps or sb3["n_timesteps"]
    env_kwargs = {"tier": args.tier}
    seeds = split_seeds("validation", args.episodes)
    total, every = matched.schedule(sb3, timesteps, args.points)
    print(f"{TRAINERS[args.trainer]} on {args.env} (tier {args.tier}): {total:,} env steps, a validation every "
          f"{every:,} on {args.episodes} validation seeds", flush=True)
    taken = [str(p) for seed in args.seeds if (p := run_path(args.runs_dir, args.trainer, args.env, seed)).exists()]
    if taken and not args.force:
        raise SystemExit(f"sb3_vs_jax.py: curves already there, not replaced (--force replaces them): {', '.join(taken)}")
    args.runs_dir.mkdir(parents=True, exist_ok=True)
    for seed in args.seeds:
        path = run_path(args.runs_dir, args.trainer, args.env, seed)
        record = {"trainer": args.trainer, "env_id": args.env, "env_kwargs": env_kwargs, "seed": seed,
                  "episodes": args.episodes, "complete": False, "curve": [],
                  "machine": {"python": platform.python_version(), "machine": platform.machine(),
                              "logical_cpus": os.cpu_count(), "load_average_start": os.getloadavg()[0]}}

        def save(point: Sequence[float]) -> None:
            steps, wall, rate, _ = point
            record["curve"].append(row(point))
            print(f"  seed {seed}: {steps:>8,} env steps  {wall:7.1f} s  success {rate:.3f}", flush=True)
            path.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")

        if args.trainer == "sb3":
            record["hyperparameters"] = sb3
            _, curve = matched.train_sb3(sb3, args.env, env_kwargs, seed, timesteps, args.points, seeds,
                                         progress=save)
        else:
            from footstep_gym.rl import ppo_jax

            cfg = matched.matched_jax_config(sb3, args.env, env_kwargs, timesteps, args.points, args.episodes,
                                             args.unroll)
            record["hyperparameters"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in vars(cfg).items()}
            result = ppo_jax.train(cfg, seed, validation_seeds=seeds,
                                   progress=lambda steps, wall, rate: save((steps, wall, rate, None)))
            curve = result.curve
        record["curve"] = [row(point) for point in curve]
        record["complete"] = True
        record["machine"]["load_average_end"] = os.getloadavg()[0]
        path.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        print(f"  {path}", flush=True)


def report(args: argparse.Namespace) -> list[Path]:
    import footstep_gym
    from footstep_gym.rl import matched
    from footstep_gym.rl.compute import plateau_tolerance

    records = {t: [json.loads(p.read_text(encoding="utf-8"))
                   for p in sorted(args.runs_dir.glob(f"{t}_{args.env}_*.json"))] for t in TRAINERS}
    missing = [t for t, rs in records.items() if not rs]
    if missing:
        raise SystemExit(f"sb3_vs_jax.py: no curves of {', '.join(missing)} in {args.runs_dir}")
    episodes = {r["episodes"] for rs in records.values() for r in rs}
    if len(episodes) != 1:
        raise SystemExit(f"sb3_vs_jax.py: the curves differ in validation episodes ({sorted(episodes)})")
    n = episodes.pop()
    curves = {TRAINERS[t]: [[tuple(p) for p in r["curve"]] for r in rs] for t, rs in records.items()}
    summary = matched.summarise(curves, n)
    scene = footstep_gym.scenarios.scene_of(args.env)
    args.results.mkdir(parents=True, exist_ok=True)
    stem = args.results / f"sb3_vs_jax_{scene}"
    data = {"env_id": args.env, "env_kwargs": records["sb3"][0]["env_kwargs"], "validation_episodes": n,
            "command": "python baselines/sb3_vs_jax.py --trainer {sb3,jax} --seeds 1 2 3; --report",
            "plateau_tolerance": plateau_tolerance(n), "differences": list(matched.DIFFERENCES),
            "summary": summary, "runs": {t: rs for t, rs in records.items()}}
    Path(f"{stem}.json").write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    tier = data["env_kwargs"].get("tier", "")
    matched.plot(curves, f"{stem}.png", f"{args.env}, {tier} tier: SB3 PPO vs ppo-jax, matched hyperparameters "
                                        f"({n} validation seeds per point)")
    total = max(r["curve"][-1][0] for rs in records.values() for r in rs if r["complete"]) if any(
        r["complete"] for rs in records.values() for r in rs) else None
    partial = [f"{TRAINERS[t]} seed {r['seed']} ({r['curve'][-1][0]:,} env steps)" for t, rs in records.items()
               for r in rs if not r["complete"]]

    machines = [r["machine"] for rs in records.values() for r in rs]
    machine = machines[0]
    load = (min(m["load_average_start"] for m in machines),
            max(m.get("load_average_end", m["load_average_start"]) for m in machines))

    def listed(values: Sequence, spec: str) -> str:
        return ", ".join("–" if v is None else format(v, spec) for v in values)

    lines = [f"# The same learner across trainers on {args.env}", "",
             f"Written by `python baselines/sb3_vs_jax.py --report`. Both trainers on the JAX scene "
             f"({data['env_kwargs']}), SB3 PPO's hyperparameters (configs/rl/ppo.yml) in both, over SB3's budget "
             f"({'' if total is None else f'{total:,} env steps: '}whole updates between validations); each point: "
             f"the deterministic policy on the validation split's first {n} seeds in the reference env, after the "
             f"same PPO updates. Times: training only (validation left out; ppo-jax's include its jit), on a shared "
             f"{machine['logical_cpus']}-core machine whose load average was {load[0]:.0f}-{load[1]:.0f} during "
             f"these runs: CPU time is the fairer cost.", ""]
    if partial:
        lines += [f"**Partial**: still training when this was written: {'; '.join(partial)}; their curves stop "
                  "there (rerun `--report` when they end).", ""]
    lines += ["| trainer | seeds | env steps reached | latest success | plateaued (last 3 within "
              f"{plateau_tolerance(n):.3f}) | env steps to 0.9 | CPU s to 0.9 | CPU s (all) |",
              "|---|---:|---|---|---|---|---|---|"]
    for name, s in summary.items():
        lines.append(f"| {name} | {s['seeds']} | {listed(s['reached_steps'], ',')} | "
                     f"{listed(s['latest_success'], '.3f')} | {sum(s['plateaued'])}/{s['seeds']} | "
                     f"{listed(s['steps_to_0.9'], ',')} | {listed(s['cpu_s_to_0.9'], ',.0f')} | "
                     f"{listed(s['cpu_s'], ',.0f')} |")
    names = list(summary)
    longest = max((s["steps"] for s in summary.values()), key=len)
    lines += ["", "Mean success per validation point (seeds that reached it):", "",
              "| env steps | " + " | ".join(names) + " |", "|---:|" + "---:|" * len(names)]
    for i, st in enumerate(longest):
        cells = [f"{s['mean_success'][i]:.3f} ({s['seeds_per_point'][i]})" if i < len(s["steps"]) else "–"
                 for s in summary.values()]
        lines.append(f"| {st:,} | " + " | ".join(cells) + " |")
    lines += ["", "What Brax's PPO does otherwise:", ""] + [f"- {d}" for d in matched.DIFFERENCES]
    lines += ["", f"![curves]({Path(f'{stem}.png').name})", ""]
    Path(f"{stem}.md").write_text("\n".join(lines), encoding="utf-8")
    return [Path(f"{stem}.{e}") for e in ("json", "md", "png")]


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.report == (args.trainer is not None):
        parser.error("one of --trainer or --report")
    if args.points < 2 or args.episodes < 1:
        parser.error("--points must be >= 2 and --episodes >= 1")
    if args.report:
        for path in report(args):
            print(path)
        return 0
    train(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
