"""Helpers of ``baselines/benchmark.py``: summaries, machine description, memory probes, markdown.

Standard library and numpy only (no psutil): RSS comes from ``/proc/self/statm``,
``/proc/self/status`` (``VmHWM``, reset through ``/proc/self/clear_refs``) and
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


def median_ratio_interval(numerator: Sequence[Sequence[float]], denominator: Sequence[Sequence[float]],
                          rng: np.random.Generator, n_boot: int = 2000, level: float = 0.95) -> tuple[float, float]:
    """Bootstrap interval of ``median(numerator) / median(denominator)`` resampling *clusters* in pairs.

    ``numerator[i]`` and ``denominator[i]`` are the timings of cluster ``i`` (one seed's episode,
    run by each of two planners): a footstep's time depends on its episode, so episodes, not
    footsteps, are the independent draws. Each of ``n_boot`` resamples draws clusters with
    replacement, the same ones for both sides. Returns the ``level`` percentile interval.
    """
    if len(numerator) != len(denominator) or not len(numerator):
        raise ValueError(f"need the same number (> 0) of clusters on both sides, got {len(numerator)} and "
                         f"{len(denominator)}")
    num = [np.asarray(c, dtype=float) for c in numerator]
    den = [np.asarray(c, dtype=float) for c in denominator]
    k = len(num)
    ratios = np.empty(n_boot)
    for b in range(n_boot):
        pick = rng.integers(0, k, k)
        top, bottom = np.concatenate([num[i] for i in pick]), np.concatenate([den[i] for i in pick])
        ratios[b] = np.median(top) / np.median(bottom) if top.size and bottom.size else np.nan
    lo, hi = np.nanpercentile(ratios, [50 * (1 - level), 50 * (1 + level)])
    return float(lo), float(hi)


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
def loadavg() -> list[float] | None:
    """The 1, 5 and 15 minute load averages (None where the OS has none)."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def rss_bytes() -> int | None:
    """Current resident set size of this process [bytes] (``/proc/self/statm``; ``None`` elsewhere)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            pages = int(f.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def _vm_hwm_bytes() -> int | None:
    """``VmHWM`` (peak RSS) from ``/proc/self/status`` [bytes], ``None`` where unavailable."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


class RssPeak:
    """Peak RSS of this process from now on, C allocations (pymunk/chipmunk, numpy) included.

    ``getrusage``'s ``ru_maxrss`` is the peak over the whole process life, usually set while
    importing. Here, on Linux, writing ``5`` to ``/proc/self/clear_refs`` resets the kernel's
    peak (``VmHWM``) to the current RSS, so :attr:`peak` is the exact peak since then, even
    inside a call. Where that is not allowed, it falls back to the largest current RSS
    seen by :meth:`sample` (call it after every step; it misses peaks inside a call).
    ``peak`` is ``None`` without ``/proc``.
    """

    def __init__(self) -> None:
        self._page = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096
        try:
            self._f = open("/proc/self/statm", "rb", buffering=0)  # noqa: SIM115 - closed in close()
        except OSError:
            self._f = None
        self.sampled_peak: int | None = None
        self.samples = 0
        try:
            with open("/proc/self/clear_refs", "w", encoding="ascii") as f:
                f.write("5")
            self.hwm_reset = _vm_hwm_bytes() is not None
        except OSError:
            self.hwm_reset = False
        self.sample()

    @property
    def method(self) -> str:
        if self.hwm_reset:
            return "VmHWM reset at the baseline (/proc/self/clear_refs)"
        return "current RSS sampled after every step" if self._f is not None or self.samples else "unavailable"

    def sample(self) -> int | None:
        if self._f is None:
            return None
        self._f.seek(0)
        rss = int(self._f.read().split()[1]) * self._page
        self.samples += 1
        if self.sampled_peak is None or rss > self.sampled_peak:
            self.sampled_peak = rss
        return rss

    @property
    def peak(self) -> int | None:
        hwm = _vm_hwm_bytes() if self.hwm_reset else None
        vals = [v for v in (hwm, self.sampled_peak) if v is not None]
        return max(vals) if vals else None

    def close(self) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None


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
