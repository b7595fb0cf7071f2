"""Is the revolving door passable at a robot's top speed along the corridor's wall? A privileged probe, not a planner.

    python baselines/door_wall_lane.py --robot op3-swing --lane -0.47
    python baselines/door_wall_lane.py --robot '{"profile": "op3-swing", "t_ds": [0.1, 0.3], "nominal_t_ds": 0.2}'

For each validation seed, open-loop command sequences are stepped through ``FootstepDoor-v0`` (the env judges every
collision): step in place ``k`` times at T_SS nominal and T_DS ``d`` (``k`` = 0..25, ``d`` each double-support time
of the robot's box on a grid: the start time), side-step at the nominal period to the lane ``y = --lane`` (1 cm of
side stride per step), then walk 10 cm strides at T_SS the swing floor of a 10 cm stride (up to 10 ms; the first three
steps ramp up) and the nominal T_DS along the lane, back to the goal's line past x = 0.7 m. It reports, per seed, how
many start times reach the goal: whether, and how narrowly, the door lets the robot through at that speed.
Writes baselines/results/fullbody/door_wall_lane_<robot>_<lane>.json (kept unless --force). Validation seeds only.
"""

from __future__ import annotations

import argparse
import json
import math

import gymnasium as gym
import numpy as np

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import footstep
from footstep_gym.footstep import LEFT
from fullbody import OUT, _target, robot_arg, robot_label, validation_seeds

STRIDE, SIDE, WAITS = 0.1, 0.01, range(26)
GOAL_LINE_X = 0.7  # [m] past the door's disc: steer back to the goal's line


def attempt(env: gym.Env, seed: int, lane: float, waits: int, wait_t_ds: float, t_ss: float,
            applied: list | None = None) -> str | None:
    """One sequence (see the module doc): the env's termination (``"goal"``, ``"collision"``, ...) or None; the
    commands the env applied are appended to ``applied``."""
    env.reset(seed=seed)
    u, rob = env.unwrapped, env.unwrapped.robot
    L, t_n, t_dn = rob.nominal_side_stride, rob.nominal_t_ss, rob.nominal_t_ds

    def centre() -> tuple[float, float]:
        a, b = u.feet[LEFT], u.feet[-LEFT]
        return 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])

    def side_stride(y_target: float) -> float:  # widen the right foot's steps and narrow the left's to go right
        y = centre()[1]
        if abs(y - y_target) < 0.005:
            return L
        d = SIDE if y > y_target else -SIDE
        return L + d if u.support_side == LEFT else L - d

    def step(command: list[float]) -> str | None:  # the episode's end ("truncated" at the time limit), or None
        _, _, terminated, truncated, info = env.step(np.array(command, dtype=np.float32))
        if applied is not None:
            applied.append(info["command"])
        return (info.get("termination") or "truncated") if terminated or truncated else None

    for _ in range(waits):
        if end := step([0.0, L, 0.0, t_n, wait_t_ds]):
            return end
    for _ in range(40):
        if centre()[1] <= lane + 0.005:
            break
        if end := step([0.0, side_stride(lane), 0.0, t_n, t_dn]):
            return end
    ramp = [(STRIDE / 2, t_n), (STRIDE, 0.5), (STRIDE, 0.45)]
    goal_y = u.episode_config.goal[1]
    for j in range(80):
        S, T = ramp[j] if j < len(ramp) else (STRIDE, t_ss)
        if end := step([S, side_stride(lane if centre()[0] < GOAL_LINE_X else goal_y), 0.0, max(T, t_ss), t_dn]):
            return end
    return None


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="op3-swing", type=robot_arg, help="robot profile or JSON mapping")
    parser.add_argument("--lane", type=float, default=-0.47, help="[m] the lane's y (the corridor: -0.66 .. 0)")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--walk", action="store_true", help="walk each seed's first passing sequence on the OP3")
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args(argv)
    path = _target(OUT / f"door_wall_lane_{robot_label(args.robot)}_{args.lane:g}.json", args.force)
    env = gym.make("FootstepDoor-v0", robot=args.robot)
    rob = env.unwrapped.robot
    t_ss = math.ceil(round(footstep.swing_time_floor(rob, STRIDE, math) * 100, 6)) / 100
    t_ss = min(max(t_ss, rob.t_ss[0]), rob.t_ss[1])
    wait_t_ds = [d for d in (0.1, 0.11, 0.15, 0.2, 0.25, 0.3) if rob.t_ds[0] <= d <= rob.t_ds[1]]
    rows = []
    for seed in validation_seeds(args.episodes, 0):
        ends = [(k, d, attempt(env, seed, args.lane, k, d, t_ss)) for k in WAITS for d in wait_t_ds]
        passing = [[k, d] for k, d, end in ends if end == "goal"]
        row = {"seed": seed, "start_times": len(ends), "passing": passing}
        if passing and args.walk:  # the first passing sequence walked on the OP3
            from footstep_gym.fullbody import walk

            applied: list = []
            attempt(env, seed, args.lane, *passing[0], t_ss, applied)
            res = walk(np.array(applied), robot=rob)
            margins = res.cop_margin[np.isfinite(res.cop_margin)]
            row.update(op3_fell=res.fell, op3_fell_at=res.fell_at,
                       op3_min_cop_margin_mm=round(1000 * float(margins.min()), 2) if margins.size else None)
        rows.append(row)
        print(seed, f"{len(passing)} of {len(ends)} start times reach the goal", passing[:4],
              {k: v for k, v in row.items() if k.startswith("op3")}, flush=True)
    env.close()
    speed = STRIDE / (t_ss + rob.nominal_t_ds)
    out = {"robot": args.robot, "lane_y": args.lane, "t_ss": t_ss, "t_ds": rob.nominal_t_ds, "speed": round(speed, 4),
           "seeds_passing": sum(bool(r["passing"]) for r in rows),
           "seeds_passing_and_op3_no_fall": (sum(bool(r["passing"]) and not r["op3_fell"] for r in rows)
                                             if args.walk else None), "rows": rows}
    print({k: v for k, v in out.items() if k != "rows"})
    path.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
