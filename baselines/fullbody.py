"""Footstep commands walked on the ROBOTIS OP3 in MuJoCo (footstep_gym.fullbody; docs/fullbody.md).

    python baselines/fullbody.py replay --policy period-aware --env FootstepDoor-v0 --episodes 10 [--video]
    python baselines/fullbody.py nominal            # 20 footsteps of the nominal command (and of 5 cm strides)
    python baselines/fullbody.py agreement          # the env's verdict against the OP3 (docs/fullbody.md §3)
    python baselines/fullbody.py swing              # steady strides x T_SS on the OP3 (op3-lipm) against op3's floor
    python baselines/fullbody.py double-support     # steady strides at their swing floor x T_DS on the OP3
    python baselines/fullbody.py door-lane --walk   # the door along its wall (a privileged probe)
    python baselines/fullbody.py summary            # the board's column: fullbody_paper_op3.json/.csv from the tables

Episodes use the validation split's seeds (configs/eval.yaml), never the test split's. Results go to
baselines/results/fullbody/; an existing file is kept unless --force.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import sys
import time
from pathlib import Path

import numpy as np

from footstep_gym.config import read_yaml

OUT = Path(__file__).resolve().parent / "results" / "fullbody"


def _target(path: Path, force: bool) -> Path:
    if path.exists() and not force:
        sys.exit(f"{path} exists; pass --force to replace it")
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def validation_seeds(n: int, offset: int) -> list[int]:
    first, end = read_yaml("eval.yaml")["splits"]["validation"]
    if offset < 0 or first + offset + n > end:
        sys.exit(f"--offset {offset} + --episodes {n} leaves the validation split [{first}, {end})")
    return list(range(first + offset, first + offset + n))


def robot_arg(text: str) -> object:
    """A profile's name, or a JSON mapping of robot keys (``'{"profile": "op3", "t_ss": [0.3, 0.6]}'``)."""
    return json.loads(text) if text.lstrip().startswith("{") else text


def robot_label(robot: object) -> str:
    if isinstance(robot, str):
        return robot
    def text(v: object) -> str:
        return "-".join(f"{x:g}" for x in v) if isinstance(v, (list, tuple)) else str(v)

    return "-".join(text(v) if k == "profile" else f"{k}{text(v)}" for k, v in robot.items())


def cmd_replay(args: argparse.Namespace) -> None:
    from footstep_gym.evaluation.fullbody_column import NO_EPISODE
    from footstep_gym.fullbody.replay import admitted, markdown_table, record_episodes, summary, table_rows, \
        walk_episodes, write_video

    label = args.name or args.policy
    name = "_".join([args.env, args.tier, args.cell or "all", label, robot_label(args.robot)]).replace("/", "-")
    path = _target(args.out / f"{name}.md", args.force)
    recorded = args.robot if args.recorded_with is None else {} if args.recorded_with == "default" \
        else args.recorded_with
    episodes = [dataclasses.replace(ep, policy=label) for ep in
                record_episodes(args.policy, args.env, validation_seeds(args.episodes, args.offset), args.tier,
                                args.cell, recorded, args.run)]
    kept = [ep for ep in episodes if args.recorded_with is None or admitted(ep, args.robot)]
    rows = table_rows(walk_episodes(kept, args.robot))
    left = [ep.seed for ep in episodes if ep not in kept]
    note = (f"Recorded with robot {args.recorded_with!r}; walked: the {len(kept)} of {len(episodes)} episodes whose "
            f"every command lies in {args.robot!r}'s box, T_SS at or above its swing floor"
            + (f" (left out: seeds {left})" if left else "") + ".\n\n" if args.recorded_with is not None else "")
    text = (f"# {label} on {args.env} (tier {args.tier}, cell {args.cell or 'drawn'}), robot {args.robot}, "
            f"walked on the OP3\n\n" + note + (markdown_table(summary(rows)) + "\n" + markdown_table(rows)
                                                 if rows else NO_EPISODE + "\n"))
    path.write_text(text, encoding="utf-8")
    print(text)
    if args.video:
        os.environ.setdefault("MUJOCO_GL", "osmesa")
        ep = episodes[0]
        print("video:", write_video(ep.commands, _target(args.out / f"{name}_{ep.seed}.mp4", args.force), args.robot))


def cmd_nominal(args: argparse.Namespace) -> None:
    from footstep_gym.fullbody import walk
    from footstep_gym.robot import load_robot

    robot = load_robot(args.robot)
    path = _target(args.out / f"nominal_{robot_label(args.robot)}.json", args.force)
    out = {}
    for label, stride in (("nominal", 0.0), ("stride_5cm", 0.05)):
        cmd = robot.nominal_command.copy()
        cmd[0] = stride
        t = time.perf_counter()
        res = walk(np.tile(cmd, (args.steps, 1)), robot=args.robot)
        wall = time.perf_counter() - t
        short = walk(np.tile(cmd, (1, 1)), robot=args.robot)  # the prelude and stop alone (and one step)
        out[label] = {"command": cmd.tolist(), "footsteps": args.steps, "fell": res.fell, "fell_at": res.fell_at,
                      "median_foot_error_mm": round(1000 * float(np.median(res.foot_error)), 2),
                      "max_foot_error_mm": round(1000 * float(np.max(res.foot_error)), 2),
                      "median_yaw_error_deg": round(float(np.degrees(np.median(res.yaw_error))), 3),
                      "min_cop_margin_mm": round(1000 * float(np.nanmin(res.cop_margin)), 2),
                      "wall_s": round(wall, 2), "sim_s": round(res.sim_time, 2),
                      "wall_per_footstep_s": round((res.wall_time - short.wall_time) / (args.steps - 1), 3)}
        print(label, out[label])
    path.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")


def cmd_agreement(args: argparse.Namespace) -> None:
    from footstep_gym.fullbody.study import agreement_records, agreement_report

    path = _target(args.out / f"agreement_{robot_label(args.robot)}_seed{args.seed}.json", args.force)

    def progress(i: int, rec: dict) -> None:
        print(f"{i:4d} {rec['family']:15s} env {rec['env_fall_at']} {rec['env_fall']}  OP3 fell {rec['body_fell_at']}"
              f"  fell or tipped {rec['body_failed_at']}  {rec['wall_time']:.1f} s", flush=True)

    raw = args.out / f"agreement_{robot_label(args.robot)}_seed{args.seed}.records.json"
    if args.report_only:  # the walks of an earlier run, reported again
        records = json.loads(raw.read_text(encoding="utf-8"))
    else:
        records = agreement_records(args.robot, args.sequences, args.seed, progress)
        _target(raw, args.force).write_text(json.dumps(records) + "\n", encoding="utf-8")
    report = agreement_report(records, args.robot)
    print(json.dumps({k: v for k, v in report.items()}, indent=1))
    path.write_text(json.dumps({"robot": args.robot, "seed": args.seed, "sequences": len(records),
                                "report": report}, indent=1) + "\n", encoding="utf-8")


def cmd_grid(args: argparse.Namespace) -> None:
    """``swing`` (study.swing_grid) or ``double-support`` (study.double_support_grid): rows printed and written."""
    from footstep_gym.fullbody import study

    name, grid = {"swing": ("swing_grid", study.swing_grid),
                  "double-support": ("double_support_grid", study.double_support_grid)}[args.command]
    path = _target(args.out / f"{name}_{robot_label(args.robot)}.json", args.force)
    rows = grid(args.robot, args.limited)
    for r in rows:
        print(r, flush=True)
    path.write_text(json.dumps({"robot": args.robot, "limited": args.limited, "rows": rows}, indent=1) + "\n",
                    encoding="utf-8")


def cmd_door_lane(args: argparse.Namespace) -> None:
    from footstep_gym.fullbody.door_lane import door_wall_lane

    path = _target(args.out / f"door_wall_lane_{robot_label(args.robot)}_{args.lane:g}.json", args.force)
    out = door_wall_lane(args.robot, validation_seeds(args.episodes, 0), args.lane, args.walk)
    for row in out["rows"]:
        print(row["seed"], f"{len(row['passing'])} of {row['start_times']} start times reach the goal",
              {k: v for k, v in row.items() if k.startswith("op3")}, flush=True)
    print({k: v for k, v in out.items() if k != "rows"})
    path.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")


def cmd_summary(args: argparse.Namespace) -> None:
    from footstep_gym.evaluation.fullbody_column import FullBodyError, write_summary

    try:
        paths = write_summary(args.out, args.tier, robot_label(args.robot))
    except FullBodyError as exc:
        sys.exit(str(exc))
    for path in paths:
        print("wrote", path)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default=None, type=robot_arg,
                        help="robot profile (configs/robots/), or a JSON mapping of robot keys (default: op3; "
                             "op3-lipm, the LIPM without the servos' limits, for swing and double-support)")
    parser.add_argument("--out", type=Path, default=OUT, help="output folder")
    parser.add_argument("--force", action="store_true", help="replace existing output files")
    sub = parser.add_subparsers(dest="command", required=True)
    rp = sub.add_parser("replay", help="record a policy's episodes through the env and walk them on the OP3")
    rp.add_argument("--policy", required=True, help="a name of footstep_gym.make_policy (planner or agent)")
    rp.add_argument("--env", default="FootstepDoor-v0")
    rp.add_argument("--tier", default="paper")
    rp.add_argument("--cell", default=None, help="the tier's cell (default: drawn per episode)")
    rp.add_argument("--episodes", type=int, default=10)
    rp.add_argument("--offset", type=int, default=0, help="first validation seed's offset in its split")
    rp.add_argument("--run", default=None, help="an agent's training run (zoo folder or .zip)")
    rp.add_argument("--name", default=None,
                    help="the method's name in the tables and the summary (default --policy): e.g. an agent trained "
                         "with another robot than the shipped one")
    rp.add_argument("--recorded-with", default=None, type=robot_arg,
                    help="record with this robot ('default': configs/robot.yaml, the agents'), walk on --robot the "
                         "episodes its box and swing floor admit")
    rp.add_argument("--video", action="store_true", help="an MP4 of the first episode (MUJOCO_GL=osmesa headless)")
    nm = sub.add_parser("nominal", help="the nominal gait")
    nm.add_argument("--steps", type=int, default=20)
    ag = sub.add_parser("agreement", help="the env's verdict against the OP3 on drawn sequences")
    ag.add_argument("--sequences", type=int, default=120)
    ag.add_argument("--seed", type=int, default=2026)
    ag.add_argument("--report-only", action="store_true", help="report the walks saved by an earlier run")
    sw = sub.add_parser("swing", help="steady strides x T_SS walked on the OP3, beside the swing's floor")
    sw.add_argument("--limited", default="op3", help="the profile whose swing floor is shown")
    ds = sub.add_parser("double-support", help="steady strides at their swing floor x T_DS walked on the OP3")
    ds.add_argument("--limited", default="op3", help="the profile whose swing floor sets T_SS")
    dl = sub.add_parser("door-lane", help="a privileged probe: the door along its wall at the robot's top speed")
    dl.add_argument("--lane", type=float, default=-0.47, help="[m] the lane's y (the corridor: -0.66 .. 0)")
    dl.add_argument("--episodes", type=int, default=10)
    dl.add_argument("--walk", action="store_true", help="walk each seed's first passing sequence on the OP3")
    sm = sub.add_parser("summary", help="pool the replay tables of a tier per policy: the board's full-body column")
    sm.add_argument("--tier", default="paper")
    args = parser.parse_args(argv)
    if getattr(args, "name", None) is not None and not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*", args.name):
        parser.error(f"--name {args.name!r}: letters, digits, '.', '_' and '-' only (it names files and table rows)")
    if args.robot is None:  # the grids walk the LIPM's plan of commands below op3's floor, which op3 would refuse
        args.robot = "op3-lipm" if args.command in ("swing", "double-support") else "op3"
    {"replay": cmd_replay, "nominal": cmd_nominal, "agreement": cmd_agreement, "swing": cmd_grid,
     "double-support": cmd_grid, "door-lane": cmd_door_lane,
     "summary": cmd_summary}[args.command](args)


if __name__ == "__main__":
    main()
