"""Disjoint seed ranges for training, validation (tuning) and the reported test (``configs/eval.yaml``).

As CrowdNav keeps validation and test cases apart, an evaluation names its split and the
episodes take the split's seeds in order: ``split_seeds("test", 20)`` is the first 20 test
seeds, ``split_seeds("test", 20, offset=20)`` the next 20.
"""

from __future__ import annotations

from footstep_gym.config import read_yaml
from footstep_gym.errors import ConfigError


def _load() -> dict[str, tuple[int, int]]:
    raw = read_yaml("eval.yaml").get("splits")
    if not isinstance(raw, dict) or not raw:
        raise ConfigError("eval.yaml: expected a mapping 'splits: {name: [first, end]}'")
    splits: dict[str, tuple[int, int]] = {}
    for name, bounds in raw.items():
        if not (isinstance(bounds, list) and len(bounds) == 2 and all(isinstance(v, int) for v in bounds)
                and 0 <= bounds[0] < bounds[1]):
            raise ConfigError(f"eval.yaml: splits.{name} must be [first, end) whole numbers, 0 <= first < end; "
                              f"got {bounds!r}")
        splits[name] = (bounds[0], bounds[1])
    ranges = sorted(splits.values())
    for (a0, a1), (b0, _) in zip(ranges, ranges[1:]):
        if b0 < a1:
            raise ConfigError(f"eval.yaml: splits overlap ({a0}-{a1} and {b0}-...)")
    return splits


SPLITS: dict[str, tuple[int, int]] = _load()


def split_seeds(split: str, n: int, offset: int = 0) -> list[int]:
    """``n`` seeds of ``split``, from its ``offset``-th seed on."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; choose one of {sorted(SPLITS)}")
    first, end = SPLITS[split]
    if n < 1 or offset < 0:
        raise ValueError(f"need n >= 1 and offset >= 0, got n={n} offset={offset}")
    if first + offset + n > end:
        raise ValueError(f"split {split!r} has {end - first} seeds; offset {offset} + {n} episodes goes past its end")
    return list(range(first + offset, first + offset + n))
