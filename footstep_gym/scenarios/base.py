"""What every scenario shares: start, goal, limits, per-episode randomisation; the hooks it fills."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

from footstep_gym import config
from footstep_gym.config import nonnegative, pair, plain, positive
from footstep_gym.errors import ConfigError
from footstep_gym.scenes import draw_config
from footstep_gym.world import World


@dataclass(frozen=True, kw_only=True)
class ScenarioConfig:
    """Keys every scenario's YAML has (SI units), with defaults in code (a scene overrides those it sets otherwise;
    its YAML documents them and may override them again). Keyword-only, so a scenario's own keys need no default."""

    start: tuple[float, float] = pair(default=(0.0, 0.0))  # [m] robot centre at reset
    start_yaw: float = plain(default=0.0)  # [rad] heading at reset
    start_jitter: float = nonnegative(default=0.02)  # [m] uniform +- jitter of the start, per episode
    goal: tuple[float, float] = pair(default=(1.9, 0.0))  # [m]
    goal_tolerance: float = positive(default=0.1)  # [m]
    time_limit: float = positive(default=60.0)  # [s] simulated, then truncated
    max_steps: int = positive(default=200)  # footsteps, then truncated
    randomize: dict = plain(default={})  # {key: [lo, hi]}: drawn uniformly per episode from reset(seed=...)

    #: Top-level sections of the YAML that are no fields (so no ``gymnasium.make`` keywords): ``config.load``
    #: sets them aside; ``fuzz`` is read by :meth:`Scenario.fuzz_ranges`.
    SIDE_SECTIONS: ClassVar[tuple[str, ...]] = ("fuzz",)

    @classmethod
    def numeric_keys(cls) -> list[str]:
        """The float keys ``randomize`` (and a scenario's ``fuzz`` and ``sweep_axes``) may name: no ``max_*`` bound."""
        bound_keys = set(cls.upper_bounds().values())
        return [name for name in config.numeric_fields(cls) if name not in bound_keys]

    def validate(self) -> None:
        numeric = self.numeric_keys()
        for key, bounds in self.randomize.items():
            if key not in numeric:
                raise ConfigError(f"randomize: {key!r} is not a numeric key of this scenario; "
                                  f"use one of {sorted(numeric)}")
            if not (isinstance(bounds, (list, tuple)) and len(bounds) == 2):
                raise ConfigError(f"randomize.{key} must be [lo, hi], got {bounds!r}")
            lo, hi = (config.number(f"randomize.{key}", b) for b in bounds)
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
                unit = f" {units[key]}" if units[key] else ""
                what = (f"randomize.{key} reaches {value:g}{unit}, above" if key in self.randomize
                        else f"{key}={value:g}{unit} is above")
                raise ConfigError(
                    f"{type(self).__name__}: {what} {max_key}={limit:g}{unit} (the collision "
                    f"sweep's cost grows with it; raise {max_key} to allow more, at a cost per step)")

    def draw(self, rng: np.random.Generator) -> "ScenarioConfig":
        """This config with every ``randomize`` key drawn from its range (validated again)."""
        if not self.randomize:
            return self
        return config.replace(self, **draw_config(self, rng))


class RobotMotion(NamedTuple):
    """The robot over one footstep, as :meth:`Scenario.before_step` gets it (world frame, SI units)."""

    position: tuple[float, float]  # [m] CoM (the body circle's centre) at the footstep's start
    velocity: tuple[float, float]  # [m/s] chord: (CoM at the footstep's end - at its start) / its duration


class Scenario:
    """A scene: builds its obstacles into a :class:`World` and moves them each footstep.

    Subclasses set ``config_file`` / ``Config`` and fill :meth:`build` (:meth:`build_static`
    for walls, and
    :meth:`before_step` when obstacles change velocity over time). One instance serves one
    episode; it may keep per-episode random draws from ``rng``.
    """

    #: The YAML: a path relative to ``configs/`` (``"scenarios/door.yaml"``) or an absolute path.
    config_file: ClassVar[str]
    Config: ClassVar[type[ScenarioConfig]]
    #: The id ``gymnasium.make`` knows it by (registered by ``footstep_gym.scenarios.register_scenario``).
    env_id: ClassVar[str]
    #: ``{key: unit}``: the numeric config keys an evaluation sweeps for this scene (``eval_planner.py``
    #: gives each a flag, ``door_speed`` -> ``--door-speed``; the unit labels flags and figures).
    sweep_axes: ClassVar[dict[str, str]] = {}
    #: Whether an evaluation writes this scene's command tables (as the paper's Tables 2 and 4) beside its figures.
    command_tables: ClassVar[bool] = True
    #: The config keys :meth:`build_static` reads (properties count by the keys they read); ``None``: any
    #: key may matter. The env keeps its walls across resets while these keys are unchanged.
    static_keys: ClassVar[tuple[str, ...] | None] = None
    #: ``gymnasium.make_vec``'s ``vector_entry_point`` for this scene: its batched backend (``None``: none).
    vector_entry_point: ClassVar[str | None] = None

    def __init__(self, cfg: Any, rng: np.random.Generator) -> None:
        self.cfg = cfg
        self.rng = rng

    @classmethod
    def load_config(cls, overrides: dict[str, Any] | None = None) -> Any:
        return config.load(cls.Config, cls.config_file, overrides)

    @classmethod
    def fuzz_ranges(cls) -> dict[str, tuple[float, float]]:
        """``{key: (lo, hi)}``: the ``randomize=`` ranges a soak test draws from, in the YAML's order.

        Read from the YAML's top-level ``fuzz:`` section (no field, so no ``gymnasium.make``
        keyword; ``{}`` without one). Each key must be a numeric key ``randomize`` accepts, with
        ``lo <= hi`` allowed by the field at both ends; a ``hi`` of ``.inf`` means up to the key's
        ``max_*`` bound (read from the base config), a finite one must not pass that bound.
        Raises :class:`ConfigError` naming the file and the key.
        """
        where = f"{cls.config_file}: fuzz"
        section = config.read_yaml(cls.config_file).get("fuzz")
        if section is None:
            return {}
        if not isinstance(section, dict):
            raise ConfigError(f"{where} must be a mapping {{key: [lo, hi]}}, got {section!r}")
        base = cls.load_config()
        fields = {f.name: f for f in dataclasses.fields(cls.Config)}
        numeric = cls.Config.numeric_keys()
        bounds = cls.Config.upper_bounds()
        out: dict[str, tuple[float, float]] = {}
        for key, value in section.items():
            if key not in numeric:
                raise ConfigError(f"{where}: {key!r} is not a numeric key of {cls.Config.__name__}; "
                                  f"use one of {sorted(numeric)}")
            if not (isinstance(value, (list, tuple)) and len(value) == 2):
                raise ConfigError(f"{where}.{key} must be [lo, hi], got {value!r}")
            lo = config.number(f"{where}.{key}", value[0])
            if key in bounds and isinstance(value[1], float) and value[1] == float("inf"):
                hi = float(getattr(base, bounds[key]))  # .inf: up to the bound
            else:
                hi = config.number(f"{where}.{key}", value[1])
            if lo > hi:
                raise ConfigError(f"{where}.{key} must have lo <= hi, got {value!r}")
            if key in bounds and hi > getattr(base, bounds[key]):
                raise ConfigError(f"{where}.{key} reaches {hi:g}, above {bounds[key]}={getattr(base, bounds[key]):g} "
                                  "(write .inf for up to the bound)")
            check = fields[key].metadata.get("check")
            inside = {"positive": lo > 0, "nonnegative": lo >= 0, "fraction": lo > 0 and hi <= 1}.get(check, True)
            if not inside:
                raise ConfigError(f"{where}.{key} = {value!r} leaves the field's range ({check})")
            out[key] = (lo, hi)
        try:  # every range at once, as randomize= (the scenario's own checks, e.g. on sizes)
            cls.load_config({"randomize": {k: list(v) for k, v in out.items()}})
        except ConfigError as exc:
            raise ConfigError(f"{where}: as randomize=, {exc}") from None
        return out

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

    def before_step(self, world: World, t: float, duration: float, robot: RobotMotion | None = None) -> None:
        """Set the obstacles' velocities for the footstep from ``t`` to ``t + duration`` [s].

        ``robot``: the robot over that footstep (its CoM at ``t`` and chord velocity), for obstacles that
        react to it (the ORCA crowd with ``robot_visible``); ``None`` when unknown. Others ignore it."""
