"""Formatting of figures for the markdown reports, and strict JSON (no NaN / inf)."""

from __future__ import annotations

import math
from typing import Any, Iterable, Sequence

import numpy as np


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
