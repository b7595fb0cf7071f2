"""The shipped agents side by side: learning curves per scene with every agent, and what training cost.

Both read the shipped agents' folders (``<agents>/<agent>/<EnvId>_<seed>/``: ``manifest.json``,
``validation.csv`` and/or ``evaluations.npz``; :func:`footstep_gym.rl.training.ship`):

* :func:`scene_curves`: one PNG per env id, success against env steps (left) and against
  training wall time (right), a line per agent (the mean over its training seeds, the band
  their range). A run's curve is its ``validation.csv`` (success on the validation split's
  seeds of its training distribution, :class:`~footstep_gym.rl.callbacks.ValidationCallback`),
  drawn solid; a run shipped without one has only the zoo's periodic evaluation
  (``evaluations.npz``: episodes seeded from the training seed, on the env's default settings
  unless the run gave ``--eval-env-kwargs``), drawn dashed and labelled so; its wall time is
  then the steps over the run's mean rate (the manifest's ``env_steps_per_s``).
* :func:`cost_rows` / :func:`cost_table`: per agent and env id, the training runs' env steps,
  wall time and env steps/s (median over seeds) and the final validation success.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from footstep_gym.rl import training


def _runs(agents_dir: Path) -> dict[tuple[str, str], list[tuple[Path, dict[str, Any]]]]:
    """``{(agent folder, env id): [(run folder, manifest), ...]}`` of the shipped agents, sorted."""
    groups: dict[tuple[str, str], list[tuple[Path, dict[str, Any]]]] = {}
    for path in sorted(Path(agents_dir).glob("*/*/manifest.json")):
        manifest = json.loads(path.read_text(encoding="utf-8"))
        groups.setdefault((path.parent.parent.name, manifest["env_id"]), []).append((path.parent, manifest))
    return groups


def run_curve(run: Path, manifest: dict[str, Any]) -> tuple[dict[str, np.ndarray], str]:
    """``({"timesteps", "wall_time_s", "success"}, source)`` of one shipped run: its validation curve
    (``source`` ``"validation"``), else the zoo's evaluations with wall time from the mean rate
    (``"zoo eval"``), else empty arrays (``"none"``)."""
    curve = training.validation_curve(run)
    if curve["success"]:
        return {k: np.asarray(curve[k], dtype=float) for k in ("timesteps", "wall_time_s", "success")}, "validation"
    zoo = training.eval_curve(run)
    if zoo["success"]:
        steps = np.asarray(zoo["timesteps"], dtype=float)
        rate = float(manifest.get("env_steps_per_s") or np.nan)
        return {"timesteps": steps, "wall_time_s": steps / rate, "success": np.asarray(zoo["success"])}, "zoo eval"
    return {"timesteps": np.array([]), "wall_time_s": np.array([]), "success": np.array([])}, "none"


def _mean_band(curves: list[dict[str, np.ndarray]], x: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """x (the first run's, cut to the shortest run), and the mean, min and max success over the runs."""
    n = min(len(c["success"]) for c in curves)
    xs = np.mean([c[x][:n] for c in curves], axis=0)
    ys = np.array([c["success"][:n] for c in curves])
    return xs, ys.mean(axis=0), ys.min(axis=0), ys.max(axis=0)


def scene_curves(agents_dir: str | Path, out_dir: str | Path) -> list[Path]:
    """One PNG per env id with every shipped agent's learning curve: ``<out_dir>/scene_<EnvId>.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by_env: dict[str, list[tuple[str, list[tuple[Path, dict[str, Any]]]]]] = {}
    for (agent, env_id), runs in _runs(Path(agents_dir)).items():
        by_env.setdefault(env_id, []).append((agent, runs))
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for env_id, agents in sorted(by_env.items()):
        fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True, layout="constrained")
        drawn = 0
        for k, (agent, runs) in enumerate(agents):
            curves = [run_curve(run, m) for run, m in runs]
            sources = {s for _, s in curves}
            curves = [c for c, s in curves if s != "none"]
            if not curves:
                continue
            style = "-" if sources == {"validation"} else "--"
            label = f"{agent} ({len(curves)} seed{'s' if len(curves) > 1 else ''}"
            label += ")" if sources == {"validation"} else "; zoo eval, not the validation split)"
            color = f"C{k % 10}"
            for ax, x, scale in ((axes[0], "timesteps", 1e3), (axes[1], "wall_time_s", 60.0)):
                xs, mean, lo, hi = _mean_band(curves, x)
                short = len(xs) <= training.SHORT_CURVE  # one point alone draws no line: mark every point
                ax.plot(xs / scale, mean, style, color=color, lw=1.8, label=label, marker="o" if short else None)
                if len(curves) > 1 and len(xs) > 1:
                    ax.fill_between(xs / scale, lo, hi, color=color, alpha=0.15, lw=0)
                elif len(curves) > 1:  # the runs' range at the one point
                    ax.errorbar(xs / scale, mean, yerr=[mean - lo, hi - mean], fmt="none", color=color, capsize=3)
            drawn += 1
        if not drawn:
            plt.close(fig)
            continue
        axes[0].set_xlabel("env steps (thousands)")
        axes[1].set_xlabel("training wall time (min, this machine)")
        axes[0].set_ylabel("success rate")
        for ax in axes:
            ax.set_ylim(-0.03, 1.03)
            ax.grid(alpha=0.3)
        axes[0].legend(fontsize=7, loc="lower right")
        fig.suptitle(f"{env_id}: success while training (mean over training seeds, band: their range)", fontsize=10)
        path = out_dir / f"scene_{env_id}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def cost_rows(agents_dir: str | Path) -> list[dict[str, Any]]:
    """Per shipped agent and env id: ``agent``, ``algorithm``, ``env_id``, ``seeds``, ``timesteps``,
    ``wall_time_s``, ``env_steps_per_s`` (medians over the seeds) and ``final_success`` (mean; ``None`` if no
    run has one) with ``final_on`` (what it was measured on)."""
    rows = []
    for (agent, env_id), runs in sorted(_runs(Path(agents_dir)).items()):
        manifests = [m for _, m in runs]
        finals = [m["final_eval_success"] for m in manifests if m.get("final_eval_success") is not None]
        rows.append({
            "agent": agent, "algorithm": manifests[0]["algorithm"], "env_id": env_id, "seeds": len(manifests),
            "timesteps": float(np.median([m["timesteps"] for m in manifests])),
            "wall_time_s": float(np.median([m["wall_time_s"] for m in manifests])),
            "env_steps_per_s": float(np.median([m["env_steps_per_s"] for m in manifests])),
            "final_success": float(np.mean(finals)) if finals else None,
            "final_on": sorted({m.get("final_eval_on", "the zoo's eval env") for m in manifests}),
        })
    return rows


def cost_table(agents_dir: str | Path) -> str:
    """:func:`cost_rows` as a markdown table."""
    lines = ["| agent | algorithm | env | seeds | env steps | wall time (min) | env steps/s | final success (on) |",
             "|---|---|---|---:|---:|---:|---:|---|"]
    for r in cost_rows(agents_dir):
        final = "-" if r["final_success"] is None else f"{r['final_success']:.2f} ({', '.join(r['final_on'])})"
        lines.append(f"| {r['agent']} | {r['algorithm']} | {r['env_id']} | {r['seeds']} | {r['timesteps']:,.0f} | "
                     f"{r['wall_time_s'] / 60:.1f} | {r['env_steps_per_s']:,.0f} | {final} |")
    return "\n".join(lines)
