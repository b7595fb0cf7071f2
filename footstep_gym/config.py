"""Configuration: YAML files under ``configs/`` loaded into validated dataclasses.

Every number the simulation uses is a config field with its default in the code, stated and
documented in a YAML file that overrides it; keyword arguments of ``gymnasium.make`` override
single keys. Unknown keys, wrong types and values outside
their allowed range raise :class:`ConfigError` naming the key and the value.

A config is a frozen dataclass; each field's type (resolved from its annotation) picks its
converter in :data:`CONVERTERS`, and its constraint (:func:`positive`, :func:`interval`, ...) the
range the value must lie in. A field's default is in the code (``positive(0.23)``), so a config can
be made without a file (``EnvConfig()``); the YAML documents every key and overrides the defaults, and
a key the file leaves out keeps its default. Typed converters rather than pydantic, because the configs stay plain
dataclasses that plugins declare with one-line fields, and every error stays the one line that names
the file, the key and the value (with a "did you mean" for an unknown key) without translating
pydantic's multi-line reports.
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import math
import os
import typing
from pathlib import Path
from typing import Any, Callable, Mapping, TypeVar

import yaml

from footstep_gym.errors import ConfigError

_CONFIG_ENV_VAR = "FOOTSTEP_GYM_CONFIG_DIR"

T = TypeVar("T")


def config_dir() -> Path:
    """The folder holding the YAML files.

    ``$FOOTSTEP_GYM_CONFIG_DIR`` if set; else ``footstep_gym/configs/`` of an installed
    package (``pip install .`` maps the repo's ``configs/`` there); else the repo's
    top-level ``configs/`` (a source checkout or an editable install).
    """
    env = os.environ.get(_CONFIG_ENV_VAR)
    here = Path(__file__).resolve().parent
    candidates = [Path(env)] if env else [here / "configs", here.parent / "configs"]
    for path in candidates:
        if path.is_dir():
            return path
    tried = ", ".join(repr(str(p)) for p in candidates)
    raise ConfigError(f"config folder not found (tried {tried}); set ${_CONFIG_ENV_VAR} to the folder "
                      "holding robot.yaml, env.yaml and scenarios/")


def read_yaml(relative: str) -> dict[str, Any]:
    """Read ``configs/<relative>`` into a dict (``relative`` may be an absolute path: that file)."""
    path = config_dir() / relative
    with open(path, encoding="utf-8") as fh:
        data = yaml.safe_load(fh) or {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at top level, got {type(data).__name__}")
    return data


# ---------------------------------------------------------------- field constraints
def _field(check: str | None, default: Any, kw: dict[str, Any]) -> Any:
    """A dataclass field with constraint ``check`` and ``default`` (a list or dict is copied for each instance;
    ``dataclasses.MISSING``: none, the key is required)."""
    metadata = {"check": check, **kw}
    if isinstance(default, (list, dict)):
        return dataclasses.field(default_factory=lambda: copy.deepcopy(default), metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def positive(default: Any = dataclasses.MISSING, allow_inf: bool = False, **kw: Any) -> Any:
    """A number field that must be > 0 (and finite, unless ``allow_inf``: then ``.inf`` means no limit)."""
    return _field("positive_or_inf" if allow_inf else "positive", default, kw)


def nonnegative(default: Any = dataclasses.MISSING, **kw: Any) -> Any:
    """A float field that must be >= 0."""
    return _field("nonnegative", default, kw)


def fraction(default: Any = dataclasses.MISSING, **kw: Any) -> Any:
    """A float field in (0, 1]."""
    return _field("fraction", default, kw)


def interval(default: Any = dataclasses.MISSING, **kw: Any) -> Any:
    """A pair ``[lo, hi]`` with lo <= hi."""
    return _field("interval", default, kw)


def pair(default: Any = dataclasses.MISSING, **kw: Any) -> Any:
    """A point ``[x, y]`` of two finite numbers."""
    return _field("pair", default, kw)


def plain(default: Any = dataclasses.MISSING, **kw: Any) -> Any:
    """A field with no constraint beyond its type."""
    return _field(None, default, kw)


def defaults(cls: type) -> dict[str, Any]:
    """``{field: default}`` of config dataclass ``cls``, for the fields that have one."""
    out = {}
    for f in dataclasses.fields(cls):  # type: ignore[arg-type]
        if f.default is not dataclasses.MISSING:
            out[f.name] = f.default
        elif f.default_factory is not dataclasses.MISSING:
            out[f.name] = f.default_factory()
    return out


def unknown_keys_message(where: str, unknown: list[str], known: list[str]) -> str:
    """One line naming the ``unknown`` keys of ``where`` (with the closest known one, if any) and the known keys."""
    parts = []
    for key in unknown:
        close = difflib.get_close_matches(key, known, n=1)
        parts.append(f"{key!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
    return f"{where}: unknown key(s) {', '.join(parts)}; known keys: {', '.join(sorted(known))}"


def _to_int(label: str, value: Any, check: str | None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or int(value) != value:
        raise ConfigError(f"{label} must be an integer, got {value!r}")
    value = int(value)
    if check == "positive" and value <= 0:
        raise ConfigError(f"{label} must be > 0, got {value!r}")
    if check == "nonnegative" and value < 0:
        raise ConfigError(f"{label} must be >= 0, got {value!r}")
    return value


def _to_float(label: str, value: Any, check: str | None) -> float:
    if check == "positive_or_inf":
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise ConfigError(f"{label} must be a number > 0 (.inf: no limit), got {value!r}")
        return float(value)
    value = number(label, value)
    if check == "positive" and not value > 0:
        raise ConfigError(f"{label} must be > 0, got {value!r}")
    if check == "nonnegative" and not value >= 0:
        raise ConfigError(f"{label} must be >= 0, got {value!r}")
    if check == "fraction" and not 0 < value <= 1:
        raise ConfigError(f"{label} must be in (0, 1], got {value!r}")
    return value


def _to_bool(label: str, value: Any, check: str | None) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{label} must be true or false, got {value!r}")
    return value


def _to_str(label: str, value: Any, check: str | None) -> str:
    if not isinstance(value, str):
        raise ConfigError(f"{label} must be a string, got {value!r}")
    return value


def _to_mapping(label: str, value: Any, check: str | None) -> dict:
    if not isinstance(value, Mapping):
        raise ConfigError(f"{label} must be a mapping, got {value!r}")
    return dict(value)


def _to_pair(label: str, value: Any, check: str | None) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ConfigError(f"{label} must be a pair [{'lo, hi' if check == 'interval' else 'x, y'}], got {value!r}")
    lo, hi = (number(label, v) for v in value)
    if check == "interval" and lo > hi:
        raise ConfigError(f"{label} must have lo <= hi, got {value!r}")
    return (lo, hi)


def _to_numbers(label: str, value: Any, check: str | None) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)):
        raise ConfigError(f"{label} must be a list of numbers, got {value!r}")
    return tuple(number(label, v) for v in value)


def _to_list(label: str, value: Any, check: str | None) -> Any:
    return value  # its class's validate() checks its items


#: The converter of each field type a config may declare: ``(label, value, check) -> value``, raising
#: :class:`ConfigError` naming ``label``; ``check`` is the field's constraint (:func:`positive`, ...).
CONVERTERS: dict[Any, Callable[[str, Any, "str | None"], Any]] = {
    int: _to_int, float: _to_float, bool: _to_bool, str: _to_str, dict: _to_mapping, list: _to_list,
    tuple[float, float]: _to_pair, tuple[float, ...]: _to_numbers,
}
_FIELD_TYPES: dict[type, dict[str, Any]] = {}


def field_types(cls: type) -> dict[str, Any]:
    """``{field: type}`` of config dataclass ``cls``, the annotations resolved to types (``tuple[float, float]``)."""
    types = _FIELD_TYPES.get(cls)
    if types is None:
        hints = typing.get_type_hints(cls)
        types = _FIELD_TYPES[cls] = {f.name: hints[f.name] for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
        unsupported = {name: t for name, t in types.items() if t not in CONVERTERS}
        if unsupported:
            raise TypeError(f"{cls.__name__}: no config converter for field type(s) {unsupported}; "
                            f"config fields are one of {list(CONVERTERS)}")
    return types


def numeric_fields(cls: type) -> list[str]:
    """The fields of config dataclass ``cls`` declared ``float``."""
    return [name for name, t in field_types(cls).items() if t is float]


def number(label: str, value: Any) -> float:
    """``value`` as a finite float, else :class:`ConfigError` naming ``label`` (booleans are not numbers)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{label} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(f"{label} must be finite, got {value!r}")
    return value


def build(cls: type[T], data: Mapping[str, Any], where: str) -> T:
    """Make dataclass ``cls`` from ``data`` over the fields' defaults: nothing unknown, every field without a
    default present, all valid (the defaults included)."""
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = [k for k in data if k not in fields]
    if unknown:
        raise ConfigError(unknown_keys_message(where, unknown, list(fields)))
    data = {**defaults(cls), **data}
    missing = [k for k in fields if k not in data]
    if missing:
        raise ConfigError(f"{where}: missing key(s) {', '.join(missing)}")
    types = field_types(cls)
    values = {name: CONVERTERS[types[name]](f"{where}.{name}", data[name], f.metadata.get("check"))
              for name, f in fields.items()}
    obj = cls(**values)
    validate = getattr(obj, "validate", None)
    if validate is not None:
        validate()
    return obj


def split_overrides(
    overrides: Mapping[str, Any], *groups: tuple[str, type]
) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
    """Sort flat keyword overrides into the dataclass ``groups`` they belong to.

    Returns ``({group: {key: value}}, leftover)``. A key may be given as ``group={...}``
    too (e.g. ``robot={"com_height": 0.25}``), and a group whose class has profiles as the
    profile's name (``robot="darwin-op"``, the same as ``robot={"profile": "darwin-op"}``; see :func:`load`).
    """
    out: dict[str, dict[str, Any]] = {name: {} for name, _ in groups}
    leftover: dict[str, Any] = {}
    field_owner: dict[str, str] = {}
    for name, cls in groups:
        for f in dataclasses.fields(cls):  # type: ignore[arg-type]
            field_owner.setdefault(f.name, name)
    for key, value in overrides.items():
        if key in out:
            if isinstance(value, str):  # a profile's name
                value = {PROFILE_KEY: value}
            if not isinstance(value, Mapping):
                raise ConfigError(f"{key} must be a mapping of overrides or a profile name, got {value!r}")
            out[key].update(value)
        elif key in field_owner:
            out[field_owner[key]][key] = value
        else:
            leftover[key] = value
    return out, leftover


# ---------------------------------------------------------------- profiles
#: The override key that names a profile: ``{"profile": "darwin-op", "com_height": 0.25}``.
PROFILE_KEY = "profile"


def profile_names(folder: str) -> list[str]:
    """The profiles in ``configs/<folder>/`` (file names without ``.yaml``), sorted."""
    path = config_dir() / folder
    return sorted(p.stem for p in path.glob("*.yaml")) if path.is_dir() else []


def read_profile(cls: type, name: Any) -> dict[str, Any]:
    """The keys profile ``name`` sets for ``cls`` (``configs/<cls.PROFILE_FOLDER>/<name>.yaml``).

    A profile holds only keys that differ from the class's base file; unknown profile names,
    and keys that are not fields of ``cls``, raise :class:`ConfigError` naming the known ones.
    """
    folder = getattr(cls, "PROFILE_FOLDER", None)
    if folder is None:
        raise ConfigError(f"{cls.__name__} has no profiles; got {PROFILE_KEY}={name!r}")
    known = profile_names(folder)
    if not isinstance(name, str) or name not in known:
        raise ConfigError(f"unknown {cls.__name__.lower()} profile {name!r}; known profiles: {', '.join(known) or '(none)'} "
                          f"(configs/{folder}/<name>.yaml)")
    relative = f"{folder}/{name}.yaml"
    data = read_yaml(relative)
    fields = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = [k for k in data if k not in fields]
    if unknown:
        raise ConfigError(unknown_keys_message(relative, unknown, list(fields)))
    return data


def load(cls: type[T], relative: str, overrides: Mapping[str, Any] | str | None = None) -> T:
    """Load ``configs/<relative>`` into ``cls`` with ``overrides`` applied on top.

    For a class with profiles (``cls.PROFILE_FOLDER``, e.g. :class:`~footstep_gym.robot.Robot`):
    ``overrides`` may be a profile's name, or hold one under ``"profile"``; the profile's keys
    apply on top of the base file and the other overrides on top of the profile.

    The file's top-level sections named in ``cls.SIDE_SECTIONS`` (e.g. a scenario's ``fuzz:``)
    are no fields: set aside here (read with :func:`read_yaml`), never an override.
    """
    data = read_yaml(relative)
    for section in getattr(cls, "SIDE_SECTIONS", ()):
        data.pop(section, None)
    if isinstance(overrides, str):
        overrides = {PROFILE_KEY: overrides}
    if overrides and PROFILE_KEY in overrides:
        overrides = dict(overrides)
        data.update(read_profile(cls, overrides.pop(PROFILE_KEY)))
    if overrides:
        fields = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
        unknown = [k for k in overrides if k not in fields]
        if unknown:
            raise ConfigError(unknown_keys_message(relative, unknown, list(fields)))
        data.update(overrides)
    return build(cls, data, relative)


def replace(obj: T, **changes: Any) -> T:
    """A validated copy of config ``obj`` with ``changes``."""
    # Field by field, nested configs as mappings: no deep copy of the lists and dicts that stay as they are.
    values = {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}  # type: ignore[arg-type]
    data = {k: dataclasses.asdict(v) if dataclasses.is_dataclass(v) else v for k, v in values.items()}
    data.update(changes)
    return build(type(obj), data, type(obj).__name__)
