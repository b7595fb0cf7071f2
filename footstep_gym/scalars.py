"""The array namespace ``xp`` of plain Python numbers, for the maths written once for every backend.

Functions written with an array namespace (:func:`footstep_gym.lipm.com_state`,
:mod:`footstep_gym.collision`) run on numpy or JAX arrays with ``xp = numpy`` / ``jax.numpy``, and on
one float or complex number at a time with ``xp`` this module: ``math``'s functions, the builtin
``abs`` (of a complex number too) and the few array functions such code needs, on scalars. A
branch becomes :func:`where`, which computes both arms (cheap for scalars) and picks one.

The compiled kernels (:mod:`footstep_gym.kernels.sweep`) compile the same functions with numba, with
this module as ``xp`` (numba is told how to compile :func:`where`, :func:`minimum` and
:func:`maximum` there); this module never imports numba.
"""

from __future__ import annotations

import builtins
from math import cos, exp, hypot, isfinite, sin, sqrt
from typing import Any

abs = builtins.abs  # noqa: A001 (the array namespaces' name)

__all__ = ["abs", "cos", "exp", "hypot", "isfinite", "maximum", "minimum", "sin", "sqrt", "where"]


def where(condition: Any, x: Any, y: Any) -> Any:
    """``x`` if ``condition`` else ``y`` (``numpy.where`` of scalars; both arms already computed)."""
    return x if condition else y


def minimum(a: Any, b: Any) -> Any:
    """The smaller of ``a`` and ``b``: Python's ``min(a, b)`` (``a`` unless ``b < a``; ``a`` if either is NaN)."""
    return b if b < a else a


def maximum(a: Any, b: Any) -> Any:
    """The larger of ``a`` and ``b``: Python's ``max(a, b)`` (``a`` unless ``b > a``; ``a`` if either is NaN)."""
    return b if b > a else a
