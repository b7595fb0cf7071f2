"""Train ``ppo-jax`` (Brax's PPO on a batched JAX scene, footstep_gym/rl/ppo_jax.py), seed after seed; ship them.

Usage::

    python baselines/train_jax.py --timesteps 200000                    # a first, short try (seed 1): runs/ppo-jax/
    python baselines/train_jax.py --seeds 1 2 3 4 5 --ship              # train, ship, write the figures
    python baselines/train_jax.py --report                              # the figures again, from the shipped agents
    python baselines/train_jax.py --recurrent --agent ppo-jax-gru-noise --ship   # a GRU policy (ppo-jax-gru.yml)

Hyperparameters: ``configs/rl/ppo-jax.yml`` (``--config``). Brax trains whole PPO updates in equal chunks between
validations, so the env steps are rounded up (:func:`footstep_gym.rl.ppo_jax.planned`); the first line printed says
what is trained, the number the run records. Each seed trains in this process (JAX on every core
it is given) into ``--runs-dir/<EnvId>_<seed>/`` in rl_zoo3's layout (:func:`footstep_gym.rl.ppo_jax.write_run`);
between training chunks the deterministic policy plays the validation split's first seeds in the reference env
(the learning curve: success against training wall time, jit included, validation left out). With ``--ship``
each run is copied to ``--agents-dir/ppo-jax/<EnvId>_<seed>/`` with a ``manifest.json``
(:func:`footstep_gym.rl.training.ship`, plus the time to 0.95 validation success and the JAX versions); an agent
already shipped there is never replaced without ``--force`` (checked before any training). The figures
(``--results``: ``ppo_jax_<scene>.json``, ``.md`` and ``_curves.png``) put the shipped seeds beside SB3
PPO's shipped door agents (``--reference``).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path
from typing import Any, Sequence

REPO = Path(__file__).resolve().parent.parent
AGENT = "ppo-jax"
#: The success the issue's goal is stated at.
TARGET = 0.95


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, nargs="+", default=[1], help="training seeds (default 1; the shipped: 1-5)")
    p.add_argument("--env", default="door",
                   help="a scene (door, crossing, crowd) or its env id (FootstepDoor-v0): its entry of the config")
    p.add_argument("--config", type=Path, default=None,
                   help="hyperparameter file (default configs/rl/ppo-jax.yml; with --recurrent ppo-jax-gru.yml)")
    p.add_argument("--recurrent", action="store_true",
                   help="a recurrent (GRU / LSTM) policy, footstep_gym/rl/ppo_jax_rnn.py, instead of Brax's MLP")
    p.add_argument("--timesteps", type=int, default=None,
                   help="env steps per seed (default: the config's), rounded up to whole PPO updates")
    p.add_argument("--runs-dir", type=Path, default=REPO / "runs" / AGENT, help="where runs are written")
    p.add_argument("--devices", type=int, default=1,
                   help="CPU cores as JAX devices, over which Brax's trainer splits the envs and each update "
                        "(default 1: the shipped runs' setting; num_envs and batch_size must divide by it)")
    p.add_argument("--tier", default=None,
                   help="train on this tier of the benchmark (replaces the config's env_kwargs tier; e.g. structure, "
                        "noise for the in-distribution tracks)")
    p.add_argument("--agent", default=AGENT,
                   help="the agent's name: its folder under --agents-dir and its row on the board (default ppo-jax)")
    p.add_argument("--ship", action="store_true", help="ship each run to --agents-dir/<agent>/")
    p.add_argument("--force", action="store_true", help="with --ship: replace agents already shipped")
    p.add_argument("--agents-dir", type=Path, default=REPO / "baselines" / "agents", help="the agents folder")
    p.add_argument("--results", type=Path, default=REPO / "baselines" / "results" / "jax",
                   help="where ppo_jax_<scene>.json/.md/_curves.png are written (after --ship, or with --report)")
    p.add_argument("--reference", default="ppo", help="the shipped SB3 agent folder compared with (default ppo)")
    p.add_argument("--report", action="store_true", help="only write the figures from the shipped agents")
    p.add_argument("--no-report", action="store_true",
                   help="with --ship: do not write the figures (seeds trained in parallel processes; --report after)")
    return p


# ---------------------------------------------------------------- the figures
def _curve(run: Path) -> dict[str, list[float]]:
    from footstep_gym.rl.training import success_curve

    return success_curve(run)


def time_to(steps: list[float], wall: list[float], success: list[float], target: float = TARGET) -> tuple:
    """``(env steps, wall s)`` at the first evaluation with success >= ``target`` (None, None if never)."""
    for s, w, r in zip(steps, wall, success):
        if r >= target:
            return s, w
    return None, None


def agent_rows(agents_dir: Path, folder: str, env_id: str) -> list[dict[str, Any]]:
    """One row per shipped seed: steps, wall time, throughput, final success, time (and steps) to :data:`TARGET`.

    An agent whose curve has no wall times (the zoo's evaluations of the SB3 PPO agents) gets them at its
    training's mean rate (manifest's wall time x steps / timesteps), marked ``wall_estimated``."""
    rows = []
    for run in sorted((agents_dir / folder).glob(f"{env_id}_*"), key=lambda p: int(p.name.rsplit("_", 1)[-1])):
        mpath = run / "manifest.json"
        if not mpath.is_file():
            continue
        m = json.loads(mpath.read_text(encoding="utf-8"))
        c = _curve(run)
        estimated = not c.get("wall_time_s")
        wall = c.get("wall_time_s") or [t / m["timesteps"] * m["wall_time_s"] for t in c["timesteps"]]
        steps, secs = time_to(c["timesteps"], wall, c["success"])
        rows.append({"run": run.name, "seed": m["seed"], "timesteps": m["timesteps"], "wall_time_s": m["wall_time_s"],
                     "cpu_time_s": m.get("cpu_time_s"), "cpu_time_to_target_s": m.get(f"cpu_time_to_{TARGET}_s"),
                     "load_average_start_end": m.get("load_average_start_end"),
                     "env_steps_per_s": m["env_steps_per_s"], "final_success": m["final_eval_success"],
                     "final_episodes": m["final_eval_episodes"], "steps_to_target": steps,
                     "time_to_target_s": None if secs is None else round(secs, 1), "wall_estimated": estimated,
                     "curve": {"timesteps": c["timesteps"], "wall_time_s": [round(w, 1) for w in wall],
                               "success": c["success"]}})
    return rows


def median(values: list[float | None]) -> float | None:
    """The median, a seed that never reached the target counted as infinitely slow (None if half or more did not)."""
    import numpy as np

    vals = sorted(np.inf if v is None else v for v in values)
    if not vals:
        return None
    m = float(np.median(vals))
    return None if not np.isfinite(m) else m


def write_report(agents_dir: Path, results: Path, env_id: str, reference: str) -> list[Path]:
    """``ppo_jax_<scene>.json``, ``.md`` and ``_curves.png`` in ``results`` (``<scene>``: ``env_id``'s); their paths."""
    import footstep_gym

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ours = agent_rows(agents_dir, AGENT, env_id)
    ref = agent_rows(agents_dir, reference, env_id)
    if not ours:
        raise SystemExit(f"train_jax.py: no shipped {AGENT} agent for {env_id} in {agents_dir / AGENT}")
    summary = {}
    for name, rows in ((AGENT, ours), (reference, ref)):
        summary[name] = {"seeds": len(rows), "median_time_to_target_s": median([r["time_to_target_s"] for r in rows]),
                         "median_steps_to_target": median([r["steps_to_target"] for r in rows]),
                         "median_wall_time_s": median([r["wall_time_s"] for r in rows]),
                         "median_cpu_time_to_target_s": median([r["cpu_time_to_target_s"] for r in rows])
                         if any(r["cpu_time_s"] is not None for r in rows) else None,
                         "median_env_steps_per_s": median([r["env_steps_per_s"] for r in rows])}
    results.mkdir(parents=True, exist_ok=True)
    data = {"env_id": env_id, "target_success": TARGET, "summary": summary, AGENT: ours, reference: ref}
    stem = f"ppo_jax_{footstep_gym.scenarios.scene_of(env_id)}"
    jpath = results / f"{stem}.json"
    jpath.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")

    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    for rows, color, label in ((ours, "tab:blue", AGENT), (ref, "tab:orange", f"{reference} (SB3)")):
        for i, r in enumerate(rows):
            c = r["curve"]
            ax.plot(c["wall_time_s"], c["success"], color=color, lw=1.0, alpha=0.8,
                    ls="--" if r["wall_estimated"] else "-", label=label if i == 0 else None)
    ax.axhline(TARGET, color="grey", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_xlabel("training wall time [s] (log scale; SB3's dashed: its mean rate)")
    ax.set_ylabel("validation success (deterministic)")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.set_title(f"{env_id}, train tier: validation success vs wall time (2 shared cores)", fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    ppath = results / f"{stem}_curves.png"
    fig.savefig(ppath, dpi=110)
    plt.close(fig)

    def fmt(v: Any, spec: str = ",.0f") -> str:
        return "never" if v is None else format(v, spec)

    lines = [f"# ppo-jax on {env_id} (train tier): time to {TARGET} validation success",
             "", "Written by `python baselines/train_jax.py --report` from the shipped agents' manifests and curves "
             "(`baselines/agents/ppo-jax/`, SB3 PPO's in `baselines/agents/ppo/`). Wall time on the shared 2-core "
             "machine, start-up and jit included, validation episodes left out; validation: the validation split's "
             "first seeds in the reference env, deterministic policy. SB3 PPO's curves have no wall times (the zoo's "
             "evaluations): its time to the target is its step count at the run's mean rate.", "",
             f"| agent | seed | env steps | wall s | env steps/s | steps to {TARGET} | time to {TARGET} [s] | "
             f"CPU s to {TARGET} | load avg (start, end) | final success (episodes) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---|---|"]
    for name, rows in ((AGENT, ours), (reference, ref)):
        for r in rows:
            lines.append(f"| {name} | {r['seed']} | {r['timesteps']:,} | {r['wall_time_s']:,.1f} | "
                         f"{r['env_steps_per_s']:,.0f} | {fmt(r['steps_to_target'])} | "
                         f"{fmt(r['time_to_target_s'], ',.1f')}{' (est.)' if r['wall_estimated'] else ''} | "
                         f"{'-' if r['cpu_time_s'] is None else fmt(r['cpu_time_to_target_s'], ',.1f')} | "
                         f"{r['load_average_start_end'] or '-'} | {r['final_success']} ({r['final_episodes']}) |")
    a, b = summary[AGENT], summary[reference]
    ratio = (b["median_time_to_target_s"] / a["median_time_to_target_s"]
             if a["median_time_to_target_s"] and b["median_time_to_target_s"] else None)
    lines += ["", f"Medians over seeds: {AGENT} reaches {TARGET} in {fmt(a['median_time_to_target_s'], ',.1f')} s "
              f"({fmt(a['median_steps_to_target'])} env steps, {a['seeds']} seeds); {reference} (SB3) in "
              f"{fmt(b['median_time_to_target_s'], ',.1f')} s ({fmt(b['median_steps_to_target'])} env steps, "
              f"{b['seeds']} seeds)" + (f": {ratio:.1f}x faster in wall time." if ratio else ".")
              + (f" {AGENT}'s process CPU time to {TARGET} (all threads, validation left out; a bound that does not "
                 f"move with the machine's load: on two free cores its wall time would be at least half of it): "
                 f"median {fmt(a['median_cpu_time_to_target_s'], ',.1f')} s."
                 if a.get("median_cpu_time_to_target_s") is not None else ""),
              "", f"![curves]({ppath.name})", ""]
    mpath = results / f"{stem}.md"
    mpath.write_text("\n".join(lines), encoding="utf-8")
    return [jpath, mpath, ppath]


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from footstep_gym.errors import ConfigError
    from footstep_gym.scenarios import resolve_env_id

    try:
        env_id = resolve_env_id(args.env)
    except ConfigError as exc:
        parser.error(f"--env: {exc}")
    if args.report:
        for path in write_report(args.agents_dir, args.results, env_id, args.reference):
            print(path)
        return 0
    if any(s < 0 for s in args.seeds):
        parser.error(f"--seeds: a training seed is a whole number >= 0, got {min(args.seeds)}")
    if len(set(args.seeds)) != len(args.seeds):
        parser.error(f"--seeds: a seed given twice ({' '.join(map(str, args.seeds))})")
    if not args.agent or "/" in args.agent or args.agent.startswith("."):
        parser.error(f"--agent: a folder name, got {args.agent!r}")
    if args.force and not args.ship:
        parser.error("--force applies with --ship only")
    if args.timesteps is not None and args.timesteps < 1:
        parser.error("--timesteps must be >= 1")
    if args.devices < 1:
        parser.error("--devices must be >= 1")
    if args.recurrent and args.devices != 1:
        parser.error("--devices: the recurrent trainer runs on one device")
    from footstep_gym.jax import speed

    if args.devices > 1:
        try:
            if speed.use_cpu_devices(args.devices) < args.devices:
                parser.error(f"--devices {args.devices}: JAX has fewer devices here")
        except RuntimeError as exc:  # JAX started before (train_jax.main called in a process that used JAX)
            parser.error(f"--devices {args.devices}: {exc}")
    from footstep_gym.rl import ppo_jax as ppo
    from footstep_gym.rl import ppo_jax_rnn

    learner = ppo_jax_rnn if args.recurrent else ppo
    try:
        asked = learner.load_config(env_id, args.config)
        if args.tier is not None:
            asked = ppo.with_tier(asked, args.tier)
        cfg = ppo.planned(asked, args.timesteps)
    except ConfigError as exc:
        print(f"train_jax.py: {exc}", file=sys.stderr)
        return 2
    if cfg.num_envs % args.devices or cfg.batch_size % args.devices:
        parser.error(f"--devices {args.devices}: num_envs ({cfg.num_envs}) and batch_size ({cfg.batch_size}) of "
                     f"{cfg.env_id} must divide by it")
    print(ppo.plan_line(args.timesteps or asked.num_timesteps, cfg), f"on {ppo.jax_devices()}", flush=True)
    if args.ship and not args.force:
        taken = [str(d) for s in args.seeds if (d := args.agents_dir / args.agent / f"{cfg.env_id}_{s}").exists()]
        if taken:
            print(f"train_jax.py: already shipped, not replaced (--force replaces them): {', '.join(taken)}",
                  file=sys.stderr)
            return 2
    command = "python baselines/train_jax.py " + shlex.join(argv if argv is not None else sys.argv[1:])
    for seed in args.seeds:
        print(f"{args.agent} {cfg.env_id} seed {seed}", flush=True)

        def progress(steps: int, wall: float, rate: float) -> None:
            print(f"  {steps:>10,} env steps  {wall:7.1f} s  validation success {rate:.2f}", flush=True)

        result = learner.train(cfg, seed, progress=progress)
        run = ppo.write_run(result, args.runs_dir, command)
        t = result.time_to(TARGET)
        print(f"  done: {result.timesteps:,} env steps in {result.wall_time_s:.1f} s "
              f"({result.timesteps / result.wall_time_s:,.0f} env steps/s), time to {TARGET}: "
              f"{'never' if t is None else f'{t:.1f} s'}; run {run}", flush=True)
        if args.ship:
            dest = ppo.ship(run, result, args.agents_dir, args.agent, TARGET)
            print(f"  shipped: {dest}", flush=True)
    if args.ship and not args.no_report and args.agent == AGENT:
        for path in write_report(args.agents_dir, args.results, cfg.env_id, args.reference):
            print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
