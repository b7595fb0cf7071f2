"""The action: from what an agent sends to the footstep command ``[S, L, θ, T_SS, T_DS]`` the env applies.

Three rules, in this order (docs/model.md §2):

1. **Read in the action's own precision.** A float16/float32 field equal to one of its field's
   limits rounded to that dtype (``float32(0.6) = 0.6000000238``, what SB3 sends at the box's
   upper T_SS bound) is that limit exactly, not a hair beyond it (:func:`pin_to_limits`).
2. **The fixed-period tail.** With ``fixed_period`` the action is ``[S, L, θ]`` and the
   command's ``T_SS, T_DS`` are the robot's nominal ones (:attr:`ActionLimits.tail`).
3. **Clip to the box.** A finite command outside the box is clipped into it, and reported
   (:func:`clip_commands`).

:func:`to_commands` applies them to a batch ``(..., n)`` with numpy; :class:`ActionReader` to one
action in plain Python (the env's step, where numpy's per-call cost on five numbers counts), with
the same arithmetic. Units: m, m, rad, s, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
from gymnasium import spaces

from footstep_gym.errors import ActionError
from footstep_gym.robot import COMMAND_FIELDS, Robot

_FLOAT_DTYPES = (np.dtype(np.float64), np.dtype(np.float32))


@dataclass(frozen=True, eq=False)
class ActionLimits:
    """What reading an action needs: the command box, the values a field is pinned at, the fixed tail."""

    fields: tuple[str, ...]  # the action's fields: COMMAND_FIELDS, or its first three with the period fixed
    low: np.ndarray  # (5,) float64 [m, m, rad, s, s] the command box's lower bounds, the robot's exactly
    high: np.ndarray  # (5,) float64 upper bounds
    pins: tuple[np.ndarray, ...]  # per command field, ascending float64: its box bounds and, for θ, the turn limits
    tail: np.ndarray  # (5 - len(fields),) float64 [s] the fields the action leaves out (nominal T_SS, T_DS)


def action_limits(robot: Robot, fixed_period: bool = False) -> ActionLimits:
    """The :class:`ActionLimits` of ``robot``'s command box; ``fixed_period``: the action is ``[S, L, θ]``."""
    fields = COMMAND_FIELDS[:3] if fixed_period else COMMAND_FIELDS
    low, high = robot.command_low, robot.command_high
    turns = (-robot.turn_outer, -robot.turn_inner, robot.turn_inner, robot.turn_outer)
    pins = tuple(np.array(sorted({lo, hi, *(turns if i == 2 else ())}))
                 for i, (lo, hi) in enumerate(zip(low.tolist(), high.tolist())))
    return ActionLimits(fields, low, high, pins, robot.nominal_command[len(fields):].copy())


def action_space(limits: ActionLimits) -> spaces.Box:
    """``Box(len(fields),)`` float32: the command box's bounds of the action's fields, rounded to float32."""
    n = len(limits.fields)
    return spaces.Box(limits.low[:n].astype(np.float32), limits.high[:n].astype(np.float32), dtype=np.float32)


def pin_to_limits(actions: Any, pins: Sequence[np.ndarray]) -> np.ndarray:
    """``actions`` ``(..., n)`` as float64, each float16/float32 field equal to one of its ``pins`` rounded to the
    action's dtype replaced by that pin (of pins that round alike, the lowest); float64 actions unchanged."""
    a = np.asarray(actions)
    out = a.astype(np.float64)
    if a.dtype.kind != "f" or a.dtype.itemsize >= 8:
        return out
    for i in range(a.shape[-1]):
        column = out[..., i]
        rounded = pins[i].astype(a.dtype).astype(np.float64)
        out[..., i] = np.select([column == r for r in rounded], list(pins[i]), default=column)
    return out


def clip_commands(commands: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(commands clipped to [low, high], whether each was outside)`` for commands ``(..., 5)`` float64."""
    clipped = np.clip(commands, low, high)
    return clipped, np.any(clipped != commands, axis=-1)


def to_commands(actions: Any, limits: ActionLimits) -> tuple[np.ndarray, np.ndarray]:
    """The commands ``(..., 5)`` float64 a batch of actions ``(..., n)`` stands for, and which were clipped ``(...,)``.

    The three rules of this module, vectorised; :class:`ActionReader` is its twin for one action.
    Raises :class:`ActionError` on a wrong last axis or a non-finite value.
    """
    a = np.asarray(actions)
    n = len(limits.fields)
    if a.ndim == 0 or a.shape[-1] != n:
        raise ActionError(f"actions must have a last axis of {n} [{', '.join(limits.fields)}], got shape {a.shape}")
    values = pin_to_limits(a, limits.pins)
    if not np.all(np.isfinite(values)):
        raise ActionError(f"actions hold non-finite values: {values[~np.isfinite(values)][:5].tolist()}")
    if len(limits.tail):
        values = np.concatenate([values, np.broadcast_to(limits.tail, values.shape[:-1] + limits.tail.shape)], axis=-1)
    return clip_commands(values, limits.low, limits.high)


def pin_tables(pins: Sequence[np.ndarray], dtype: Any) -> list[dict[float, float]]:
    """Per field, ``{pin rounded to dtype (as float64): pin}``, the lowest pin where several round alike: the
    lookup :class:`ActionReader` pins a field by (as :func:`pin_to_limits` does)."""
    tables = []
    for p in pins:
        table: dict[float, float] = {}
        for rounded, exact in zip(p.astype(dtype).astype(np.float64).tolist(), p.tolist()):
            table.setdefault(rounded, exact)
        tables.append(table)
    return tables


class ActionReader:
    """Reads one action at a time into its command, in plain Python (the env's step; :func:`to_commands`'s twin).

    ``reader(action, where)`` returns ``(command, clipped)``: the five floats and whether the action lay outside
    the box. A wrong shape or a non-finite field raises :class:`ActionError` naming ``where`` and the field.
    """

    def __init__(self, limits: ActionLimits) -> None:
        self.limits = limits
        self._low, self._high = limits.low.tolist(), limits.high.tolist()
        self._tail = limits.tail.tolist()
        self._tables: dict[np.dtype, list[dict[float, float]]] = {}  # per action dtype, made when first met

    def __call__(self, action: Any, where: str) -> tuple[list[float], bool]:
        fields = self.limits.fields
        if type(action) is np.ndarray and action.shape == (len(fields),) and action.dtype in _FLOAT_DTYPES:
            raw, values = action, action.tolist()  # float32 and float64 convert to Python floats exactly
        else:
            try:
                raw = np.asarray(action)
                a = raw.astype(np.float64)
            except (TypeError, ValueError) as exc:
                raise ActionError(f"{where}: action must be {len(fields)} numbers [{', '.join(fields)}], "
                                  f"got {action!r}") from exc
            if a.shape != (len(fields),):
                raise ActionError(f"{where}: action shape={a.shape} but expected ({len(fields)},) = "
                                  f"[{', '.join(fields)}]")
            values = a.tolist()
        if not all(map(math.isfinite, values)):
            bad = [f"{name}={v}" for name, v in zip(fields, values) if not math.isfinite(v)]
            raise ActionError(f"{where}: action has non-finite field(s): {', '.join(bad)}")
        dtype = raw.dtype
        if dtype.kind == "f" and dtype.itemsize < 8:
            # Each pin rounded to the action's dtype, back in float64 (exactly): equal to the action's field
            # (exact in float64 too) exactly when equal in that dtype.
            tables = self._tables.get(dtype)
            if tables is None:
                tables = self._tables[dtype] = pin_tables(self.limits.pins, dtype)
            values = [table.get(v, v) for table, v in zip(tables, values)]
        if self._tail:
            values += self._tail
        command = [lo if v < lo else hi if v > hi else v for v, lo, hi in zip(values, self._low, self._high)]
        return command, command != values
