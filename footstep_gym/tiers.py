"""Benchmark tiers: named distributions of scene settings, read from ``configs/benchmark.yaml``.

Every scene env takes ``tier=`` at ``gymnasium.make`` (as Procgen's envs take
``distribution_mode``): ``"paper"`` (today's fixed settings, the paper's scenes: what an env made
without a tier is),
``"train"`` (each scene's training distribution), ``"shifted"`` (each training range moved to
the next band beyond it), ``"structure"`` (the train tier's scenes with a named structural change:
a second door, wider cars, reactive pedestrians, a denser ring) and ``"noise"`` (known scenes
through the sensing-noise profile). The tiers are data, not code: each tier names the **rule** its
cells follow (:data:`RULE_KINDS`) and holds, per scene, named **cells**, each made from its entry
by that rule (:func:`derive_cell`) into a mapping of env keywords (any key of the scene's YAML,
``randomize`` ranges included, and the ``sensing_*`` keys of ``configs/env.yaml`` that do not
shape the observation). ``gymnasium.make(id, tier="shifted")`` draws one of the tier's cells per
episode, uniformly, from the env's seeded generator (``reset(seed=s)`` fixes the cell and the
episode; a tier with one cell draws nothing, so ``tier="paper"`` is today's env bit for bit), and
``tier_cell="fast"`` picks one cell for every episode (what a benchmark reports per cell).

The env knows nothing of tiers: ``gymnasium.make`` builds a scene env through :func:`make_env`, which turns
``tier`` and ``tier_cell`` into :class:`~footstep_gym.env.FootstepEnv`'s plain ``cells`` (one mapping of env
keywords per cell, the user's keywords merged in) and ``tier`` (a label) with :func:`env_kwargs`, before the env
is built; an env made without ``tier`` never reads this file.

Keywords given with a tier are applied on top of its cells, except those a cell sets (as a value
or as a ``randomize`` range): giving one of those raises :class:`~footstep_gym.errors.ConfigError`
naming it, since a tier is a documented distribution whose results must stay comparable
(``tier="paper"`` sets nothing, so every key is free there, as without a tier).

The file is read and its structure, rules and key names checked when a tier is first asked for (an
unknown tier or cell raises ``ConfigError`` naming the known ones; a cell its rule cannot make, a
rule naming a tier below it or a shift tier leaving a range unmoved raise ``ConfigError`` saying
so; a cell's unknown key raises the env's own message naming the scene's keys); a cell's values are
checked by the scene's config when an env of that tier is made (every cell of the tier is built then,
so a bad value fails at ``gymnasium.make``, not at some later reset). ``tests/test_tiers.py`` builds every cell
of every tier.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

import yaml

from footstep_gym import config
from footstep_gym.env_config import EnvConfig
from footstep_gym.errors import ConfigError

if TYPE_CHECKING:
    from footstep_gym.env import FootstepEnv

#: The file, relative to ``configs/``.
TIERS_FILE = "benchmark.yaml"
#: The tier of an env made without ``tier=``: the paper's scenes, unchanged.
DEFAULT_TIER = "paper"
#: A tier's key that is no scene: one line saying what the tier is.
ABOUT_KEY = "about"
#: A tier's key that is no scene: the rule its cells follow, ``{kind: ..., ...}`` (:data:`RULE_KINDS`).
RULE_KEY = "rule"
#: The kinds of rule a tier's cells follow (configs/benchmark.yaml's header says each in full):
#:   paper      every cell is empty: the scene's YAML exactly;
#:   train      each cell is a distribution written out (it must draw something: a ``randomize`` range);
#:   shift      ``{base: TIER, band: F}``: a cell ``{shift: {KEY: up|down}}`` is the base tier's cell of the scene
#:              with KEY's range [lo, hi] moved to the next band beyond it, [hi, hi + F (hi - lo)] (up) or
#:              [lo - F (hi - lo), lo] (down); every range of the base cell is shifted by some cell, or listed in
#:              the rule's ``dropped: {SCENE/KEY: reason}`` (the oracle's or a null's validation score);
#:   structure  ``{base: TIER}``: a cell ``{change: TEXT, set: {...}}`` is the base tier's cell of the scene plus the
#:              keywords of a named structural change, none of which the base cell draws (its ranges stay);
#:   noise      ``{profile: x-NAME}``: a cell ``{base: TIER/CELL}`` is that cell of the scene seen through the noise
#:              profile (sensing_* keys only), which the base cell must not set.
RULE_KINDS = ("paper", "train", "shift", "structure", "noise")
#: Top-level keys with this prefix are no tiers: blocks the cells share (``x-noise``, the noise rule's profile).
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
    rule: str = ""  # one line: the rule that made the cell from the file's entry (:func:`derive_cell`)

    @property
    def keys(self) -> frozenset[str]:
        """The keys the cell fixes: those it sets and those its ``randomize`` draws."""
        fixed = {k for k in self.kwargs if k != "randomize"}
        return frozenset(fixed | set(self.kwargs.get("randomize") or {}))


@dataclass(frozen=True)
class Tier:
    """A tier: its name, its ``about`` line, its rule's kind (:data:`RULE_KINDS`) and its cells per scene
    (``{scene: {cell: TierCell}}``)."""

    name: str
    about: str
    scenes: Mapping[str, Mapping[str, TierCell]]
    kind: str = ""


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
        rule = _tier_rule(body.get(RULE_KEY), f"{where}: {name}.{RULE_KEY}", tiers, data)
        scenes: dict[str, Mapping[str, TierCell]] = {}
        for scene, cells in body.items():
            if scene in (ABOUT_KEY, RULE_KEY):
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
                    raise ConfigError(f"{at} must be a mapping, got {kwargs!r}")
                made, text = derive_cell(rule, scene, kwargs, tiers, at)
                check_cell_keys(scene, made, at)
                parsed[cell] = TierCell(name, scene, cell, plain(made), text)
            scenes[scene] = parsed
        if rule["kind"] == "shift":
            _check_every_axis_shifted(rule, scenes, tiers, f"{where}: {name}")
        tiers[name] = Tier(name, about, scenes, rule["kind"])
    return tiers


def _tier_rule(rule: Any, where: str, earlier: Mapping[str, Tier], data: Mapping[str, Any]) -> dict[str, Any]:
    """A tier's ``rule`` checked: its kind, and the base tier (an earlier one) or noise profile it names."""
    if rule is None:
        raise ConfigError(f"{where} is missing: every tier names the rule its cells follow, {{kind: ...}} with kind "
                          f"one of {', '.join(RULE_KINDS)} (configs/benchmark.yaml's header)")
    if not isinstance(rule, Mapping) or rule.get("kind") not in RULE_KINDS:
        raise ConfigError(f"{where} must be a mapping {{kind: ...}} with kind one of {', '.join(RULE_KINDS)}, "
                          f"got {rule!r}")
    kind = rule["kind"]
    allowed = {"paper": {"kind"}, "train": {"kind"}, "shift": {"kind", "base", "band"},
               "structure": {"kind", "base"}, "noise": {"kind", "profile"}}[kind]
    optional = {"dropped"} if kind == "shift" else set()
    if not allowed <= set(rule) <= allowed | optional:
        raise ConfigError(f"{where}: a {kind!r} rule has the keys {', '.join(sorted(allowed))}"
                          f"{' (and optionally ' + ', '.join(sorted(optional)) + ')' if optional else ''}, got "
                          f"{', '.join(sorted(rule))}")
    out = dict(rule)
    dropped = rule.get("dropped", {})
    if not isinstance(dropped, Mapping) or not all(
            isinstance(k, str) and k.count("/") == 1 and isinstance(v, str) and v.strip() for k, v in dropped.items()):
        raise ConfigError(f"{where}.dropped must map 'SCENE/KEY' to the reason (the oracle's or a null baseline's "
                          f"validation score) the shifted cell was dropped, got {dropped!r}")
    out["dropped"] = dict(dropped)
    if "base" in rule and rule["base"] not in earlier:
        raise ConfigError(f"{where}.base: {rule['base']!r} is no tier above this one; tiers above: "
                          f"{', '.join(earlier) or '(none)'}")
    if kind == "shift" and not (isinstance(rule["band"], (int, float)) and not isinstance(rule["band"], bool)
                                and 0 < rule["band"] <= 1):
        raise ConfigError(f"{where}.band must be a number in (0, 1] (the next band's width over the base range's), "
                          f"got {rule['band']!r}")
    if kind == "noise":
        profile = rule["profile"]
        body = data.get(profile) if isinstance(profile, str) and profile.startswith(SHARED_PREFIX) else None
        if not isinstance(body, Mapping) or not body:
            raise ConfigError(f"{where}.profile must name a top-level {SHARED_PREFIX}* block of sensing keys, got "
                              f"{profile!r}")
        bad = [k for k in body if k not in cell_env_keys()]
        if bad:
            raise ConfigError(f"{where}.profile {profile}: {', '.join(bad)} is no sensing key a cell may set; use "
                              f"{', '.join(cell_env_keys())}")
        out["noise"] = plain(body)
    return out


def _base_cell(tiers: Mapping[str, Tier], tier_name: str, scene: str, cell: str | None, where: str) -> TierCell:
    listed = tiers[tier_name].scenes.get(scene) or {}
    if cell is None:
        if len(listed) != 1:
            raise ConfigError(f"{where}: the base tier {tier_name!r} must have exactly one cell for scene {scene!r}, "
                              f"has {len(listed)}")
        return next(iter(listed.values()))
    if cell not in listed:
        raise ConfigError(f"{where}: base {tier_name}/{cell} is no cell of scene {scene!r}; its cells there: "
                          f"{', '.join(listed) or '(none)'}")
    return listed[cell]


def next_band(lo: float, hi: float, band: float, direction: str) -> list[float]:
    """The band just beyond ``[lo, hi]``, ``band`` times its width wide: above it (``up``) or below (``down``)."""
    width = band * (hi - lo)
    out = [hi, hi + width] if direction == "up" else [lo - width, lo]
    return [round(v, 10) for v in out]  # 20 + 0.25 * 15 = 23.75, not 23.750000000000004


def derive_cell(rule: Mapping[str, Any], scene: str, entry: Mapping[str, Any], tiers: Mapping[str, Tier],
                where: str) -> tuple[dict[str, Any], str]:
    """A cell's env keywords made from its file entry by its tier's ``rule`` (:data:`RULE_KINDS`), and one line
    saying how; an entry the rule cannot make raises :class:`ConfigError` naming what is wrong."""
    kind = rule["kind"]
    if kind == "paper":
        if entry:
            raise ConfigError(f"{where}: a cell of a 'paper' tier is the scene's YAML exactly and sets nothing, got "
                              f"{dict(entry)!r}")
        return {}, f"configs/scenarios/{scene}.yaml as it is"
    if kind == "train":
        if not entry.get("randomize"):
            raise ConfigError(f"{where}: a cell of a 'train' tier is a distribution: it needs a randomize range")
        return plain(entry), "the training distribution, written out"
    expected = {"shift": {"shift"}, "structure": {"change", "set"}, "noise": {"base"}}[kind]
    if set(entry) != expected:
        raise ConfigError(f"{where}: a cell of a {kind!r} tier has exactly the keys {', '.join(sorted(expected))}, "
                          f"got {', '.join(sorted(entry)) or '(none)'}")
    if kind == "shift":
        base = _base_cell(tiers, rule["base"], scene, None, where)
        shift = entry["shift"]
        ranges = base.kwargs.get("randomize") or {}
        if not isinstance(shift, Mapping) or not shift:
            raise ConfigError(f"{where}.shift must be a mapping {{key: up|down}}, got {shift!r}")
        out = plain(base.kwargs)
        said = []
        for key, direction in shift.items():
            if key not in ranges:
                raise ConfigError(f"{where}.shift: {key!r} is no range the base cell {rule['base']}/{base.name} "
                                  f"draws; its ranges: {', '.join(ranges) or '(none)'}")
            if direction not in ("up", "down"):
                raise ConfigError(f"{where}.shift.{key} must be 'up' or 'down', got {direction!r}")
            lo, hi = (float(v) for v in ranges[key])
            out["randomize"][key] = next_band(lo, hi, float(rule["band"]), direction)
            said.append(f"{key} {lo:g}..{hi:g} -> {out['randomize'][key][0]:g}..{out['randomize'][key][1]:g}")
        return out, f"{rule['base']}/{base.name} with the next band ({rule['band']:g} x the range's width): " \
                    + "; ".join(said)
    if kind == "structure":
        base = _base_cell(tiers, rule["base"], scene, None, where)
        change, keys = entry["change"], entry["set"]
        if not isinstance(change, str) or not change.strip():
            raise ConfigError(f"{where}.change must name the structural change in words, got {change!r}")
        if not isinstance(keys, Mapping) or not keys:
            raise ConfigError(f"{where}.set must be a non-empty mapping of the change's env keywords, got {keys!r}")
        check_cell_keys(scene, keys, f"{where}.set")
        given = {k for k in keys if k != "randomize"} | set(keys.get("randomize") or {})
        clash = sorted(given & set(base.kwargs.get("randomize") or {}))
        if clash:
            raise ConfigError(f"{where}.set changes {', '.join(clash)}, which the base cell {rule['base']}/"
                              f"{base.name} draws: a structural change keeps the base's ranges (a shift tier moves "
                              f"them)")
        out = plain(base.kwargs)
        out.update({k: plain(v) for k, v in keys.items() if k != "randomize"})
        if keys.get("randomize"):
            out["randomize"] = {**out.get("randomize", {}), **plain(keys["randomize"])}
        return out, f"{rule['base']}/{base.name} + {change}"
    ref = entry["base"]
    if not isinstance(ref, str) or ref.count("/") != 1:
        raise ConfigError(f"{where}.base must be 'TIER/CELL' (a cell of this scene in a tier above), got {ref!r}")
    tier_name, cell = ref.split("/")
    if tier_name not in tiers:
        raise ConfigError(f"{where}.base: {tier_name!r} is no tier above this one; tiers above: {', '.join(tiers)}")
    base = _base_cell(tiers, tier_name, scene, cell, where)
    noise = rule["noise"]
    clash = sorted(set(noise) & base.keys)
    if clash:
        raise ConfigError(f"{where}: the base cell {ref} already sets {', '.join(clash)}")
    return {**plain(base.kwargs), **plain(noise)}, f"{ref} through the noise profile {rule['profile']}"


def _check_every_axis_shifted(rule: Mapping[str, Any], scenes: Mapping[str, Mapping[str, TierCell]],
                              tiers: Mapping[str, Tier], where: str) -> None:
    """A shift tier moves every range of its base: each scene's base ranges are each shifted by some cell, or listed
    in the rule's ``dropped`` with the validation score that dropped the cell."""
    for scene, base_cells in tiers[rule["base"]].scenes.items():
        ranges = set(next(iter(base_cells.values())).kwargs.get("randomize") or {}) if len(base_cells) == 1 else set()
        mine = scenes.get(scene, {})
        base_ranges = next(iter(base_cells.values())).kwargs.get("randomize") or {}
        moved = {k for c in mine.values() for k in (c.kwargs.get("randomize") or {})
                 if k in ranges and c.kwargs["randomize"][k] != base_ranges[k]}
        dropped = {key.split("/")[1] for key in rule["dropped"] if key.split("/")[0] == scene}
        both = sorted(moved & dropped)
        if both:
            raise ConfigError(f"{where}: {scene}'s {', '.join(both)} is shifted by a cell and listed as dropped")
        missing = sorted(ranges - moved - dropped)
        if missing:
            raise ConfigError(f"{where}: the shift rule moves every range of {rule['base']}; no cell of scene "
                              f"{scene!r} shifts {', '.join(missing)}")


def load_tiers() -> dict[str, Tier]:
    """Every tier of ``configs/benchmark.yaml`` (read again when the file changes), structure and keys checked."""
    path = config.config_dir() / TIERS_FILE
    try:
        stamp = (str(path), os.stat(path).st_mtime_ns)
    except OSError as exc:
        raise ConfigError(f"{path}: the benchmark tiers' file is missing ({exc})") from None
    tiers = _CACHE.get(stamp)
    if tiers is None:
        try:
            data = config.read_yaml(TIERS_FILE)
        except yaml.YAMLError as exc:
            mark = getattr(exc, "problem_mark", None)
            where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
            raise ConfigError(f"{path}: the benchmark tiers' file is not valid YAML{where}: "
                              f"{getattr(exc, 'problem', None) or exc}") from None
        tiers = _parse(data, TIERS_FILE)
        _CACHE.clear()
        _CACHE[stamp] = tiers
    return tiers


def tier_names() -> list[str]:
    """The tiers, in the file's order (``paper``, ``train``, ``shifted``, ``structure``, ``noise``)."""
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


def env_kwargs(scene: str, tier_name: str, cell: str | None = None, overrides: Mapping[str, Any] | None = None
               ) -> dict[str, Any]:
    """The keywords of :class:`~footstep_gym.env.FootstepEnv` for an env of ``scene`` in tier ``tier_name`` (every
    cell, or only ``cell``) with the user's ``overrides``: ``{"tier": tier_name, "cells": {name: keywords}}``, each
    cell's keywords its own with the overrides merged in (:func:`merge`, which refuses an override of what the cell
    fixes). Reads ``configs/benchmark.yaml``; :class:`ConfigError` naming the file for a bad tier or cell."""
    where = f"FootstepEnv({scene})"
    return {"tier": tier_name,
            "cells": {c.name: merge(c, dict(overrides or {}), where) for c in cells(scene, tier_name, cell)}}


def make_env(scenario: str = "door", render_mode: str | None = None, tier: str | None = None,
             tier_cell: str | None = None, **overrides: Any) -> FootstepEnv:
    """``gymnasium.make``'s entry point of every scene env: ``FootstepEnv(scenario, render_mode, **overrides)``, or
    with ``tier`` (and ``tier_cell``) the tier's cells resolved first (:func:`env_kwargs`). Without ``tier`` the
    tiers' file is not read."""
    from footstep_gym.env import FootstepEnv

    if tier is None:
        if tier_cell is not None:
            raise ConfigError(f"FootstepEnv({scenario}): tier_cell={tier_cell!r} needs tier= (the tier it is a cell "
                              f"of, e.g. tier={DEFAULT_TIER!r})")
        return FootstepEnv(scenario, render_mode, **overrides)
    return FootstepEnv(scenario, render_mode, **env_kwargs(scenario, tier, tier_cell, overrides))
