"""Crowd footsteps/s of ORCA as array functions (footstep_gym/scenes/orca.py, JAX) beside pyrvo (RVO2), same run.

    python baselines/orca_speed.py                        # each ORCA cell of the crowd's structure tier, N = 4096
    python baselines/orca_speed.py --sizes 256,4096 --steps 20

Per cell: one reference crowd's footsteps of 0.8 s (8 ORCA steps, pyrvo through OrcaCrowd.advance, 4 footsteps of each
of the 64 crowds after one of warm-up) per second,
and N crowds stepped at once under jit(vmap) (the cell's first 64 episodes repeated), the median of the repeats,
its ratio to the reference and the compile time. Engine: footstep_gym/jax/speed.py (orca_crowds, orca_rates). Quote
the figures with the load average this prints.
"""

from __future__ import annotations

import argparse
import os


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cells", default="counter_flow,crossing_flows,closing_in")
    p.add_argument("--sizes", default="4096")
    p.add_argument("--steps", type=int, default=10, help="footsteps per timed run")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--devices", type=int, default=1, help="(on a CPU) JAX devices; the crowds run on the first")
    args = p.parse_args(argv)
    from footstep_gym.jax import speed

    speed.use_cpu_devices(args.devices)
    print(f"load average {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print(f"{'cell':>15} {'N':>6} {'pyrvo crowd/s':>14} {'JAX crowd/s':>12} {'x pyrvo':>8} {'compile s':>9}")
    for cell in args.cells.split(","):
        crowds = speed.orca_crowds(cell, 64)
        for n in (int(s) for s in args.sizes.split(",")):
            ref, r = speed.orca_rates(crowds, n, args.steps, args.repeats)
            print(f"{cell:>15} {n:>6} {ref:>14,.0f} {r.steps_per_s:>12,.0f} {r.steps_per_s / ref:>8.0f} "
                  f"{r.compile_s:>9.1f}", flush=True)
    print(f"load average after {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
