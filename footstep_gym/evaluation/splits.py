"""Disjoint seed ranges for training, validation (tuning) and the reported test (``configs/eval.yaml``).

As CrowdNav keeps validation and test cases apart, an evaluation names its split and the
episodes take the split's seeds in order: ``split_seeds("validation", 20)`` is the first 20
validation seeds, ``split_seeds("validation", 20, offset=20)`` the next 20. The ``test`` split is the board's: its seeds are
given only to a release run (``split_seeds("test", n, release=True)``: ``eval_planner.py --benchmark --release``,
docs/benchmark.md §5), so no development run can touch it by mistake. The splits are the same for every
tier: a trainer on tier T (the in-distribution track) resets ``gym.make(id, tier=T)`` with
``train`` seeds (:func:`train_seed_stream`), is tuned on ``validation`` and reported on ``test``.
:data:`PROTOCOL_VERSION` is the file's ``protocol_version``, written into every ``benchmark.json``.
"""

from __future__ import annotations

from typing import Iterator

from footstep_gym.config import read_yaml
from footstep_gym.errors import ConfigError


def _load() -> tuple[dict[str, tuple[int, int]], int]:
    data = read_yaml("eval.yaml")
    version = data.get("protocol_version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise ConfigError(f"eval.yaml: protocol_version must be a whole number >= 1, got {version!r}")
    raw = data.get("splits")
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
    missing = [name for name in ("train", "validation", "test") if name not in splits]
    if missing:
        raise ConfigError(f"eval.yaml: splits {', '.join(missing)} missing (the protocol needs train, validation "
                          f"and test)")
    return splits, version


SPLITS: dict[str, tuple[int, int]]
#: The split of the board's results, run only by a release (:func:`split_seeds` ``release=True``).
TEST = "test"
#: The benchmark protocol's version (``configs/eval.yaml``): 3 since protocol 3's fresh test split.
PROTOCOL_VERSION: int
SPLITS, PROTOCOL_VERSION = _load()


def split_seeds(split: str, n: int, offset: int = 0, *, release: bool = False) -> list[int]:
    """``n`` seeds of ``split``, from its ``offset``-th seed on. The :data:`TEST` split's only with ``release``
    (a release run of the board): ``ValueError`` otherwise."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; choose one of {sorted(SPLITS)}")
    if split == TEST and not release:
        raise ValueError("the test split is the board's: it runs only as eval_planner.py --benchmark --release "
                         "(committed code, logged); develop on the validation split")
    first, end = SPLITS[split]
    if n < 1 or offset < 0:
        raise ValueError(f"need n >= 1 and offset >= 0, got n={n} offset={offset}")
    if first + offset + n > end:
        raise ValueError(f"split {split!r} has {end - first} seeds; offset {offset} + {n} episodes goes past its end")
    return list(range(first + offset, first + offset + n))


def train_seed_stream(seed: int = 0) -> Iterator[int]:
    """Episode seeds for a trainer: the ``train`` split's seeds from its ``seed``-th on, in order, for ever (wrapping
    round the split), e.g. ``env.reset(seed=next(stream))`` per episode of ``gym.make(id, tier=T)``."""
    first, end = SPLITS["train"]
    if not 0 <= seed < end - first:
        raise ValueError(f"seed must index the train split's {end - first} seeds, got {seed}")
    k = seed
    while True:
        yield first + k
        k = (k + 1) % (end - first)
