"""``configs/planner.yaml`` (:mod:`footstep_gym.planners.params`): every key is read by the planners, the
switches of ``additions`` are booleans, the paper's policies switch all of them off.

The "every key read" test runs each registered policy for a few steps with a config whose
sections record which of their fields the code reads: a key the code never reads (a
constant that lives in code instead, or a leftover) fails it by name.
"""

from __future__ import annotations

import dataclasses
import types
from typing import Any

import gymnasium as gym
import pytest

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym import config as fs_config
from footstep_gym.errors import ConfigError
from footstep_gym.planners import POLICIES, load_planner_config, make_policy
from footstep_gym.planners.params import AdditionsParams, PlannerConfig


class RecordingSection:
    """Stands for one config section: attribute reads are recorded as ``"<section>.<key>"``; methods of the
    section run with this object as ``self``, so what they read is recorded too."""

    def __init__(self, name: str, section: Any, seen: set[str]) -> None:
        object.__setattr__(self, "_name", name)
        object.__setattr__(self, "_section", section)
        object.__setattr__(self, "_seen", seen)
        object.__setattr__(self, "_fields", {f.name for f in dataclasses.fields(section)})

    def __getattr__(self, key: str) -> Any:
        if key in self._fields:
            self._seen.add(f"{self._name}.{key}")
            return getattr(self._section, key)
        attr = getattr(type(self._section), key)
        return types.MethodType(attr, self) if callable(attr) else attr


class RecordingConfig:
    """A :class:`PlannerConfig` whose sections are :class:`RecordingSection` s."""

    def __init__(self, cfg: PlannerConfig, seen: set[str]) -> None:
        for f in dataclasses.fields(cfg):
            setattr(self, f.name, RecordingSection(f.name, getattr(cfg, f.name), seen))


def all_keys() -> set[str]:
    data = fs_config.read_yaml("planner.yaml")
    return {f"{section}.{key}" for section, keys in data.items() for key in keys}


def test_recording_section_records_reads_and_method_reads():
    seen: set[str] = set()
    cfg = RecordingConfig(load_planner_config(), seen)
    assert cfg.rrt.iterations > 0
    cfg.pso.delta_bounds()
    assert seen == {"rrt.iterations", "pso.d_front_stride_m", "pso.d_side_stride_m", "pso.d_turn_deg",
                    "pso.d_t_ss_s", "pso.d_t_ds_s"}


def test_every_key_of_planner_yaml_is_read_by_the_planners():
    """Construct each registered policy with a recording config and plan a few steps in each scene."""
    seen: set[str] = set()
    base = load_planner_config()
    for env_id, kwargs in (("FootstepDoor-v0", {"door_speed": 17.0}), ("FootstepCrowd-v0", {})):
        env = gym.make(env_id, **kwargs)
        for name in POLICIES:
            policy = make_policy(name, env.unwrapped.robot, seed=0, config=RecordingConfig(base, seen))
            obs, _ = env.reset(seed=0)
            policy.reset(seed=0)
            for _ in range(3):
                obs, *_ = env.step(policy.act(obs, env.unwrapped.sensing()))
        env.close()
    unread = sorted(all_keys() - seen)
    assert not unread, f"keys of configs/planner.yaml never read by the planners: {unread}"


def test_yaml_keys_are_the_dataclass_fields():
    cfg = load_planner_config()
    fields = {f"{s.name}.{f.name}" for s in dataclasses.fields(cfg) for f in dataclasses.fields(getattr(cfg, s.name))}
    assert fields == all_keys()


def test_additions_are_booleans_and_all_on_by_default():
    cfg = load_planner_config()
    values = dataclasses.asdict(cfg.additions)
    assert values and all(v is True for v in values.values())
    with pytest.raises(ConfigError, match="additions.waiting_walks must be true or false"):
        load_planner_config({"additions_waiting_walks": 1})
    with pytest.raises(ConfigError, match="unknown key"):
        load_planner_config({"additions": {"no_such_switch": False}})


def test_paper_policies_switch_every_addition_off():
    switches = {f.name for f in dataclasses.fields(AdditionsParams)}
    for name in ("paper-period-aware", "paper-fixed-period"):
        policy = make_policy(name, seed=0)
        assert policy.name == name
        assert not any(getattr(policy.config.additions, s) for s in switches)
    assert make_policy("paper-period-aware").vary_period and not make_policy("paper-fixed-period").vary_period


def test_overrides_apply_on_top_of_a_policys_own_switches():
    policy = make_policy("paper-period-aware", additions_fallback=True, rrt_iterations=50)
    assert policy.config.additions.fallback and not policy.config.additions.waiting_walks
    assert policy.config.rrt.iterations == 50
    policy = make_policy("period-aware", additions={"centred_period": False})
    assert not policy.config.additions.centred_period and policy.config.additions.waiting_walks
