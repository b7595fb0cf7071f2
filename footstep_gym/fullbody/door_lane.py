"""Is the revolving door passable at a robot's top speed along the corridor's wall? A privileged probe, not a planner.

:func:`door_wall_lane` steps open-loop command sequences through ``FootstepDoor-v0`` (the env judges every
collision): step in place ``k`` times at the nominal T_SS and a T_DS ``d`` (``k`` in :data:`WAITS`, ``d`` each
double-support time of :data:`WAIT_T_DS` in the robot's box: together, the start time), side-step at the nominal
period to the lane ``y = lane`` (:data:`SIDE` of side stride per step), then walk :data:`STRIDE` strides at T_SS
the swing floor of that stride (up to 10 ms; the first three steps ramp up) and the nominal T_DS along the lane,
back to the goal's line past ``x =`` :data:`GOAL_LINE_X`. Per seed: which start times reach the goal, and the first
of them walked on the OP3. The start times are tried exhaustively, knowing nothing of the door: what passes is
what the env lets through (docs/fullbody.md §3.3).
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import gymnasium as gym
import numpy as np

from footstep_gym import footstep
from footstep_gym.footstep import LEFT
from footstep_gym.robot import Robot

#: [m] the walk's stride; [m] the side stride added or taken per side step; the steps in place tried.
STRIDE, SIDE, WAITS = 0.1, 0.01, tuple(range(26))
#: [s] the double-support times of the steps in place (those in the robot's box).
WAIT_T_DS = (0.1, 0.11, 0.15, 0.2, 0.25, 0.3)
#: [m] past the door's disc the walk steers back to the goal's line.
GOAL_LINE_X = 0.7


def attempt(env: gym.Env, seed: int, lane: float, waits: int, wait_t_ds: float, t_ss: float,
            applied: list | None = None) -> str | None:
    """One sequence (the module doc) on ``env`` reset with ``seed``: the episode's end (``"goal"``, ``"collision"``,
    ``"fall"``, ``"truncated"``) or None; the commands the env applied are appended to ``applied``."""
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

    def step(command: list[float]) -> str | None:
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


def walk_time_floor(robot: Robot) -> float:
    """[s] the walk's T_SS: the swing floor of a :data:`STRIDE` stride, up to 10 ms, within the robot's box."""
    t_ss = math.ceil(round(footstep.swing_time_floor(robot, STRIDE, math) * 100, 6)) / 100
    return min(max(t_ss, robot.t_ss[0]), robot.t_ss[1])


def door_wall_lane(robot: Robot | Mapping[str, Any] | str, seeds: Sequence[int], lane: float,
                   walk_first: bool = False) -> dict[str, Any]:
    """The probe (module doc) on each of ``seeds`` along ``y = lane`` [m]: the start times that reach the goal per
    seed, and with ``walk_first`` the first of them walked on the OP3 (needs MuJoCo)."""
    env = gym.make("FootstepDoor-v0", robot=robot)
    rob = env.unwrapped.robot
    t_ss = walk_time_floor(rob)
    wait_t_ds = [d for d in WAIT_T_DS if rob.t_ds[0] <= d <= rob.t_ds[1]]
    rows = []
    try:
        for seed in seeds:
            ends = [(k, d, attempt(env, seed, lane, k, d, t_ss)) for k in WAITS for d in wait_t_ds]
            passing = [[k, d] for k, d, end in ends if end == "goal"]
            row: dict[str, Any] = {"seed": int(seed), "start_times": len(ends), "passing": passing}
            if passing and walk_first:
                from footstep_gym.fullbody import walk

                applied: list = []
                attempt(env, seed, lane, *passing[0], t_ss, applied)
                res = walk(np.array(applied), robot=rob)
                margins = res.cop_margin[np.isfinite(res.cop_margin)]
                row.update(op3_fell=res.fell, op3_fell_at=res.fell_at,
                           op3_min_cop_margin_mm=round(1000 * float(margins.min()), 2) if margins.size else None)
            rows.append(row)
    finally:
        env.close()
    return {"robot": robot, "lane_y": lane, "t_ss": t_ss, "t_ds": rob.nominal_t_ds,
            "speed": round(STRIDE / (t_ss + rob.nominal_t_ds), 4),
            "seeds_passing": sum(bool(r["passing"]) for r in rows),
            "seeds_passing_and_op3_no_fall": (sum(bool(r["passing"]) and not r["op3_fell"] for r in rows)
                                             if walk_first else None), "rows": rows}
