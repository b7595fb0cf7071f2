"""How fast footstep_gym is: env steps/s, LIPM checks/s, planning time per footstep, memory, PPO training, tiers.

    python baselines/speed.py            # quick, the default
    python baselines/speed.py --full     # more repetitions, more episodes
    python baselines/speed.py --out runs/speed --sections env,lipm
    python baselines/speed.py --sections env --compare-with /tmp/before   # + the steady walk on another checkout
    python baselines/speed.py --sections tiers --out runs/speed_tiers     # per benchmark tier only

Prints markdown tables and writes ``<out>/speed.json`` and ``<out>/speed.md``. Every rate is the median and
spread (IQR and min/max) over repetitions measured in this one run, after a warm-up,
with ``time.perf_counter``. Measured:

* **env steps/s**, one process, for ``FootstepDoor-v0``, ``FootstepCrossing-v0`` and
  ``FootstepCrowd-v0`` with three kinds of commands: ``random`` (seeded
  ``action_space`` samples; these fall often, so most steps are short), ``near_nominal``
  (the nominal command walking forward at half the largest stride, plus small seeded
  noise, clipped to the robot's limits: full footsteps with their collision sweeps) and
  ``planner`` (the period-aware planner's commands, recorded once and replayed from the
  same seeds, so the planner's time is excluded and measured separately). Episodes reset
  when done and resets are inside the timed loop (the episode length is reported). The
  same through ``gym.make_vec(id, num_envs=2, vectorization_mode="sync"/"async")``
  (``AsyncVectorEnv``: 2 worker processes, checked and recorded; steps/s counts sub-env
  transitions, the reset-only steps of the default ``NEXT_STEP`` autoreset are timed but
  not counted), and the same for ``CartPole-v1``, ``Pendulum-v1`` and ``BipedalWalker-v3``
  (random commands; skipped when not installed). Single-process cells are interleaved
  round by round, so the FootstepDoor / BipedalWalker ratio is paired per round;
* **LIPM feasibility checks/s**: ``lipm.check_step`` (one command, plain Python) and
  ``lipm.check_steps`` with batches of 1, 32 and 1024 (commands/s);
* **planning time per footstep** (``policy.act``; median, p95, p99) of ``period-aware``,
  ``fixed-period`` and ``pso-only`` on each env, and their success rates on the same seeds
  (the planners alternate seed by seed), timed through the evaluation runner's episode loop
  after its warm-up (``footstep_gym.evaluation.runner``: 10 untimed acts per planner and env);
* **PPO training throughput**: env steps/s inside ``model.learn`` with 1 and 2 envs for
  ``FootstepDoor-v0`` beside ``CartPole-v1`` with the same network and hyperparameters (the
  ceiling: what PPO itself costs), through ``footstep_gym.rl.training.ppo_throughput`` in a
  subprocess (torch stays out of this one);
* with ``--compare-with DIR``, the ``FootstepDoor-v0`` steady walk once more on the
  ``footstep_gym`` package of another checkout in ``DIR`` (a worker process, in the same
  interleaved rounds): a before/after figure from one run;
* **peak memory** of one env (make + reset + N near-nominal steps) and of the period-aware
  planner (M acts), on each env: the ``tracemalloc`` peak, and the peak RSS above the
  baseline (the kernel's ``VmHWM`` reset at the baseline; else sampled after every step;
  C allocations included), each figure in a fresh subprocess;
* **per tier** (``tiers``; ``speedlib.tier_rates``): on every cell of every benchmark tier of every
  scene (``gym.make(id, tier=TIER, tier_cell=CELL)``, ``configs/benchmark.yaml``), the period-aware
  planner's time per footstep through the evaluation runner after its warm-up of the cell (median, p99,
  pooled over a tier's cells), and env steps/s, one process, with its commands recorded once and replayed
  from the same seeds (the env section's interleaved rounds; resets timed); a tier's rate is per round the
  median over its cells, and its ratio to the scene's ``paper`` tier is paired per round.

Targets (PASS/MISS in the output; in ``speedlib.targets``, never in timed tests): FootstepDoor
steps/s >= 2x BipedalWalker's on a steady walk (near-nominal commands; >= 1x with random
commands, which mostly time reset, and with the planner's commands); batched LIPM >= 1e6 commands/s at batch 1024; period-aware
planning median <= 1 % and p99 <= 5 % of the nominal period per footstep, and >= 10x
faster than pso-only at no lower success rate; the ``hard`` tier's steps/s >= 0.5x ``paper``'s per scene (the
paper crowd is the scripted one; each ORCA crowd cell against it too), and the period-aware planner on
``hard`` at a median <= 2 ms and a p99 <= 20 ms per footstep.

The code is ``baselines/speedlib`` (one module per section; see its docstring), beside this file and
not part of the installed package; this file is its command line.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from speedlib.env_rates import bench_envs
from speedlib.fmt import finite_json
from speedlib.lipm_rates import bench_lipm
from speedlib.machine import loadavg, machine_info
from speedlib.memory_use import bench_memory
from speedlib.planner_times import bench_planners
from speedlib.ppo_rates import bench_ppo
from speedlib.settings import MODES, SECTIONS, log
from speedlib.reports import speed_report
from speedlib.targets import evaluate_targets
from speedlib.tier_rates import bench_tiers

from footstep_gym.robot import load_robot


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n")[0] + " Quick mode by default; "
        "--full for more repetitions and episodes. Prints markdown tables (with each target's PASS/MISS) on "
        "stdout, progress on stderr, and writes <out>/speed.json and <out>/speed.md.")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="the default: few repetitions, 4 seeds per planner and env")
    g.add_argument("--full", action="store_true",
                   help="more repetitions (21 per cell) and 12 seeds per planner and env")
    g.add_argument("--smoke", action="store_true", help=argparse.SUPPRESS)  # tiny, for the tests
    p.add_argument("--out", type=Path, default=Path("runs/speed"), help="folder for speed.json and speed.md")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--sections", default=",".join(SECTIONS),
                   help=f"comma-separated subset of {','.join(SECTIONS)}")
    p.add_argument("--compare-with", type=Path, default=None, metavar="DIR",
                   help="also time the FootstepDoor-v0 steady walk on the footstep_gym package found in DIR "
                        "(another checkout: the 'before' of a change), in the same interleaved rounds")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    args = parse_args(argv)
    if args.compare_with is not None and not (args.compare_with / "footstep_gym" / "__init__.py").is_file():
        raise SystemExit(f"--compare-with {args.compare_with}: no footstep_gym package there")
    settings = MODES["full" if args.full else "smoke" if args.smoke else "quick"]
    sections = [s.strip() for s in args.sections.split(",") if s.strip()]
    unknown = set(sections) - set(SECTIONS)
    if unknown:
        raise SystemExit(f"unknown section(s) {sorted(unknown)}; choose from {SECTIONS}")
    robot = load_robot()
    started = time.time()
    t0 = time.perf_counter()
    res: dict[str, Any] = {"meta": {"mode": settings.name, "settings": settings.__dict__, "seed": args.seed,
                                    "sections": sections, "machine": machine_info(),
                                    "started_unix": started, "nominal_period_s": robot.nominal_period}}
    res["meta"]["load_average_start"] = loadavg()
    replays: dict[str, list] = {}
    if "planners" in sections or "env" in sections:  # the env section replays the planner's commands
        log("planners ...")
        planners, replays = bench_planners(settings, args.seed)
        if "planners" in sections:
            res["planners"] = planners
    if "lipm" in sections:
        log("lipm ...")
        res["lipm"] = bench_lipm(settings, args.seed)
    if "env" in sections:
        log("env steps ...")
        res["env_steps"] = bench_envs(settings, args.seed, replays, args.compare_with)
        if args.compare_with is not None:
            res["meta"]["compare_with"] = str(args.compare_with)
    if "memory" in sections:
        log("memory ...")
        res["memory"] = bench_memory(settings)
    if "ppo" in sections:
        log("ppo ...")
        res["ppo"] = bench_ppo(settings)
    if "tiers" in sections:
        log("tiers ...")
        res["tiers"] = bench_tiers(settings, args.seed)
    res["meta"]["duration_s"] = time.perf_counter() - t0
    res["meta"]["torch_imported"] = "torch" in sys.modules  # the benchmarked paths are torch-free
    res["meta"]["load_average_end"] = loadavg()
    res["targets"], res["ratios"] = evaluate_targets(res, robot.nominal_period)
    text = speed_report(res)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "speed.json").write_text(json.dumps(finite_json(res), indent=2) + "\n", encoding="utf-8")
    (args.out / "speed.md").write_text(text + "\n", encoding="utf-8")
    log(f"wrote {args.out / 'speed.json'} and {args.out / 'speed.md'}")
    return res


if __name__ == "__main__":
    main()
