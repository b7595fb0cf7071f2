"""What every scenario shares: start, goal, limits, per-episode randomisation; the hooks it fills."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from footstep_gym import config
from footstep_gym.config import nonnegative, pair, plain, positive
from footstep_gym.errors import ConfigError
from footstep_gym.world import World


@dataclass(frozen=True)
class ScenarioConfig:
    """Keys every scenario's YAML has (SI units)."""

    start: tuple[float, float] = pair()  # [m] robot centre at reset
    start_yaw: float = plain()  # [rad] heading at reset
    start_jitter: float = nonnegative()  # [m] uniform +- jitter of the start, per episode
    goal: tuple[float, float] = pair()  # [m]
    goal_tolerance: float = positive()  # [m]
    time_limit: float = positive()  # [s] simulated, then truncated
    max_steps: int = positive()  # footsteps, then truncated
    randomize: dict = plain()  # {key: [lo, hi]}: drawn uniformly per episode from reset(seed=...)

    def validate(self) -> None:
        fields = {f.name: str(f.type) for f in dataclasses.fields(self)}
        bound_keys = set(self.upper_bounds().values())
        for key, bounds in self.randomize.items():
            if key not in fields or fields[key] != "float" or key in bound_keys:
                numeric = sorted(k for k, t in fields.items() if t == "float" and k not in bound_keys)
                raise ConfigError(f"randomize: {key!r} is not a numeric key of this scenario; use one of {numeric}")
            if not (isinstance(bounds, (list, tuple)) and len(bounds) == 2):
                raise ConfigError(f"randomize.{key} must be [lo, hi], got {bounds!r}")
            lo, hi = (config._number(f"randomize.{key}", b) for b in bounds)
            if lo > hi:
                raise ConfigError(f"randomize.{key} must have lo <= hi, got {bounds!r}")
        self._check_upper_bounds()

    # ------------------------------------------------------------ upper bounds of speeds and scales
    @classmethod
    def upper_bounds(cls) -> dict[str, str]:
        """``{key: max_key}``: every key whose value (and ``randomize`` range) must stay <= the ``max_key``'s.

        Declared on the field (``nonnegative(max_key="max_door_speed", unit="deg/s")``). These are
        the speeds and scales the collision sweep's number of checks grows with.
        """
        return {f.name: f.metadata["max_key"] for f in dataclasses.fields(cls) if f.metadata.get("max_key")}

    def largest(self, key: str) -> float:
        """The largest value numeric ``key`` can take in an episode: its ``randomize`` upper end, else its value."""
        if key in self.randomize:
            return max(float(b) for b in self.randomize[key])
        return float(getattr(self, key))

    def _check_upper_bounds(self) -> None:
        units = {f.name: f.metadata.get("unit", "") for f in dataclasses.fields(self)}
        for key, max_key in self.upper_bounds().items():
            limit = getattr(self, max_key)
            value = self.largest(key)
            if value > limit:
                what = (f"randomize.{key} reaches {value:g}" if key in self.randomize
                        else f"{key}={value:g}")
                unit = f" {units[key]}" if units[key] else ""
                raise ConfigError(
                    f"{type(self).__name__}: {what}{unit} is above {max_key}={limit:g}{unit} (the collision "
                    f"sweep's cost grows with it; raise {max_key} to allow more, at a cost per step)")

    def draw(self, rng: np.random.Generator) -> "ScenarioConfig":
        """This config with every ``randomize`` key drawn from its range (validated again)."""
        if not self.randomize:
            return self
        return config.replace(self, **{k: float(rng.uniform(*v)) for k, v in self.randomize.items()})


class Scenario:
    """A scene: builds its obstacles into a :class:`World` and moves them each footstep.

    Subclasses set ``config_file`` / ``Config`` and fill :meth:`build` (:meth:`build_static`
    for walls, and
    :meth:`before_step` when obstacles change velocity over time). One instance serves one
    episode; it may keep per-episode random draws from ``rng``.
    """

    config_file: ClassVar[str]
    Config: ClassVar[type[ScenarioConfig]]
    #: The config keys :meth:`build_static` reads (properties count by the keys they read); ``None``: any
    #: key may matter. The env keeps its walls across resets while these keys are unchanged.
    static_keys: ClassVar[tuple[str, ...] | None] = None

    def __init__(self, cfg: Any, rng: np.random.Generator) -> None:
        self.cfg = cfg
        self.rng = rng

    @classmethod
    def load_config(cls, overrides: dict[str, Any] | None = None) -> Any:
        return config.load(cls.Config, cls.config_file, overrides)

    @classmethod
    def static_key(cls, cfg: Any) -> Any:
        """What the walls of an episode with config ``cfg`` depend on: equal keys, equal walls."""
        if cls.static_keys is None:
            return cfg
        return tuple(getattr(cfg, k) for k in cls.static_keys)

    def build_static(self, world: World) -> None:
        """Add what never moves (walls). Must not draw from ``rng``: the env keeps these shapes
        across resets while the episode's config is unchanged."""

    def build(self, world: World) -> None:
        """Add the moving obstacles at time 0 (drawing from ``rng`` as needed)."""
        raise NotImplementedError

    def before_step(self, world: World, t: float, duration: float) -> None:
        """Set the obstacles' velocities for the footstep from ``t`` to ``t + duration`` [s]."""
