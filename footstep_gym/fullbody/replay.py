"""Episodes of any policy, recorded through the reference env, walked on the OP3 (docs/fullbody.md §4).

:func:`record_episodes` runs a policy on one cell of a tier with the ``op3`` robot (``gym.make(env_id,
robot="op3", tier=..., tier_cell=...)``) and keeps the commands the env applied (``info["command"]``, after
clipping) and how the episode ended; :func:`walk_episodes` walks each episode's commands on the OP3 in MuJoCo,
from the env's start pose moved to the origin (MuJoCo's floor has no obstacles: an episode that ended in a
collision is walked through its last command whole).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import gymnasium as gym
import numpy as np

from footstep_gym.fullbody import walk
from footstep_gym.fullbody.walker import WalkResult


@dataclass(frozen=True)
class Episode:
    """One episode of the reference env: its seed, the commands applied, how it ended."""

    env_id: str
    tier: str
    cell: str | None
    policy: str
    seed: int
    commands: np.ndarray  # (n, 5) [S, L, theta, T_SS, T_DS] as the env applied them
    termination: str | None  # "goal", "collision", "fall" or None (truncated)
    fall: str | None  # the env's fall reason on a fall


def record_episodes(policy: str, env_id: str, seeds: Sequence[int], tier: str = "paper", cell: str | None = None,
                    robot: Any = "op3", run: str | None = None) -> list[Episode]:
    """Run ``policy`` (a name of :func:`footstep_gym.make_policy`; ``run`` for an agent) on ``env_id``'s ``cell``
    of ``tier`` with ``robot``, one episode per seed, and keep what each did."""
    from footstep_gym import make_policy
    from footstep_gym.evaluation.runner import bind_truth

    env = gym.make(env_id, robot=robot, tier=tier, tier_cell=cell)
    out = []
    try:
        for seed in seeds:
            pol = make_policy(policy, env.unwrapped.robot, seed=seed, run=run)
            bind_truth(pol, env)  # the privileged planners read the env itself; the others get nothing
            obs, _ = env.reset(seed=seed)
            pol.reset(seed=seed)
            commands, info = [], {}
            terminated = truncated = False
            while not (terminated or truncated):
                obs, _, terminated, truncated, info = env.step(pol.act(obs, env.unwrapped.sensing()))
                commands.append(info["command"])
            out.append(Episode(env_id, tier, cell, policy, int(seed), np.array(commands, dtype=float).reshape(-1, 5),
                               info.get("termination"), info.get("fall")))
    finally:
        env.close()
    return out


def admitted(episode: Episode, robot: Any = "op3") -> bool:
    """Whether every command of ``episode`` lies in ``robot``'s command box with its T_SS at or above the swing's
    floor (:func:`footstep_gym.footstep.swing_time_floor`; none for a robot without servo limits): an episode
    recorded with another robot, e.g. an agent's on the default one, can then be walked on the OP3 as it was
    commanded, and its commands are ones ``robot``'s env would have accepted kinematically but for the turn limits
    and the soles' overlap, which depend on the footstep's side."""
    from footstep_gym.footstep import swing_time_floor
    from footstep_gym.fullbody import as_robot

    rob = as_robot(robot)
    cmd = episode.commands
    in_box = np.all(cmd >= rob.command_low - 1e-9) and np.all(cmd <= rob.command_high + 1e-9)
    return bool(in_box and np.all(cmd[:, 3] >= swing_time_floor(rob, cmd[:, 0]) - 1e-9))


def walk_episodes(episodes: Sequence[Episode], robot: Any = "op3") -> list[tuple[Episode, WalkResult]]:
    """Each episode's commands walked on the OP3 (:func:`footstep_gym.fullbody.walk`)."""
    return [(ep, walk(ep.commands, robot=robot)) for ep in episodes]


def table_rows(walked: Sequence[tuple[Episode, WalkResult]]) -> list[dict[str, Any]]:
    """One row per episode: the env's outcome beside the full body's."""
    rows = []
    for ep, res in walked:
        rows.append({
            "env": ep.env_id, "tier": ep.tier, "cell": ep.cell or "", "policy": ep.policy, "seed": ep.seed,
            "footsteps": len(ep.commands), "env_end": ep.termination or "truncated", "env_fall": ep.fall or "",
            "op3_fell": res.fell, "op3_fell_at": "" if res.fell_at is None else res.fell_at,
            "median_foot_error_mm": _mm(np.median(res.foot_error)) if len(res.foot_error) else "",
            "min_cop_margin_mm": _mm(np.nanmin(res.cop_margin)) if np.any(np.isfinite(res.cop_margin)) else "",
            "sim_time_s": round(res.sim_time, 3), "wall_time_s": round(res.wall_time, 3),
        })
    return rows


def _mm(x: float) -> float:
    return round(1000.0 * float(x), 2) if math.isfinite(x) else float("nan")


def summary(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (env, cell, policy): episodes, the env's success rate and the share the OP3 walked without a fall."""
    groups: dict[tuple, list] = {}
    for r in rows:
        groups.setdefault((r["env"], r["cell"], r["policy"]), []).append(r)
    out = []
    for (env, cell, policy), rs in groups.items():
        out.append({"env": env, "cell": cell, "policy": policy, "episodes": len(rs),
                    "env_success": round(sum(r["env_end"] == "goal" for r in rs) / len(rs), 3),
                    "op3_no_fall": round(sum(not r["op3_fell"] for r in rs) / len(rs), 3),
                    "env_success_and_op3_no_fall": round(sum(r["env_end"] == "goal" and not r["op3_fell"]
                                                             for r in rs) / len(rs), 3)})
    return out


def markdown_table(rows: Sequence[dict[str, Any]]) -> str:
    """``rows`` as a Markdown table (the keys of the first row are the columns)."""
    if not rows:
        return ""
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(str(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def write_video(commands: np.ndarray, path: str | Path, robot: Any = "op3", fps: int = 25,
                size: tuple[int, int] = (480, 360)) -> Path:
    """An MP4 of the OP3 walking ``commands`` (MuJoCo's offscreen renderer, frames at ``fps`` of simulated time).

    Headless machines need an offscreen OpenGL: Debian's ``libosmesa6`` with ``MUJOCO_GL=osmesa``.
    """
    import mujoco
    from moviepy import ImageSequenceClip

    from footstep_gym.fullbody.model import shared_op3
    from footstep_gym.fullbody.plan import gait_plan
    from footstep_gym.fullbody.walker import walk_plan
    from footstep_gym.fullbody import as_robot

    op3 = shared_op3()
    cmd = np.atleast_2d(np.asarray(commands, dtype=float))
    plan = gait_plan(as_robot(robot), cmd)
    every = max(1, int(round(1.0 / (fps * (plan.t[1] - plan.t[0])))))
    with mujoco.Renderer(op3.model, height=size[1], width=size[0]) as renderer:
        result = walk_plan(op3, plan, cmd, render=renderer, render_every=every)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ImageSequenceClip(result.frames, fps=fps).write_videofile(str(path), codec="libx264", logger=None)
    return path
