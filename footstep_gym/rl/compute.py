"""The compute protocol for learned rows (docs/benchmark.md, "Compute protocol for learned rows").

The declared budget per track (env steps per training run) and the convergence rule's window are in
``configs/compute.yaml`` (:func:`load_protocol`). :func:`run_status` reads one shipped run (its ``manifest.json``
and learning curve), :func:`row_training` sums a board row's runs up (env steps per run, at budget or not, how
many converged, their wall and CPU times), :func:`training_text` says it in one line.

A run has **converged** when the last :data:`PLATEAU_WINDOW` points of its validation learning curve lie within
:func:`plateau_tolerance` of one another (their largest minus their smallest success rate). The tolerance is
counted in episodes, so the rule is exact on the recorded rates: one point's success rate over ``n`` episodes has
a binomial standard deviation ``sqrt(p (1 - p) / n)``, at most ``0.5 / sqrt(n)`` (at ``p = 0.5``); the tolerance
is that worst case rounded up to whole episodes, ``ceil(0.5 sqrt(n)) / n``: 4 of 40 episodes (0.10), 3 of 20
(0.15). A narrower one would call a flat curve unconverged by its episode noise alone.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from footstep_gym.errors import ConfigError

#: Validation points the rule looks at: the last three.
PLATEAU_WINDOW = 3


def plateau_tolerance(episodes: int) -> float:
    """The largest spread [success rate] of a plateau's points over ``episodes`` validation episodes each:
    ``ceil(0.5 sqrt(episodes)) / episodes`` (the module doc)."""
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"plateau_tolerance: episodes must be a whole number >= 1, got {episodes!r}")
    return math.ceil(0.5 * math.sqrt(episodes)) / episodes


def plateaued(success: Sequence[float], episodes: int, window: int = PLATEAU_WINDOW) -> bool:
    """Whether a learning curve (success rates in ``[0, 1]``, one per validation point of ``episodes`` episodes,
    in training order) ends on a plateau: its last ``window`` points within :func:`plateau_tolerance` of one
    another. A curve with fewer than ``window`` points has not shown one (False).

    Raises:
        ValueError: a rate outside ``[0, 1]`` or not a whole number of episodes out of ``episodes``.
    """
    if isinstance(window, bool) or not isinstance(window, int) or window < 2:
        raise ValueError(f"plateaued: window must be a whole number >= 2, got {window!r}")
    tol = plateau_tolerance(episodes)
    wins = []
    for rate in success:
        won = float(rate) * episodes
        if not (0.0 <= float(rate) <= 1.0) or abs(won - round(won)) > 1e-3:
            raise ValueError(f"plateaued: success {rate!r} is not a whole number of {episodes} episodes in [0, 1]")
        wins.append(round(won))
    if len(wins) < window:
        return False
    last = wins[-window:]
    return max(last) - min(last) <= round(tol * episodes)


def converged_count(curves: Sequence[Sequence[float]], episodes: Sequence[int]) -> int:
    """How many of ``curves`` (each with its ``episodes`` per point) have :func:`plateaued`."""
    if len(curves) != len(episodes):
        raise ValueError(f"converged_count: {len(curves)} curves but {len(episodes)} episode counts")
    return sum(plateaued(c, n) for c, n in zip(curves, episodes))


# ---------------------------------------------------------------- the declared protocol
#: The tracks a budget is declared for: the generalisation track and the in-distribution tracks' tiers.
TRACKS = ("generalisation", "structure", "noise")


@dataclass(frozen=True)
class ComputeProtocol:
    """``configs/compute.yaml``: the budget [env steps per run] per track, the rule's window and episodes."""

    budget_env_steps: dict[str, int]
    window: int
    validation_episodes: int

    def budget(self, trained_on_tier: str | None = None) -> int | None:
        """The declared budget of a row: its in-distribution tier's (``trained_on_tier``), else the generalisation
        track's; None for a tier without one."""
        return self.budget_env_steps.get("generalisation" if trained_on_tier is None else trained_on_tier)


def load_protocol(path: str | Path | None = None) -> ComputeProtocol:
    """``configs/compute.yaml`` (or ``path``), validated; :class:`ConfigError` naming the first bad key."""
    from footstep_gym.config import read_yaml

    where = str(path) if path is not None else "configs/compute.yaml"
    data = read_yaml(str(path) if path is not None else "compute.yaml")
    budgets = data.get("budget_env_steps")
    if not isinstance(budgets, dict) or sorted(budgets) != sorted(TRACKS):
        raise ConfigError(f"{where}: budget_env_steps must map exactly {', '.join(TRACKS)} to env steps, "
                          f"got {budgets!r}")
    for track, steps in budgets.items():
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
            raise ConfigError(f"{where}: budget_env_steps.{track} must be a whole number >= 1, got {steps!r}")
    conv = data.get("convergence")
    if not isinstance(conv, dict) or sorted(conv) != ["validation_episodes", "window"]:
        raise ConfigError(f"{where}: convergence must hold window and validation_episodes, got {conv!r}")
    for key, low in (("window", 2), ("validation_episodes", 1)):
        v = conv[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < low:
            raise ConfigError(f"{where}: convergence.{key} must be a whole number >= {low}, got {v!r}")
    return ComputeProtocol(dict(budgets), conv["window"], conv["validation_episodes"])


# ---------------------------------------------------------------- shipped runs
def run_curve(run: Path) -> tuple[list[float], int, str | None]:
    """A shipped run's learning curve: ``(success per point, episodes per point, source)``; the source is
    ``"validation"`` (its ``validation.csv``, the validation split), ``"zoo evaluation"`` (rl_zoo3's
    ``evaluations.npz``, its eval env's seeds) or None (no curve: ``([], 0, None)``)."""
    from footstep_gym.rl.training import eval_curve, validation_curve

    curve = validation_curve(run)
    if curve["success"]:
        return curve["success"], int(curve["episodes"]), "validation"
    curve = eval_curve(run)
    if curve["success"]:
        import numpy as np

        with np.load(run / "evaluations.npz") as data:
            episodes = int(data["successes"].shape[1])
        return curve["success"], episodes, "zoo evaluation"
    return [], 0, None


def run_status(run: str | Path, window: int = PLATEAU_WINDOW) -> dict[str, Any]:
    """One shipped run (``<agents>/<agent>/<EnvId>_<seed>/``): its env id, env steps, wall and CPU time [s] (None
    where its manifest lacks them), its curve's points, episodes and source (:func:`run_curve`), and whether it
    converged (:func:`plateaued`; None without a curve)."""
    run = Path(run)
    path = run / "manifest.json"
    if not path.is_file():
        raise FileNotFoundError(f"{run}: no manifest.json (not a shipped run)")
    manifest = json.loads(path.read_text(encoding="utf-8"))
    success, episodes, source = run_curve(run)
    timesteps = manifest.get("timesteps")
    return {"run": run.name, "env_id": manifest.get("env_id"),
            "timesteps": int(timesteps) if timesteps is not None else None,
            "wall_time_s": manifest.get("wall_time_s"), "cpu_time_s": manifest.get("cpu_time_s"),
            "points": len(success), "episodes": episodes, "curve": source,
            "converged": plateaued(success, episodes, window) if source else None}


def resolve_run(path: str | Path, agents_dir: str | Path) -> Path | None:
    """A benchmark file's agent run (an absolute path on the machine that evaluated it) here: the path itself if it
    is a shipped run, else ``<agents_dir>/<agent>/<run>`` by its last two parts; None if neither is."""
    path = Path(path)
    for candidate in (path, Path(agents_dir) / path.parent.name / path.name):
        if (candidate / "manifest.json").is_file():
            return candidate
    return None


def row_training(runs: Sequence[str | Path], agents_dir: str | Path, declared: int | None,
                 window: int = PLATEAU_WINDOW) -> dict[str, Any]:
    """A learned row's training, from its shipped runs (:func:`run_status`): the env steps per run (distinct values,
    ascending; a run whose manifest lacks them is counted in ``unknown_steps``), whether every run trained at least
    ``declared`` env steps (None: a run's steps unknown), how many runs converged out of how many have a curve, the
    median wall time per run and the summed CPU time [s] (None where a manifest lacks it), and runs not found."""
    found = [(r, resolve_run(r, agents_dir)) for r in runs]
    statuses = [run_status(p, window) for _, p in found if p is not None]
    steps = sorted({s["timesteps"] for s in statuses if s["timesteps"] is not None})
    unknown = sum(s["timesteps"] is None for s in statuses)
    walls = sorted(float(s["wall_time_s"]) for s in statuses if s["wall_time_s"] is not None)
    cpus = [float(s["cpu_time_s"]) for s in statuses if s["cpu_time_s"] is not None]
    with_curve = [s for s in statuses if s["converged"] is not None]
    return {"runs": len(statuses), "missing_runs": [str(r) for r, p in found if p is None],
            "env_steps_per_run": steps, "unknown_steps": unknown, "declared_budget": declared,
            "at_budget": None if unknown or not statuses or declared is None else all(
                s["timesteps"] >= declared for s in statuses),
            "converged": sum(bool(s["converged"]) for s in with_curve), "with_curve": len(with_curve),
            "curve_sources": sorted({s["curve"] for s in with_curve}),
            "median_wall_time_s": walls[len(walls) // 2] if walls else None,
            "cpu_time_s": round(sum(cpus), 1) if cpus and len(cpus) == len(statuses) else None}


def short_steps(n: int) -> str:
    """Env steps, short: ``2e7``, ``6e5``, ``8.2e5``."""
    mantissa, exponent = f"{int(n):.1e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


def steps_text(row: Mapping[str, Any]) -> str:
    """A row's env steps per run (:func:`row_training`): ``"6e5"``, ``"3e5-1e6"``; ``"unknown"`` if no run records
    them, ``" (k unknown)"`` added for runs that do not."""
    steps = row.get("env_steps_per_run") or []
    if not steps:
        return "unknown"
    text = short_steps(steps[0]) if len(steps) == 1 else f"{short_steps(steps[0])}-{short_steps(steps[-1])}"
    return text + (f" ({row['unknown_steps']} unknown)" if row.get("unknown_steps") else "")


def converged_text(row: Mapping[str, Any]) -> str:
    """``"2/5 converged"`` (runs with a curve), ``" (k without a curve)"`` added; ``"no curves"``."""
    if not row.get("with_curve"):
        return "no curves"
    text = f"{row['converged']}/{row['with_curve']} converged"
    return text + (f" ({row['runs'] - row['with_curve']} without a curve)" if row["with_curve"] < row["runs"] else "")


def training_text(row: Mapping[str, Any] | None) -> str:
    """One line of a row's training (:func:`row_training`), e.g. ``"3e5-1e6 steps/run (below 2e7), 2/9 converged"``;
    ``"unknown"`` without runs."""
    if not row or not row.get("runs"):
        return "unknown"
    text = steps_text(row) + " steps/run"
    if row.get("at_budget") is True:
        text += " (at budget)"
    elif row.get("at_budget") is False and row.get("declared_budget"):
        text += f" (below {short_steps(row['declared_budget'])})"
    return f"{text}, {converged_text(row)}"
