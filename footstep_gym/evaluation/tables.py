"""How every evaluation table writes its numbers, and the one markdown writer (pandas' ``to_markdown``).

The evaluation's summary, the results pages, ``benchmark.md`` and ``leaderboard.md`` build a pandas DataFrame of
text cells with these formatters and write it with :func:`markdown`; :func:`grid` pivots records into a row per
setting and a column per policy.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import pandas as pd

#: What a table shows where there is no number (no success, nothing measured, not run).
DASH = "–"


def num(value: float | None, digits: int = 2, scale: float = 1.0) -> str:
    """``value * scale`` with ``digits`` decimals, or :data:`DASH` for None or NaN."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return DASH
    return f"{value * scale:.{digits}f}"


def mm(value: float | None) -> str:
    """A length in metres as whole millimetres."""
    return num(value, 0, 1000.0)


def percent(value: float | None) -> str:
    """A share as whole percent: ``45 %``."""
    return DASH if value is None else f"{num(value, 0, 100.0)} %"


def interval(value: float, ci: Sequence[float], digits: int = 2) -> str:
    """``0.95 [0.76, 0.99]``."""
    return f"{value:.{digits}f} [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"


def runs(n: int) -> str:
    """``1 run``, ``3 runs``."""
    return f"{n} run{'' if n == 1 else 's'}"


def plural(n: int, word: str) -> str:
    """``1 policy``, ``3 policies``, ``2 cells``."""
    if n == 1:
        return f"{n} {word}"
    return f"{n} {word[:-1]}ies" if word.endswith("y") and word[-2:-1] not in "aeiou" else f"{n} {word}s"


def markdown(table: pd.DataFrame, left: int = 1) -> str:
    """``table`` as a GitHub markdown table (its cells as they are, no index): the first ``left`` columns aligned
    left, the others right."""
    align = ["left"] * left + ["right"] * (table.shape[1] - left)
    return table.astype(str).to_markdown(index=False, colalign=align, disable_numparse=True) + "\n"


def grid(table: pd.DataFrame, index: str, columns: str, values: str, order: Sequence[Any] | None = None
         ) -> pd.DataFrame:
    """``table`` pivoted: a row per ``index`` value (in their first order), a column per ``columns`` value (in
    ``order``, default their first order), each cell its ``values`` entry (:data:`DASH` where there is none); the
    index becomes the first column."""
    rows = list(dict.fromkeys(table[index]))
    cols = list(order) if order is not None else list(dict.fromkeys(table[columns]))
    wide = table.pivot(index=index, columns=columns, values=values).reindex(index=rows, columns=cols)
    return wide.fillna(DASH).reset_index()
