"""The scenes, each a :class:`Scenario` with its config in ``configs/scenarios/``, and their registry.

A scenario is one module (its :class:`Scenario` subclass with ``Config``, ``config_file``,
``env_id`` and ``sweep_axes``), one YAML (its keys, and a ``fuzz:`` section of soak-test
ranges) and one entry in :data:`SCENARIOS`. Everything else is derived from the registry:
``footstep_gym.ENV_IDS``, the ids ``gymnasium.make`` knows, the scenes of
``FootstepMix-v0``, the ``--env`` names and sweep flags of ``baselines/eval_planner.py`` and
the labels of its reports. A scenario defined elsewhere (a plugin, a test) joins with
:func:`register_scenario` and leaves with :func:`unregister_scenario`.
"""

from __future__ import annotations

import dataclasses
import re
from typing import Iterator, Mapping

from gymnasium.envs.registration import register, registry

from footstep_gym.errors import ConfigError
from footstep_gym.scenarios.base import Scenario, ScenarioConfig
from footstep_gym.scenarios.crossing import Crossing, CrossingConfig
from footstep_gym.scenarios.crowd import Crowd, CrowdConfig
from footstep_gym.scenarios.door import Door, DoorConfig

#: Scene name -> its class: the registry everything else reads.
SCENARIOS: dict[str, type[Scenario]] = {"door": Door, "crossing": Crossing, "crowd": Crowd}

#: Names ``--env`` / ``train_rl.py --env`` give the mix; no scene may take them.
MIX_NAMES = ("all", "mix")


class _EnvIds(Mapping[str, str]):
    """Scene name -> env id, read from :data:`SCENARIOS` at every access (a scenario registered later shows)."""

    def __getitem__(self, scene: str) -> str:
        return SCENARIOS[scene].env_id

    def __iter__(self) -> Iterator[str]:
        return iter(SCENARIOS)

    def __len__(self) -> int:
        return len(SCENARIOS)

    def __repr__(self) -> str:
        return repr(dict(self))


#: ``{"door": "FootstepDoor-v0", ...}``, one entry per registered scenario (a live view of :data:`SCENARIOS`).
ENV_IDS: Mapping[str, str] = _EnvIds()


def check_scenario(name: str, cls: type[Scenario]) -> None:
    """Raise :class:`ConfigError` if ``cls`` cannot be registered as ``name`` (without changing anything)."""
    if not isinstance(name, str) or not re.fullmatch(r"[a-z][a-z0-9_]*", name) or name in MIX_NAMES:
        raise ConfigError(f"scenario name must be lower-case letters, digits and _ (not {MIX_NAMES}), got {name!r}")
    if not (isinstance(cls, type) and issubclass(cls, Scenario)):
        raise ConfigError(f"scenario {name!r}: expected a Scenario subclass, got {cls!r}")
    for attr in ("config_file", "Config", "env_id"):
        if not hasattr(cls, attr):
            raise ConfigError(f"scenario {name!r}: {cls.__name__} sets no {attr}")
    env_id = cls.env_id
    if not isinstance(env_id, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_.-]*-v\d+", env_id):
        raise ConfigError(f"scenario {name!r}: env_id must look like 'FootstepName-v0', got {env_id!r}")
    for other, other_cls in SCENARIOS.items():
        if other != name and other_cls.env_id == env_id:
            raise ConfigError(f"scenario {name!r}: env id {env_id!r} is scenario {other!r}'s")
    numeric = cls.Config.numeric_keys()
    for key, unit in cls.sweep_axes.items():
        if key not in numeric:
            raise ConfigError(f"scenario {name!r}: sweep axis {key!r} is not a numeric key of "
                              f"{cls.Config.__name__}; use one of {sorted(numeric)}")
        if not isinstance(unit, str):
            raise ConfigError(f"scenario {name!r}: sweep axis {key!r} needs its unit as a string, got {unit!r}")


def _register_env(name: str) -> None:
    env_id = SCENARIOS[name].env_id
    if env_id not in registry:
        register(id=env_id, entry_point="footstep_gym.tiers:make_env", kwargs={"scenario": name},
                 vector_entry_point=SCENARIOS[name].vector_entry_point)


def register_scenario(name: str, cls: type[Scenario]) -> None:
    """Add scenario ``cls`` as ``name``: into :data:`SCENARIOS`, and its ``env_id`` into gymnasium's registry.

    ``footstep_gym.ENV_IDS``, the mix's default scenes and ``eval_planner.py`` (``--env name``,
    a flag per sweep axis) pick it up. Registering a name again with another class raises
    :class:`ConfigError` (:func:`unregister_scenario` first).
    """
    check_scenario(name, cls)
    if SCENARIOS.get(name, cls) is not cls:
        raise ConfigError(f"scenario {name!r} is registered already ({SCENARIOS[name].__name__})")
    SCENARIOS[name] = cls
    _register_env(name)


def unregister_scenario(name: str) -> None:
    """Remove scenario ``name`` and its env id (the inverse of :func:`register_scenario`)."""
    cls = SCENARIOS.pop(name)
    spec = registry.get(cls.env_id)
    if spec is not None and spec.kwargs.get("scenario") == name:
        del registry[cls.env_id]


def resolve_env_id(name: str, *, mix: bool = False) -> str:
    """The env id of a scene name (``door``) or an env id in any case (``FootstepDoor-v0``,
    ``footstep_gym:FootstepDoor-v0``); with ``mix=True`` also ``all``/``mix``/``FootstepMix-v0``.
    Raises :class:`ConfigError` (a ``ValueError``) listing the choices."""
    from footstep_gym import MIX_ENV_ID

    wanted = str(name).strip().lower().removeprefix("footstep_gym:")
    for scene, cls in SCENARIOS.items():
        if wanted in (scene, cls.env_id.lower()):
            return cls.env_id
    if mix and wanted in (*MIX_NAMES, MIX_ENV_ID.lower()):
        return MIX_ENV_ID
    choices = [*SCENARIOS, *ENV_IDS.values(), *((*MIX_NAMES, MIX_ENV_ID) if mix else ())]
    raise ConfigError(f"unknown env {name!r}; choose from {', '.join(choices)}")


def scene_of(env_id: str) -> str:
    """The scene name of a scene's env id (``FootstepDoor-v0`` -> ``door``)."""
    for scene, cls in SCENARIOS.items():
        if cls.env_id == env_id:
            return scene
    raise ConfigError(f"{env_id!r} is no scene's env id; known: {', '.join(ENV_IDS.values())}")


def units(scene: str | None = None) -> dict[str, str]:
    """``{key: unit}`` of the numeric keys that declare one (field metadata, then ``sweep_axes``):
    of ``scene``, or of every registered scenario (the first one's unit where two share a key)."""
    out: dict[str, str] = {}
    for cls in ([SCENARIOS[scene]] if scene is not None else reversed(list(SCENARIOS.values()))):
        out.update({f.name: f.metadata["unit"] for f in dataclasses.fields(cls.Config) if f.metadata.get("unit")})
        out.update(cls.sweep_axes)
    return out


for _name in list(SCENARIOS):
    check_scenario(_name, SCENARIOS[_name])
    _register_env(_name)

__all__ = ["SCENARIOS", "ENV_IDS", "Scenario", "ScenarioConfig", "Door", "DoorConfig", "Crossing", "CrossingConfig",
           "Crowd", "CrowdConfig", "check_scenario", "register_scenario", "unregister_scenario", "resolve_env_id",
           "scene_of", "units"]
