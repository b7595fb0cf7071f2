"""Figures (in the spirit of the paper's Fig. 8-10) and command tables (Tables 2 and 4) from traces.

Everything here reads :class:`~footstep_gym.evaluation.runner.Trace` objects only; nothing
runs an env. Matplotlib is used with the Agg backend (no display needed).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import matplotlib.ticker  # noqa: E402
from matplotlib.collections import PatchCollection  # noqa: E402
from matplotlib.patches import Circle, Polygon  # noqa: E402

from footstep_gym.evaluation.runner import Trace  # noqa: E402

LEFT_COLOUR = "#3166d6"
RIGHT_COLOUR = "#d6453b"
COM_COLOUR = "black"
WALL_COLOUR = "#505050"
GOAL_COLOUR = "#2e9e55"
TIME_CMAP = "viridis"
N_TIME_SAMPLES = 8  # obstacle (and robot body) drawn at this many instants
MARGIN = 0.45  # [m] around the robot's path and the goal
NEAR = 0.6  # [m] a travelling obstacle is kept in view where it came this close to the robot


# ---------------------------------------------------------------- outcome wording
def outcome_text(trace: Trace) -> str:
    steps = len(trace.commands)
    t = trace.times[-1]
    if trace.outcome == "goal":
        return f"goal: {steps} steps, {t:.1f} s"
    if trace.outcome == "collision":
        return f"collision ({trace.obstacle}) at step {steps}, {t:.1f} s"
    if trace.outcome == "fall":
        return f"fall (infeasible step) at step {steps}, {t:.1f} s"
    return f"timeout after {steps} steps, {t:.1f} s"


def params_text(params: dict[str, float], scenario: str | None = None) -> str:
    """``door_speed = 17 deg/s``: each key with its unit (the scenario's ``sweep_axes`` and field metadata)."""
    from footstep_gym.scenarios import SCENARIOS, units

    unit = {**units(), **(units(scenario) if scenario in SCENARIOS else {})}
    return ", ".join(f"{k} = {v:g} {unit.get(k, '')}".strip() for k, v in params.items())


# ---------------------------------------------------------------- geometry helpers
def capsule(a: np.ndarray, b: np.ndarray, r: float, n: int = 10) -> np.ndarray:
    """Outline ``(2n + 2, 2)`` of the thick segment ``a``-``b`` of half thickness ``r``."""
    d = b - a
    ang = math.atan2(d[1], d[0]) if np.hypot(*d) > 0 else 0.0
    arc_b = ang + np.linspace(-math.pi / 2, math.pi / 2, n + 1)
    arc_a = ang + np.linspace(math.pi / 2, 3 * math.pi / 2, n + 1)
    pts_b = b + r * np.stack([np.cos(arc_b), np.sin(arc_b)], axis=1)
    pts_a = a + r * np.stack([np.cos(arc_a), np.sin(arc_a)], axis=1)
    return np.vstack([pts_b, pts_a])


def foot_outline(pose: Sequence[float], length: float, width: float) -> np.ndarray:
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    corners = np.array([(0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5)]) * (length, width)
    return np.stack([x + c * corners[:, 0] - s * corners[:, 1], y + s * corners[:, 0] + c * corners[:, 1]], axis=1)


def sample_indices(n: int, k: int = N_TIME_SAMPLES) -> np.ndarray:
    """``k`` snapshot indices spread evenly over ``0 .. n-1`` (always the first and the last)."""
    return np.unique(np.round(np.linspace(0, n - 1, min(k, n))).astype(int))


def _rotating_in_place(trace: Trace, i: int) -> bool:
    """True if moving shape ``i`` turns about a fixed body position (a revolving door)."""
    return np.ptp(trace.poses[:, i, :2], axis=0).max() <= 1e-9


def view_box(traces: Sequence[Trace]) -> tuple[float, float, float, float]:
    """Axis limits covering the robot's paths, start and goal (plus a margin), the walls and any revolving door."""
    pts = [np.asarray(tr.centre) for tr in traces] + [np.asarray(tr.com) for tr in traces]
    pts += [np.array([tr.goal, tr.start]) for tr in traces]
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0) - MARGIN, allp.max(axis=0) + MARGIN
    for tr in traces:
        for i, sh in enumerate(tr.shapes):
            if sh.static:
                ends = np.array(tr.shape_world(0, i))
                lo, hi = np.minimum(lo, ends.min(axis=0) - sh.radius), np.maximum(hi, ends.max(axis=0) + sh.radius)
            elif _rotating_in_place(tr, i):
                reach = max(np.hypot(*sh.a), np.hypot(*sh.b)) + sh.radius
                c = tr.poses[0, i, :2]
                lo, hi = np.minimum(lo, c - reach - 0.05), np.maximum(hi, c + reach + 0.05)
            else:  # a travelling body: wherever it came near the robot
                near = np.linalg.norm(tr.poses[:, i, :2] - tr.com, axis=1) < NEAR
                if near.any():
                    p = tr.poses[near, i, :2]
                    reach = max(np.hypot(*sh.a), np.hypot(*sh.b)) + sh.radius
                    lo, hi = np.minimum(lo, p.min(axis=0) - reach), np.maximum(hi, p.max(axis=0) + reach)
    return float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])


# ---------------------------------------------------------------- drawing
def draw_obstacles(ax: Any, trace: Trace, norm: Any, cmap: Any) -> None:
    """Walls once; moving shapes at a few instants (colour = time, fading in), and their centre paths."""
    n = len(trace.times)
    picks = sample_indices(n)
    for i, sh in enumerate(trace.shapes):
        if sh.static:
            a, b = trace.shape_world(0, i)
            ax.add_patch(Polygon(capsule(a, b, max(sh.radius, 0.005)), closed=True, fc=WALL_COLOUR, ec="none",
                                 zorder=2))
            continue
        if _rotating_in_place(trace, i):  # a revolving door: the disc its wings sweep
            reach = max(np.hypot(*sh.a), np.hypot(*sh.b)) + sh.radius
            ax.add_patch(Circle(tuple(trace.poses[0, i, :2]), reach, fill=False, ls=":", lw=0.8, ec="0.45", zorder=1))
        else:  # a travelling body: the path of its centre
            ax.plot(trace.poses[:, i, 0], trace.poses[:, i, 1], ls=":", lw=0.8, color="0.45", zorder=1)
        for rank, k in enumerate(picks):
            colour = cmap(norm(trace.times[k]))
            alpha = 0.2 + 0.7 * (rank + 1) / len(picks)
            if sh.kind == "circle":
                a, _ = trace.shape_world(k, i)
                patch = Circle(tuple(a), sh.radius, fc=colour, ec="none", alpha=alpha, zorder=2)
            else:
                a, b = trace.shape_world(k, i)
                patch = Polygon(capsule(a, b, max(sh.radius, 0.006)), closed=True, fc=colour, ec="none",
                                alpha=alpha, zorder=2)
            ax.add_patch(patch)
    # The robot's body at the same instants, in the same colours (where it was when the obstacles were there).
    r = trace.robot["body_radius"]
    for k in picks:
        ax.add_patch(Circle(tuple(trace.com[k]), r, fill=False, ec=cmap(norm(trace.times[k])), lw=1.0, ls="--",
                            zorder=4))


def draw_robot(ax: Any, trace: Trace) -> None:
    fl, fw = trace.robot["foot_length"], trace.robot["foot_width"]
    for colour, sign in ((LEFT_COLOUR, 1), (RIGHT_COLOUR, -1)):
        feet = [Polygon(foot_outline(p, fl, fw), closed=True) for p, side in trace.footprints if side == sign]
        ax.add_collection(PatchCollection(feet, fc=colour, ec=colour, alpha=0.35, lw=0.6, zorder=3))
    ax.plot(trace.com_path[:, 0], trace.com_path[:, 1], color=COM_COLOUR, lw=1.0, zorder=5)
    ax.plot(*trace.start, marker="s", color="black", ms=6, zorder=6, ls="none")
    ax.add_patch(Circle(trace.goal, trace.goal_tolerance, fill=False, ec=GOAL_COLOUR, lw=1.5, zorder=6))
    ax.plot(*trace.goal, marker="*", color=GOAL_COLOUR, ms=11, zorder=6, ls="none")
    if trace.outcome in ("collision", "fall"):
        ax.plot(*trace.com[-1], marker="x", color="red", ms=12, mew=2.5, zorder=7, ls="none")


def legend_handles() -> list[Any]:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    return [
        Patch(fc=LEFT_COLOUR, alpha=0.5, label="left foot"), Patch(fc=RIGHT_COLOUR, alpha=0.5, label="right foot"),
        Line2D([], [], color=COM_COLOUR, lw=1.0, label="CoM path"),
        Line2D([], [], color="0.3", ls="--", marker="o", mfc="none", ms=8, lw=0,
               label="robot body at the obstacles' instants"),
        Line2D([], [], color="0.45", ls=":", lw=0.8, label="obstacle path / door disc"),
        Line2D([], [], color="black", marker="s", ls="none", label="start"),
        Line2D([], [], color=GOAL_COLOUR, marker="*", ms=11, ls="none", label="goal"),
        Line2D([], [], color="red", marker="x", mew=2.5, ms=10, ls="none", label="collision / fall"),
    ]


def draw_commands(ax: Any, trace: Trace) -> None:
    """Walking period T = T_SS + T_DS per footstep (left axis) and front stride S (right axis)."""
    steps = np.arange(1, len(trace.commands) + 1)
    if not len(steps):
        return
    period = trace.commands[:, 3] + trace.commands[:, 4]
    ax.step(steps, period, where="mid", color="tab:purple", lw=1.4, label="T (s)")
    pre = trace.pre_pso[:, 3] + trace.pre_pso[:, 4]
    changed = np.isfinite(pre) & (np.abs(pre - period) > 1e-6)
    if changed.any():
        ax.plot(steps[changed], pre[changed], "o", mfc="none", color="tab:purple", ms=4, label="T before PSO")
    ax.set_ylabel("T (s)", color="tab:purple", fontsize=8)
    ax.set_xlabel("footstep", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_ylim(0.0, max(1.0, float(np.nanmax(period)) + 0.1))
    ax2 = ax.twinx()
    ax2.step(steps, 100 * trace.commands[:, 0], where="mid", color="tab:orange", lw=1.0, label="S (cm)")
    ax2.set_ylabel("S (cm)", color="tab:orange", fontsize=8)
    ax2.tick_params(labelsize=7)
    ax2.set_ylim(-5, 11)
    ax.grid(alpha=0.3)


#: Width of one policy's panel [in], the most panels side by side and the figure's resolution [dpi]: a panel is
#: about 420 px wide, a figure at most about 1,750 px.
PANEL_W = 4.2
MAX_COLUMNS = 4
DPI = 100


def grid_shape(n: int, panel_aspect: float) -> tuple[int, int]:
    """``(rows, columns)`` of ``n`` panels of height / width ``panel_aspect``: the grid closest to square, at most
    :data:`MAX_COLUMNS` wide."""
    cols = max(1, min(n, MAX_COLUMNS, math.ceil(math.sqrt(n * panel_aspect))))
    return math.ceil(n / cols), cols


def episode_figure(traces: Sequence[Trace], path: Path, title: str) -> Path:
    """The policies on one seed side by side, a grid of panels: each the trajectory (obstacles coloured by time,
    footprints, CoM path) over a strip of the per-step period and stride. One colour bar (time) and one legend for
    all of them, below the grid."""
    cmap = plt.get_cmap(TIME_CMAP)
    t_max = max(float(tr.times[-1]) for tr in traces) or 1.0
    norm = matplotlib.colors.Normalize(0.0, t_max)
    x0, x1, y0, y1 = view_box(traces)
    scene_h = float(np.clip(PANEL_W * (y1 - y0) / max(x1 - x0, 1e-6), 1.0, 1.3 * PANEL_W))
    strip_h = 1.0
    rows, cols = grid_shape(len(traces), (scene_h + strip_h + 0.8) / PANEL_W)
    fig = plt.figure(figsize=(PANEL_W * cols + 0.6, rows * (scene_h + strip_h + 0.8) + 1.6), layout="constrained")
    grid = fig.add_gridspec(2 * rows, cols, height_ratios=[scene_h, strip_h] * rows)
    scenes, strips = [], []
    for j, tr in enumerate(traces):
        r, c = divmod(j, cols)
        ax = fig.add_subplot(grid[2 * r, c])
        scenes.append(ax)
        draw_obstacles(ax, tr, norm, cmap)
        draw_robot(ax, tr)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
        ax.set_title(f"{tr.policy}\n{outcome_text(tr)}", fontsize=9, loc="left")
        strips.append(fig.add_subplot(grid[2 * r + 1, c]))
        draw_commands(strips[-1], tr)
    for ax in scenes[-cols:]:
        ax.set_xlabel("x (m)", fontsize=8)
    for ax in scenes[::cols]:
        ax.set_ylabel("y (m)", fontsize=8)
    sm = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=scenes + strips, location="bottom", shrink=0.5, aspect=50, pad=0.01,
                 label="time (s): obstacles and robot body drawn at these instants")
    fig.legend(handles=legend_handles(), loc="outside lower center", ncols=4, fontsize=8, frameon=False)
    fig.suptitle(title, fontsize=11)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


# ---------------------------------------------------------------- command tables (paper Tables 2 and 4)
TABLE_COLUMNS = (("S (cm)", 0, 100.0, 2), ("L (cm)", 1, 100.0, 2), ("θ (rad)", 2, 1.0, 2),
                 ("T_DS (s)", 4, 1.0, 2), ("T_SS (s)", 3, 1.0, 2))


def _num(v: float, digits: int) -> str:
    s = f"{v:.{digits}f}"
    return "0." + "0" * digits if s == "-0." + "0" * digits else s


def command_table(trace: Trace) -> str:
    """Markdown table of every footstep's command, in the column order and units of Tables 2 and 4.

    Where the policy reports its pre-PSO command and PSO changed a value (as displayed),
    the pre-PSO value is given in parentheses before the optimised one and the row is in
    bold, as in the paper.
    """
    head = ["Steps"] + [c[0] for c in TABLE_COLUMNS]
    lines = [
        f"# Footstep commands: {trace.env_id} ({params_text(trace.params, trace.scenario) or 'defaults'}), "
        f"{trace.policy}, seed {trace.seed}",
        "",
        f"Outcome: {outcome_text(trace)}. Rows where PSO changed the command are in **bold**, with the "
        "command before PSO (binary search + modified RRT) in parentheses. Values are the commands "
        "the env applied; L is outward from the support foot (always > 0).",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "|".join(["---:"] * len(head)) + "|",
    ]
    for k, cmd in enumerate(trace.commands):
        pre = trace.pre_pso[k]
        cells, changed_row = [], False
        for _, idx, scale, digits in TABLE_COLUMNS:
            now = _num(cmd[idx] * scale, digits)
            before = _num(pre[idx] * scale, digits) if np.isfinite(pre[idx]) else now
            if before != now:
                changed_row = True
                cells.append(f"({before}) **{now}**")
            else:
                cells.append(now)
        step = f"**{k + 1}**" if changed_row else str(k + 1)
        lines.append("| " + " | ".join([step] + cells) + " |")
    return "\n".join(lines) + "\n"


def write_command_table(trace: Trace, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(command_table(trace), encoding="utf-8")
    return path
