"""Benchmark tiers: named distributions of scene settings, read from ``configs/benchmark.yaml``.

Every scene env takes ``tier=`` at ``gymnasium.make`` (as Procgen's envs take
``distribution_mode``): ``"paper"`` (the default: today's fixed settings, the paper's scenes),
``"train"`` (the distribution the shipped agents trained on), ``"shifted"`` (the same layouts
beyond the training ranges) and ``"hard"`` (challenges beyond speed: a second door, two-way
traffic, a reactive crowd, sensing noise). The tiers are data, not code: each tier holds, per
scene, a list of named **cells**, each a mapping of env keywords (any key of the scene's YAML,
``randomize`` ranges included, and the ``sensing_*`` keys of ``configs/env.yaml`` that do not
shape the observation). ``gymnasium.make(id, tier="shifted")`` draws one of the tier's cells per
episode, uniformly, from the env's seeded generator (``reset(seed=s)`` fixes the cell and the
episode; a tier with one cell draws nothing, so ``tier="paper"`` is today's env bit for bit), and
``tier_cell="fast"`` picks one cell for every episode (what a benchmark reports per cell).

Keywords given with a tier are applied on top of its cells, except those a cell sets (as a value
or as a ``randomize`` range): giving one of those raises :class:`~footstep_gym.errors.ConfigError`
naming it, since a tier is a documented distribution whose results must stay comparable
(``tier="paper"`` sets nothing, so every key is free there, as without a tier).

The file is read and its structure and key names checked when a tier is first asked for (an
unknown tier or cell raises ``ConfigError`` naming the known ones; a cell's unknown key raises
the env's own message naming the scene's keys); a cell's values are checked by the scene's
config when an env of that tier is made (every cell of the tier is built then, so a bad value
fails at ``gymnasium.make``, not at some later reset). ``tests/test_tiers.py`` builds every cell
of every tier.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from typing import Any, Mapping

from footstep_gym import config
from footstep_gym.env_config import EnvConfig
from footstep_gym.errors import ConfigError

#: The file, relative to ``configs/``.
TIERS_FILE = "benchmark.yaml"
#: The tier of an env made without ``tier=``: the paper's scenes, unchanged.
DEFAULT_TIER = "paper"
#: A tier's key that is no scene: one line saying what the tier is.
ABOUT_KEY = "about"
#: Top-level keys with this prefix are no tiers: blocks the cells share through YAML anchors (``x-noise: &noise``).
SHARED_PREFIX = "x-"
#: The cell of a scene the default tier does not list (a scenario registered by a plugin): no keywords.
DEFAULT_CELL = "default"
#: Keys of ``configs/env.yaml`` a cell may set: these prefixes, less :data:`SHAPING_ENV_KEYS`.
CELL_ENV_PREFIXES = ("sensing_",)
#: env.yaml keys no cell may set: they shape the observation space, which must be one for all cells.
SHAPING_ENV_KEYS = ("sensing_range",)


@dataclass(frozen=True)
class TierCell:
    """One cell of a tier for one scene: its name and the env keywords it sets (shared: read it, copy it with
    :func:`plain` to change it)."""

    tier: str
    scene: str
    name: str
    kwargs: Mapping[str, Any]

    @property
    def keys(self) -> frozenset[str]:
        """The keys the cell fixes: those it sets and those its ``randomize`` draws."""
        fixed = {k for k in self.kwargs if k != "randomize"}
        return frozenset(fixed | set(self.kwargs.get("randomize") or {}))


@dataclass(frozen=True)
class Tier:
    """A tier: its name, its ``about`` line and its cells per scene (``{scene: {cell: TierCell}}``)."""

    name: str
    about: str
    scenes: Mapping[str, Mapping[str, TierCell]]


_CACHE: dict[tuple[str, int], dict[str, Tier]] = {}


def plain(value: Any) -> Any:
    """A deep copy of a cell's data as plain dicts and lists, what ``gymnasium.make`` and the configs take."""
    if isinstance(value, Mapping):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


def cell_env_keys() -> list[str]:
    """The keys of ``configs/env.yaml`` a cell may set (sensing keys that leave the spaces alone)."""
    return [f.name for f in dataclasses.fields(EnvConfig)
            if f.name.startswith(CELL_ENV_PREFIXES) and f.name not in SHAPING_ENV_KEYS]


def check_cell_keys(scene: str, kwargs: Mapping[str, Any], where: str) -> None:
    """Raise :class:`ConfigError` (the env's own message for unknown keys) if ``kwargs`` holds a key no cell of
    ``scene`` may set: neither a key of the scene's config nor one of :func:`cell_env_keys`."""
    from footstep_gym.scenarios import SCENARIOS

    cls = SCENARIOS[scene].Config
    scene_keys = [f.name for f in dataclasses.fields(cls)]
    known = scene_keys + cell_env_keys()
    unknown = [k for k in kwargs if k not in known]
    if unknown:
        raise ConfigError(config.unknown_keys_message(where, unknown, known)
                          + " (a cell sets scene keys and the sensing_* keys of env.yaml but sensing_range; "
                            "no robot keys)")
    randomize = kwargs.get("randomize")
    if randomize is not None and not isinstance(randomize, Mapping):
        raise ConfigError(f"{where}.randomize must be a mapping {{key: [lo, hi]}}, got {randomize!r}")
    numeric = cls.numeric_keys()
    bad = [k for k in (randomize or {}) if k not in numeric]
    if bad:
        raise ConfigError(f"{where}.randomize: {', '.join(map(repr, bad))} is no numeric key of scene {scene!r}; "
                          f"use one of {sorted(numeric)}")


def _parse(data: Any, where: str) -> dict[str, Tier]:
    from footstep_gym.scenarios import SCENARIOS

    if not isinstance(data, Mapping) or not data:
        raise ConfigError(f"{where}: expected a mapping of tiers {{tier: {{{ABOUT_KEY}: ..., scene: {{cell: "
                          "{keywords}}}}}}}")
    if DEFAULT_TIER not in data:
        raise ConfigError(f"{where}: the default tier {DEFAULT_TIER!r} is missing")
    tiers: dict[str, Tier] = {}
    for name, body in data.items():
        if not isinstance(name, str) or not name:
            raise ConfigError(f"{where}: a tier's name must be a non-empty string, got {name!r}")
        if name.startswith(SHARED_PREFIX):  # YAML anchors shared by cells (as docker compose's x- keys): no tier
            continue
        if not isinstance(body, Mapping):
            raise ConfigError(f"{where}: tier {name!r} must be a mapping {{{ABOUT_KEY}: ..., scene: {{cell: ...}}}}, "
                              f"got {body!r}")
        about = body.get(ABOUT_KEY, "")
        if not isinstance(about, str):
            raise ConfigError(f"{where}: {name}.{ABOUT_KEY} must be a string, got {about!r}")
        scenes: dict[str, Mapping[str, TierCell]] = {}
        for scene, cells in body.items():
            if scene == ABOUT_KEY:
                continue
            if scene not in SCENARIOS:
                raise ConfigError(f"{where}: tier {name!r} names unknown scene {scene!r}; scenes: "
                                  f"{', '.join(SCENARIOS)} (and the key {ABOUT_KEY!r})")
            if not isinstance(cells, Mapping) or not cells:
                raise ConfigError(f"{where}: {name}.{scene} must be a non-empty mapping {{cell: {{keywords}}}}, "
                                  f"got {cells!r}")
            parsed: dict[str, TierCell] = {}
            for cell, kwargs in cells.items():
                at = f"{where}: {name}.{scene}.{cell}"
                if not isinstance(cell, str) or not cell:
                    raise ConfigError(f"{where}: {name}.{scene}: a cell's name must be a non-empty string, got {cell!r}")
                kwargs = {} if kwargs is None else kwargs
                if not isinstance(kwargs, Mapping):
                    raise ConfigError(f"{at} must be a mapping of env keywords, got {kwargs!r}")
                check_cell_keys(scene, kwargs, at)
                parsed[cell] = TierCell(name, scene, cell, plain(kwargs))
            scenes[scene] = parsed
        tiers[name] = Tier(name, about, scenes)
    return tiers


def load_tiers() -> dict[str, Tier]:
    """Every tier of ``configs/benchmark.yaml`` (read again when the file changes), structure and keys checked."""
    path = config.config_dir() / TIERS_FILE
    try:
        stamp = (str(path), os.stat(path).st_mtime_ns)
    except OSError as exc:
        raise ConfigError(f"{path}: the benchmark tiers' file is missing ({exc})") from None
    tiers = _CACHE.get(stamp)
    if tiers is None:
        tiers = _parse(config.read_yaml(TIERS_FILE), TIERS_FILE)
        _CACHE.clear()
        _CACHE[stamp] = tiers
    return tiers


def tier_names() -> list[str]:
    """The tiers, in the file's order (``paper``, ``train``, ``shifted``, ``hard``)."""
    return list(load_tiers())


def tier(name: Any) -> Tier:
    """Tier ``name``; :class:`ConfigError` naming the known tiers otherwise."""
    tiers = load_tiers()
    if not isinstance(name, str) or name not in tiers:
        raise ConfigError(f"unknown tier {name!r}; known tiers: {', '.join(tiers)} ({TIERS_FILE})")
    return tiers[name]


def cells(scene: str, tier_name: Any = DEFAULT_TIER, cell: Any = None) -> list[TierCell]:
    """The cells of ``tier_name`` for ``scene`` (in the file's order), or only ``cell`` if given.

    ``tier_name`` None is the default tier. A scene the default tier does not list (a scenario
    registered later) has one empty cell there, as every scene has in a config folder without the file. Unknown tiers and cells, and a tier that lists
    no cells for ``scene``, raise :class:`ConfigError` naming the choices.
    """
    name = DEFAULT_TIER if tier_name is None else tier_name
    if name == DEFAULT_TIER and not (config.config_dir() / TIERS_FILE).is_file():
        t = Tier(DEFAULT_TIER, "", {})  # a config folder from before the tiers: the paper's scenes
    else:
        t = tier(name)
    listed = t.scenes.get(scene)
    if listed is None:
        if t.name != DEFAULT_TIER:
            raise ConfigError(f"tier {t.name!r} has no cells for scene {scene!r} ({TIERS_FILE}); its scenes: "
                              f"{', '.join(t.scenes) or '(none)'}")
        listed = {DEFAULT_CELL: TierCell(t.name, scene, DEFAULT_CELL, {})}
    if cell is None:
        return list(listed.values())
    if not isinstance(cell, str) or cell not in listed:
        raise ConfigError(f"unknown tier_cell {cell!r} of tier {t.name!r} for scene {scene!r}; its cells: "
                          f"{', '.join(listed)} ({TIERS_FILE})")
    return [listed[cell]]


def merge(cell: TierCell, overrides: Mapping[str, Any], where: str) -> dict[str, Any]:
    """The env keywords of an episode of ``cell`` with the user's ``overrides`` on top.

    An override of a key the cell fixes (set, or drawn by its ``randomize``), as a value or as a
    ``randomize`` range, raises :class:`ConfigError` naming the keys, the tier and the cell.
    ``randomize`` ranges of other keys join the cell's. A cell that sets nothing gives back
    ``overrides`` unchanged (as a new dict).
    """
    if not cell.kwargs:
        return dict(overrides)
    user_random = overrides.get("randomize") or {}
    if not isinstance(user_random, Mapping):  # passed on as given: the scene's config names the error
        return {**plain(cell.kwargs), **overrides}
    given = {k for k in overrides if k != "randomize"} | set(user_random)
    clash = sorted(given & cell.keys)
    if clash:
        raise ConfigError(
            f"{where}: tier={cell.tier!r} cell {cell.name!r} sets {', '.join(clash)} (as a value or a randomize "
            f"range); a keyword given with a tier may not change what the tier draws (its results must stay "
            f"comparable): leave {'it' if len(clash) == 1 else 'them'} out, or use tier={DEFAULT_TIER!r} (the "
            f"paper's scene, every key free) with your own values")
    out = plain(cell.kwargs)
    out.update({k: v for k, v in overrides.items() if k != "randomize"})
    randomize = {**(out.get("randomize") or {}), **user_random}
    if randomize or "randomize" in overrides:
        out["randomize"] = randomize
    return out
