"""Helpers of ``baselines/benchmark.py``: summaries, machine description, memory probes, markdown.

Standard library and numpy only (no psutil): RSS comes from ``/proc/self/statm`` and
``resource.getrusage``.
"""

from __future__ import annotations

import math
import os
import platform
import resource
import sys
from importlib import metadata
from typing import Any, Iterable, Sequence

import numpy as np


# ------------------------------------------------------------------ statistics
def summary(samples: Sequence[float]) -> dict[str, float]:
    """Median and spread of repeated measurements: ``median, q1, q3, min, max, n``."""
    a = np.asarray(list(samples), dtype=float)
    if a.size == 0:
        return {"median": math.nan, "q1": math.nan, "q3": math.nan, "min": math.nan, "max": math.nan, "n": 0}
    q1, med, q3 = np.percentile(a, [25, 50, 75])
    return {"median": float(med), "q1": float(q1), "q3": float(q3),
            "min": float(a.min()), "max": float(a.max()), "n": int(a.size)}


def tail_summary(samples: Sequence[float]) -> dict[str, float]:
    """Distribution of many single timings: ``median, p95, p99, mean, max, n`` (same unit as the input)."""
    a = np.asarray(list(samples), dtype=float)
    if a.size == 0:
        return {"median": math.nan, "p95": math.nan, "p99": math.nan, "mean": math.nan, "max": math.nan, "n": 0}
    med, p95, p99 = np.percentile(a, [50, 95, 99])
    return {"median": float(med), "p95": float(p95), "p99": float(p99),
            "mean": float(a.mean()), "max": float(a.max()), "n": int(a.size)}


# ------------------------------------------------------------------ machine
def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def machine_info() -> dict[str, Any]:
    """CPU model, core counts, OS, Python and the versions of the packages that set the speed."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = os.cpu_count()
    return {
        "cpu": cpu,
        "cores_logical": os.cpu_count(),
        "cores_usable": usable,
        "os": platform.platform(),
        "python": platform.python_version(),
        "python_implementation": platform.python_implementation(),
        "numpy": np.__version__,
        "pymunk": _version("pymunk"),
        "gymnasium": _version("gymnasium"),
        "box2d": _version("box2d") or _version("Box2D"),
        "footstep_gym": _version("footstep_gym"),
        "executable": sys.executable,
    }


# ------------------------------------------------------------------ memory (no psutil)
def rss_bytes() -> int | None:
    """Current resident set size of this process [bytes] (``/proc/self/statm``; ``None`` elsewhere)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            pages = int(f.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def max_rss_bytes() -> int:
    """Peak resident set size of this process so far [bytes] (``getrusage``; KiB on Linux, bytes on macOS)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak) if sys.platform == "darwin" else int(peak) * 1024


# ------------------------------------------------------------------ formatting
def fmt_num(x: float | None, digits: int = 3) -> str:
    """Compact human formatting: 1,234,567 -> '1.23M', 8467 -> '8.47k', 0.0123 -> '0.0123'."""
    if x is None or not math.isfinite(x):
        return "n/a"
    ax = abs(x)
    for scale, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if ax >= scale:
            return f"{x / scale:.{digits}g}{suffix}"
    return f"{x:.{digits}g}"


def fmt_stat(s: dict[str, float] | None, spread: str = "iqr") -> str:
    """``median (q1–q3)`` or ``median (min–max)``."""
    if not s or not s.get("n"):
        return "n/a"
    lo, hi = (s["q1"], s["q3"]) if spread == "iqr" else (s["min"], s["max"])
    return f"{fmt_num(s['median'])} ({fmt_num(lo)}–{fmt_num(hi)})"


def fmt_bytes(n: float | None) -> str:
    if n is None or not math.isfinite(n):
        return "n/a"
    sign = "-" if n < 0 else ""
    n = abs(n)
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{sign}{n:.0f} {unit}" if unit == "B" else f"{sign}{n:.1f} {unit}"
        n /= 1024
    return f"{sign}{n:.1f} GiB"


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def finite_json(obj: Any) -> Any:
    """``obj`` with non-finite floats replaced by ``None`` (strict JSON has no NaN / inf)."""
    if isinstance(obj, dict):
        return {str(k): finite_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_json(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj
