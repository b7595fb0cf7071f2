"""Steps/s of the batched JAX backend beside the reference env; compile time apart.

    python baselines/jax_speed.py                                  # the door: N = 1, 64, 1024, 4096, 16384; both workloads
    python baselines/jax_speed.py --scene crowd                    # the scripted crowd
    python baselines/jax_speed.py --scene crowd --tier structure --tier-cell counter_flow   # an ORCA cell
    python baselines/jax_speed.py --sizes 4096 --workloads walk --repeats 5
    python baselines/jax_speed.py --dtype float64                  # (sets JAX's 64-bit mode)
    python baselines/jax_speed.py --devices 1                      # the batch on one core (default: split over all)
    python baselines/jax_speed.py --sizes 4096 --workloads jitter --vector   # gym.make_vec beside it, same run

Prints one table per workload (engine and workloads: ``footstep_gym/jax/speed.py``), after the reference env's
and a Gymnasium ``SyncVectorEnv``'s rates on the same workload: per N, the median steps/s over the repeats, the
slowest and fastest repeat, the ratio to one reference env measured in the same run on the same workload, the
first call's compile time and the state's size per env. With ``--vector``, each N is also stepped through
``gymnasium.make_vec`` (numpy in and out, Gymnasium's autoreset, the same devices) and, inside JAX, with the
observations computed (the plain in-JAX rollout reads none, so XLA drops them; a learner reads them): the
make_vec steps/s, its ratio to each in-JAX rate and to the reference env. On a shared machine the figures move with the load: quote
them as measured, with the load average this prints.
"""

from __future__ import annotations

import argparse
import os
import platform


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", default="1,64,1024,4096,16384", help="comma-separated batch sizes N")
    p.add_argument("--workloads", default="random,walk", help="comma-separated: random, walk, jitter")
    p.add_argument("--steps", type=int, default=0,
                   help="footsteps per timed run (default: about 2^18 env steps per run, at least 32)")
    p.add_argument("--repeats", type=int, default=3, help="timed runs per size (median reported)")
    p.add_argument("--reference-steps", type=int, default=3000, help="reference env steps timed per workload")
    p.add_argument("--sync-envs", type=int, default=8,
                   help="reference envs in the SyncVectorEnv timed beside (0: none)")
    p.add_argument("--scene", default="door", help="door, crossing or crowd (footstep_gym.jax.scenes.SCENES)")
    p.add_argument("--tier", default="train", help="benchmark tier of the scene (default train)")
    p.add_argument("--tier-cell", default=None, help="one cell of the tier (default: a cell drawn per episode)")
    p.add_argument("--dtype", default="float32", choices=("float32", "float64"))
    p.add_argument("--vector", action="store_true",
                   help="also step each N through gymnasium.make_vec (numpy in and out) in the same run")
    p.add_argument("--block", type=int, default=None,
                   help="collision checks per sweep iteration (default: footstep_gym.jax.shapes.DEFAULT_BLOCK)")
    p.add_argument("--chunk", type=int, default=64, help="envs per vmap chunk (FootstepJaxEnv.step_batch)")
    p.add_argument("--devices", type=int, default=0,
                   help="JAX devices the batch is split over (default: on a CPU, one per core; on a GPU, 1); a size "
                        "N that does not split evenly runs on one device")
    args = p.parse_args(argv)
    try:
        args.sizes = [int(s) for s in args.sizes.split(",")]
    except ValueError:
        p.error(f"--sizes must be comma-separated integers, got {args.sizes!r}")
    if any(n < 1 for n in args.sizes):
        p.error("--sizes must be >= 1")
    args.workloads = args.workloads.split(",")
    bad = [w for w in args.workloads if w not in ("random", "walk", "jitter")]
    if bad:
        p.error(f"unknown workload(s) {bad}; choose from random, walk, jitter")
    if (args.repeats < 1 or args.steps < 0 or args.reference_steps < 1 or args.chunk < 1 or args.devices < 0
            or args.sync_envs < 0):
        p.error("--repeats, --reference-steps and --chunk must be >= 1, --steps, --devices and --sync-envs >= 0")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.dtype == "float64":
        os.environ["JAX_ENABLE_X64"] = "1"
    import jax

    from footstep_gym.jax import speed

    speed.use_cpu_devices(args.devices or None)  # on a GPU, its devices are JAX's and this splits only the host
    devices = len(jax.devices())
    from footstep_gym.jax.env import FootstepJaxEnv
    from footstep_gym.scenarios import SCENARIOS

    if args.scene not in SCENARIOS:
        print(f"jax_speed.py: unknown scene {args.scene!r}; choose from {sorted(SCENARIOS)}")
        return 2
    env_id = SCENARIOS[args.scene].env_id
    from footstep_gym.jax.shapes import DEFAULT_BLOCK

    args.block = args.block or DEFAULT_BLOCK
    tier = {"tier": args.tier} if args.tier_cell is None else {"tier": args.tier, "tier_cell": args.tier_cell}
    env = FootstepJaxEnv(args.scene, dtype=args.dtype, block=args.block, **tier)
    where = " ".join(f"{k}={v}" for k, v in tier.items())
    print(f"{env_id} {where} dtype={args.dtype} block={args.block} chunk={args.chunk}; jax {jax.__version__} on "
          f"{jax.devices()[0].platform} x {devices} device(s) ({os.cpu_count()} CPUs), "
          f"{platform.processor() or platform.machine()}; "
          f"load average {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    for workload in args.workloads:
        ref = speed.reference_rate(args.reference_steps, workload, tier, env_id=env_id)
        print(f"\n{workload}: reference env (one FootstepEnv) {ref:,.0f} steps/s")
        if args.sync_envs:
            sync = speed.sync_vector_rate(max(1, args.reference_steps // args.sync_envs), workload,
                                          tier, args.sync_envs, env_id=env_id)
            print(f"{workload}: Gymnasium SyncVectorEnv of {args.sync_envs} reference envs {sync:,.0f} env steps/s")
        vec_head = (f" {'+obs/s':>12} {'make_vec/s':>12} {'vec/jax':>7} {'vec/+obs':>8} {'vec x ref':>9}"
                    if args.vector else "")
        print(f"{'N':>7} {'devices':>7} {'steps/run':>9} {'steps/s':>12} {'min':>12} {'max':>12} {'x ref':>8} "
              f"{'compile s':>9} {'state B/env':>11}{vec_head}")
        for n in args.sizes:
            steps = args.steps or max(32, (1 << 18) // n)
            d = devices if n % devices == 0 else 1
            r = speed.measure(env, n, steps, args.repeats, workload, chunk=args.chunk, devices=d)
            vec = ""
            if args.vector:
                o = speed.measure(env, n, steps, args.repeats, workload, chunk=args.chunk, devices=d, observe=True)
                v = speed.vector_rate(env_id, n, max(8, steps // 4), args.repeats, workload,
                                      {**tier, "dtype": args.dtype, "block": args.block,
                                       "chunk": args.chunk}, devices=d)
                vec = (f" {o.steps_per_s:>12,.0f} {v.steps_per_s:>12,.0f} {v.steps_per_s / r.steps_per_s:>7.2f} "
                       f"{v.steps_per_s / o.steps_per_s:>8.2f} {v.steps_per_s / ref:>9.0f}")
            print(f"{n:>7} {d:>7} {steps:>9} {r.steps_per_s:>12,.0f} {min(r.repeats):>12,.0f} {max(r.repeats):>12,.0f} "
                  f"{r.steps_per_s / ref:>8.0f} {r.compile_s:>9.1f} {r.state_bytes:>11}{vec}", flush=True)
    print(f"\nload average after: {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
