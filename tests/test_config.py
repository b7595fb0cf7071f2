"""Configuration (footstep_gym/config.py) as a user meets it: YAML files and gymnasium.make overrides.

The reference is the YAML read directly with PyYAML; every bad input must raise a
``ValueError`` (``ConfigError``) whose message names the offending key.
"""

from __future__ import annotations

import dataclasses
import math
import shutil

import gymnasium as gym
import numpy as np
import pytest
import yaml

import footstep_gym
from footstep_gym import config
from footstep_gym.config import config_dir
from footstep_gym.errors import ConfigError
from footstep_gym.robot import Robot, load_robot
from footstep_gym.scenarios import SCENARIOS, DoorConfig

NOMINAL = np.array([0.0, 0.08, 0.0, 0.6, 0.2])
SCENARIO_FILES = {"FootstepDoor-v0": "door", "FootstepCrossing-v0": "crossing", "FootstepCrowd-v0": "crowd"}


def read_yaml(name: str) -> dict:
    with open(config_dir() / name, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def as_plain(value):
    """Tuples -> lists, so a dataclass field compares with the YAML value."""
    if isinstance(value, tuple):
        return [as_plain(v) for v in value]
    return value


def rod(env):
    (view,) = [o for o in env.unwrapped.sensing().obstacles if not o.static]
    return view


# ------------------------------------------------------------------ the files reach the env
@pytest.mark.parametrize("env_id, name", SCENARIO_FILES.items())
def test_yaml_values_reach_the_env(env_id, name):
    env = gym.make(env_id).unwrapped
    for obj, data in ((env.robot, read_yaml("robot.yaml")), (env.config, read_yaml("env.yaml")),
                      (env.scenario_config, read_yaml(f"scenarios/{name}.yaml"))):
        fields = {f.name for f in dataclasses.fields(obj)}
        data = {k: v for k, v in data.items() if k not in getattr(obj, "SIDE_SECTIONS", ())}  # fuzz: no field
        assert fields == set(data), (type(obj).__name__, fields ^ set(data))  # no key unused, none missing
        for key, value in data.items():
            assert as_plain(getattr(obj, key)) == value, key


def test_robot_box_matches_yaml():
    data = read_yaml("robot.yaml")
    env = gym.make("FootstepDoor-v0")
    turn = max(data["turn_inner"], data["turn_outer"])
    low = [data["stride_front"][0], data["stride_side"][0], -turn, data["t_ss"][0], data["t_ds"][0]]
    high = [data["stride_front"][1], data["stride_side"][1], turn, data["t_ss"][1], data["t_ds"][1]]
    assert env.action_space.low == pytest.approx(low)
    assert env.action_space.high == pytest.approx(high)
    assert env.action_space.dtype == np.float32
    k = read_yaml("env.yaml")["n_obstacles_observed"]
    assert env.observation_space.shape == (12 + 5 * k,)


def test_configs_are_immutable():
    env = gym.make("FootstepDoor-v0").unwrapped
    with pytest.raises(dataclasses.FrozenInstanceError):
        env.robot.body_radius = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        env.scenario_config.door_speed = 1.0


# ------------------------------------------------------------------ overrides through gymnasium.make
def test_scenario_override_changes_the_door():
    env = gym.make("FootstepDoor-v0", door_speed=8.0)
    env.reset(seed=0)
    assert rod(env).angular_velocity == pytest.approx(-math.radians(8.0))
    # Overrides do not leak into the next env.
    default = gym.make("FootstepDoor-v0")
    default.reset(seed=0)
    assert rod(default).angular_velocity == pytest.approx(-math.radians(read_yaml("scenarios/door.yaml")["door_speed"]))


def test_env_override_changes_the_reward():
    env = gym.make("FootstepDoor-v0", reward_time=-0.5, reward_step=0.0)
    env.reset(seed=0)
    _, reward, _, _, info = env.step(NOMINAL)
    assert info["rewards"]["time"] == pytest.approx(-0.5 * 0.8)
    assert info["rewards"]["step"] == 0.0


def test_robot_override_changes_the_body():
    env = gym.make("FootstepDoor-v0", robot={"body_radius": 0.12, "turn_outer": 0.35})
    env.reset(seed=0)
    assert env.unwrapped.world.robot_radius == pytest.approx(0.12)
    assert env.unwrapped.world.robot_shape.radius == pytest.approx(0.12)
    assert env.action_space.high[2] == pytest.approx(0.35)


def test_override_dir_by_environment_variable(tmp_path, monkeypatch):
    shutil.copytree(config_dir(), tmp_path / "configs")
    path = tmp_path / "configs" / "scenarios" / "door.yaml"
    data = yaml.safe_load(path.read_text())
    data["door_speed"] = 5.0
    path.write_text(yaml.safe_dump(data))
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(tmp_path / "configs"))
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    assert rod(env).angular_velocity == pytest.approx(-math.radians(5.0))


def test_missing_config_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(tmp_path / "nowhere"))
    with pytest.raises(ConfigError, match="nowhere"):
        gym.make("FootstepDoor-v0")


@pytest.mark.parametrize("edit, key", [
    (lambda d: d.update(door_sped=3.0), "door_sped"),      # unknown key in the file
    (lambda d: d.update(door_radius="wide"), "door_radius"),  # not a number (a key left out takes its default)
])
def test_bad_yaml_file_is_rejected_by_name(tmp_path, monkeypatch, edit, key):
    shutil.copytree(config_dir(), tmp_path / "configs")
    path = tmp_path / "configs" / "scenarios" / "door.yaml"
    data = yaml.safe_load(path.read_text())
    edit(data)
    path.write_text(yaml.safe_dump(data))
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(tmp_path / "configs"))
    with pytest.raises(ValueError, match=key):
        gym.make("FootstepDoor-v0")


def test_yaml_that_is_not_a_mapping(tmp_path, monkeypatch):
    shutil.copytree(config_dir(), tmp_path / "configs")
    (tmp_path / "configs" / "env.yaml").write_text("- 1\n- 2\n")
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(tmp_path / "configs"))
    with pytest.raises(ConfigError, match="mapping"):
        gym.make("FootstepDoor-v0")


# ------------------------------------------------------------------ bad values, named
def test_unknown_key_is_named_with_a_suggestion():
    with pytest.raises(ValueError) as exc:
        gym.make("FootstepDoor-v0", door_sped=3)
    assert isinstance(exc.value, footstep_gym.ConfigError)
    assert "'door_sped'" in str(exc.value) and "door_speed" in str(exc.value)


def test_key_of_another_scenario_is_unknown():
    with pytest.raises(ValueError, match="door_speed"):
        gym.make("FootstepCrowd-v0", door_speed=8.0)
    with pytest.raises(ValueError, match="crowd_size"):
        gym.make("FootstepDoor-v0", crowd_size=4)


@pytest.mark.parametrize("env_id, kwargs, key", [
    ("FootstepDoor-v0", dict(door_radius=-0.5), "door_radius"),
    ("FootstepDoor-v0", dict(robot={"body_radius": -0.1}), "body_radius"),
    ("FootstepDoor-v0", dict(robot={"body_radus": 0.1}), "body_radus"),
    ("FootstepDoor-v0", dict(robot={"nominal_t_ss": 0.7}), "nominal_t_ss"),  # outside t_ss
    ("FootstepDoor-v0", dict(robot=0.1), "robot"),
    ("FootstepDoor-v0", dict(door_speed=-8.0), "door_speed"),
    ("FootstepDoor-v0", dict(door_speed="fast"), "door_speed"),
    ("FootstepDoor-v0", dict(door_speed=float("nan")), "door_speed"),
    ("FootstepDoor-v0", dict(goal=[1.0]), "goal"),
    ("FootstepDoor-v0", dict(corridor_y=[0.0, -1.0]), "corridor_y"),
    ("FootstepDoor-v0", dict(corridor_y=[-0.3, 0.0]), "corridor_y"),  # above the rod's tip
    ("FootstepDoor-v0", dict(max_steps=2.5), "max_steps"),
    ("FootstepDoor-v0", dict(max_steps=True), "max_steps"),
    ("FootstepDoor-v0", dict(time_limit=0.0), "time_limit"),
    ("FootstepDoor-v0", dict(n_obstacles_observed=0), "n_obstacles_observed"),
    ("FootstepDoor-v0", dict(render_size=[0, 10]), "render_size"),
    ("FootstepDoor-v0", dict(render_size=[-640, 480]), "render_size"),
    ("FootstepDoor-v0", dict(render_size=[640.5, 480]), "render_size"),
    ("FootstepCrowd-v0", dict(crowd_size=0), "crowd_size"),
    ("FootstepCrowd-v0", dict(ring_radius=0.1), "ring_radius"),
    ("FootstepCrowd-v0", dict(breathing_period=[0.0, 1.0]), "breathing_period"),
    ("FootstepCrossing-v0", dict(obstacle_speed=0.0), "obstacle_speed"),
    ("FootstepCrossing-v0", dict(timing_jitter=-1.0), "timing_jitter"),
])
def test_bad_value_is_rejected_by_name(env_id, kwargs, key):
    with pytest.raises(ValueError) as exc:
        gym.make(env_id, **kwargs)
    assert isinstance(exc.value, ConfigError)
    assert key in str(exc.value)


@pytest.mark.parametrize("randomize, words", [
    ({"door_sped": [8, 17]}, ["door_sped"]),
    ({"door_speed": [17, 8]}, ["door_speed", "lo"]),
    ({"door_speed": [8]}, ["door_speed"]),
    ({"door_speed": ["slow", 17]}, ["door_speed"]),
    ({"start": [0.0, 1.0]}, ["start"]),      # a pair, not a number
    ({"max_steps": [10, 20]}, ["max_steps"]),  # an integer key
    ([8, 17], ["randomize"]),
])
def test_bad_randomize_spec_is_rejected_by_name(randomize, words):
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepDoor-v0", randomize=randomize)
    for word in words:
        assert word in str(exc.value)


@pytest.mark.filterwarnings("ignore:.*render_mode")  # gymnasium.make's own warning comes first
@pytest.mark.parametrize("mode", ["rgb", "ansi"])
def test_bad_render_mode(mode):
    with pytest.raises(ValueError, match="render_mode"):
        gym.make("FootstepDoor-v0", render_mode=mode)


def test_bad_render_mode_type():
    from footstep_gym.env import FootstepEnv

    with pytest.raises(ValueError, match="render_mode"):
        FootstepEnv(scenario="door", render_mode=3)


def test_unknown_scenario():
    from footstep_gym.env import FootstepEnv

    with pytest.raises(ValueError, match="revolving"):
        FootstepEnv(scenario="revolving")


def test_randomize_with_equal_bounds_is_a_constant():
    env = gym.make("FootstepDoor-v0", randomize={"door_speed": [11.0, 11.0]})
    for seed in (0, 1):
        env.reset(seed=seed)
        assert rod(env).angular_velocity == pytest.approx(-math.radians(11.0))


def test_randomized_values_are_validated():
    """A draw that would break a constraint is caught (door_radius must stay > 0)."""
    with pytest.raises(ConfigError, match="door_radius"):
        env = gym.make("FootstepDoor-v0", randomize={"door_radius": [-0.5, -0.1]})
        env.reset(seed=0)


# ------------------------------------------------------------------ the module's own API
def test_load_and_replace():
    robot = load_robot({"com_height": 0.25})
    assert robot.com_height == 0.25
    assert robot.omega == pytest.approx(math.sqrt(read_yaml("robot.yaml")["gravity"] / 0.25))
    with pytest.raises(ConfigError, match="com_height"):
        config.replace(robot, com_height=-1.0)
    door = config.load(DoorConfig, "scenarios/door.yaml")
    faster = config.replace(door, door_speed=20.0)
    assert faster.door_speed == 20.0 and door.door_speed == read_yaml("scenarios/door.yaml")["door_speed"]
    assert isinstance(faster, DoorConfig)


def test_build_reports_every_missing_and_unknown_key():
    @dataclasses.dataclass(frozen=True)
    class NoDefaults:  # a plugin's config may leave its defaults out: then every key is required
        gravity: float = config.positive()
        com_height: float = config.positive()
        feet: int = config.positive(2)

    with pytest.raises(ConfigError) as exc:
        config.build(NoDefaults, {"feet": 3}, "robot")
    assert "gravity" in str(exc.value) and "com_height" in str(exc.value) and "feet" not in str(exc.value)
    data = read_yaml("robot.yaml")
    data.update(gravty=9.8, colour="red")
    with pytest.raises(ConfigError) as exc:
        config.build(Robot, data, "robot")
    assert "gravty" in str(exc.value) and "colour" in str(exc.value) and "gravity" in str(exc.value)


def test_integers_given_as_whole_floats_are_accepted():
    env = gym.make("FootstepDoor-v0", max_steps=3.0)
    assert env.unwrapped.scenario_config.max_steps == 3
    assert type(env.unwrapped.scenario_config.max_steps) is int


# ------------------------------------------------------------------ upper bounds of speeds and scales
BOUNDED = [  # (env id, key, bound key, a value above the YAML's bound, extra settings that keep the rest valid)
    ("FootstepDoor-v0", "door_speed", "max_door_speed", 1e9, {}),
    ("FootstepDoor-v0", "door_radius", "max_door_radius", 3.0, dict(corridor_y=[-3.1, 0.0], drum_segments=60)),
    ("FootstepCrossing-v0", "obstacle_speed", "max_obstacle_speed", 6.0, {}),
    ("FootstepCrossing-v0", "arrival_speed", "max_arrival_speed", 2.5, {}),
    ("FootstepCrowd-v0", "crowd_speed", "max_crowd_speed", 3.0, {}),
]


@pytest.mark.parametrize("env_id, key, bound, value, extra", BOUNDED, ids=[b[1] for b in BOUNDED])
def test_speed_above_its_bound_is_rejected_by_name(env_id, key, bound, value, extra):
    data = read_yaml(f"scenarios/{SCENARIO_FILES[env_id]}.yaml")
    limit = data[bound]
    assert value > limit
    with pytest.raises(ConfigError) as exc:
        gym.make(env_id, **{key: value, **extra})
    message = str(exc.value)
    assert f"{key}={value:g}" in message and f"{bound}={limit:g}" in message
    # A randomize range reaching above the bound is rejected at construction, not at a later reset.
    with pytest.raises(ConfigError) as exc:
        gym.make(env_id, randomize={key: [0.5 * limit, value]}, **extra)
    assert f"randomize.{key} reaches {value:g}" in str(exc.value) and bound in str(exc.value)
    # The bound itself is accepted, and raising the bound lets the value through.
    gym.make(env_id, **{key: limit, **extra}).reset(seed=0)
    env = gym.make(env_id, **{key: value, bound: 2 * value, **extra}).unwrapped
    assert getattr(env.scenario_config, key) == value


def test_door_speed_bound_is_checked_in_the_mix_env_too():
    with pytest.raises(ConfigError, match="door_speed=1e\\+09.*max_door_speed=360"):
        gym.make("FootstepMix-v0", door={"door_speed": 1e9})


@pytest.mark.parametrize("kwargs", [
    dict(breathing_amplitude=0.2, breathing_period=[1.0, 2.0], ring_radius=0.5),       # 2 pi 0.2 / 1 = 1.26 m/s
    dict(breathing_amplitude=0.04, breathing_period=[0.1, 2.0]),                        # 2.5 m/s
    dict(randomize={"breathing_amplitude": [0.0, 0.2]}, breathing_period=[1.0, 2.0], ring_radius=0.5),
])
def test_crowd_breathing_speed_above_its_bound_is_rejected_by_name(kwargs):
    limit = read_yaml("scenarios/crowd.yaml")["max_breathing_speed"]
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepCrowd-v0", **kwargs)
    message = str(exc.value)
    assert "breathing_amplitude" in message and "breathing_period" in message
    assert f"max_breathing_speed={limit:g}" in message
    gym.make("FootstepCrowd-v0", max_breathing_speed=10.0, **kwargs).reset(seed=0)


@pytest.mark.parametrize("bound", ["max_door_speed", "max_door_radius"])
def test_a_bound_cannot_be_randomized(bound):
    with pytest.raises(ConfigError, match=f"randomize: '{bound}' is not a numeric key"):
        gym.make("FootstepDoor-v0", randomize={bound: [10.0, 20.0]})


@pytest.mark.parametrize("bound", ["max_door_speed", "max_obstacle_speed", "max_sweep_checks"])
def test_bounds_must_be_positive(bound):
    env_id = "FootstepCrossing-v0" if bound == "max_obstacle_speed" else "FootstepDoor-v0"
    with pytest.raises(ConfigError, match=bound):
        gym.make(env_id, **{bound: 0})


# ====================================================================== robot profiles (configs/robots/)
def test_robot_profiles_are_listed_and_hold_only_known_keys_that_differ():
    """Each profile is a file of ``configs/robots/``; it names only keys of ``configs/robot.yaml`` and only those it
    changes (a key equal to the base would hide which limits the profile is about)."""
    from footstep_gym.robot import robot_profiles

    assert "darwin-op" in robot_profiles()
    base = read_yaml("robot.yaml")
    for name in robot_profiles():
        data = read_yaml(f"robots/{name}.yaml")
        assert data and set(data) <= set(base), name
        assert all(as_plain(data[k]) != as_plain(base[k]) for k in data), (name, data)


@pytest.mark.parametrize("robot", ["darwin-op", {"profile": "darwin-op"}])
def test_a_robot_profile_reaches_the_env_by_name(robot):
    env = gym.make("FootstepDoor-v0", robot=robot)
    env.reset(seed=0)
    got = env.unwrapped.robot
    profile = read_yaml("robots/darwin-op.yaml")
    expected = {**read_yaml("robot.yaml"), **profile}
    for key, value in expected.items():
        assert as_plain(getattr(got, key)) == pytest.approx(as_plain(value)), key
    assert got == load_robot("darwin-op") == load_robot({"profile": "darwin-op"})
    assert got != load_robot()


def test_overrides_apply_on_top_of_a_profile():
    env = gym.make("FootstepDoor-v0", robot={"profile": "darwin-op", "turn_inner": 0.3, "body_radius": 0.12})
    robot = env.unwrapped.robot
    assert robot.turn_inner == 0.3 and robot.body_radius == 0.12
    assert robot.stride_side == tuple(read_yaml("robots/darwin-op.yaml")["stride_side"])


def test_make_policy_takes_a_robot_profile():
    from footstep_gym import make_policy

    for robot in ("darwin-op", {"profile": "darwin-op"}, load_robot("darwin-op")):
        assert make_policy("paper-period-aware", robot, seed=0).robot == load_robot("darwin-op")
    assert make_policy("period-aware", {"body_radius": 0.12}).robot.body_radius == 0.12


@pytest.mark.parametrize("robot", ["nao", {"profile": "nao"}, {"profile": 3}])
def test_unknown_robot_profile_names_the_known_ones(robot):
    with pytest.raises(ConfigError, match="unknown robot profile.*known profiles: .*darwin-op"):
        gym.make("FootstepDoor-v0", robot=robot)
    with pytest.raises(ConfigError, match="known profiles: .*darwin-op"):
        load_robot(robot)


def test_a_profile_with_an_unknown_key_is_rejected_by_name(tmp_path, monkeypatch):
    shutil.copytree(config_dir(), tmp_path / "configs")
    (tmp_path / "configs" / "robots" / "broken.yaml").write_text("turn_iner: 0.3\n")
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(tmp_path / "configs"))
    with pytest.raises(ConfigError, match="robots/broken.yaml.*'turn_iner' \\(did you mean 'turn_inner'\\?\\)"):
        load_robot("broken")


def test_a_profile_is_validated_like_the_base_file(tmp_path, monkeypatch):
    shutil.copytree(config_dir(), tmp_path / "configs")
    (tmp_path / "configs" / "robots" / "crossed.yaml").write_text("stride_side: [-0.01, 0.12]\n")
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(tmp_path / "configs"))
    with pytest.raises(ConfigError, match="stride_side must be > 0"):
        load_robot("crossed")


def test_only_a_class_with_profiles_takes_one():
    with pytest.raises(ConfigError, match="DoorConfig has no profiles"):
        config.load(DoorConfig, "scenarios/door.yaml", {"profile": "darwin-op"})


# ------------------------------------------------------------------ the robot (robot.py) against its YAML file
def test_robot_matches_yaml(robot):
    with open(config_dir() / "robot.yaml", encoding="utf-8") as fh:
        raw = yaml.safe_load(fh)
    assert robot.omega == pytest.approx(math.sqrt(raw["gravity"] / raw["com_height"]))
    s = 0.5 * raw["zmp_region_scale"]
    assert robot.zmp_half_extent == pytest.approx((s * raw["foot_length"], s * raw["foot_width"]))
    t_lim = max(raw["turn_inner"], raw["turn_outer"])
    np.testing.assert_allclose(robot.command_low, [raw["stride_front"][0], raw["stride_side"][0], -t_lim,
                                                   raw["t_ss"][0], raw["t_ds"][0]])
    np.testing.assert_allclose(robot.command_high, [raw["stride_front"][1], raw["stride_side"][1], t_lim,
                                                    raw["t_ss"][1], raw["t_ds"][1]])
    np.testing.assert_allclose(robot.nominal_command, [0.0, raw["nominal_side_stride"], 0.0,
                                                       raw["nominal_t_ss"], raw["nominal_t_ds"]])
    assert robot.nominal_period == pytest.approx(raw["nominal_t_ss"] + raw["nominal_t_ds"])
    assert load_robot({"com_height": 0.25}).omega == pytest.approx(math.sqrt(raw["gravity"] / 0.25))


def test_config_unknown_key_names_it_and_suggests():
    with pytest.raises(ConfigError) as exc:
        load_robot({"com_hieght": 0.2})
    msg = str(exc.value)
    assert "com_hieght" in msg and "com_height" in msg
    assert isinstance(exc.value, ValueError)


@pytest.mark.parametrize("key, value", [
    ("body_radius", -0.1), ("body_radius", 0.0), ("com_height", -0.23), ("turn_inner", -0.1),
    ("zmp_region_scale", 1.5), ("zmp_region_scale", 0.0), ("foot_length", "long"), ("foot_width", True),
    ("t_ss", [0.6, 0.1]), ("t_ss", [0.1]), ("stride_side", [0.0, 0.1]), ("nominal_t_ss", 0.9),
    ("nominal_side_stride", 0.05), ("com_height", 1e-6),  # the LIPM's e^(2 omega T) would overflow
])
def test_config_bad_values_name_the_key(key, value):
    with pytest.raises(ConfigError) as exc:
        load_robot({key: value})
    assert key in str(exc.value)


@pytest.mark.parametrize("key, value", [
    ("com_height", float("nan")), ("body_radius", float("nan")), ("turn_inner", float("nan")),
    ("zmp_region_scale", float("nan")), ("generator_weight_position", float("nan")),
    ("stride_front", [float("nan"), 0.1]), ("t_ds", [0.1, float("nan")]),
    ("com_height", float("inf")), ("body_radius", float("-inf")),
])
def test_config_rejects_non_finite(key, value):
    with pytest.raises(ConfigError) as exc:
        load_robot({key: value})
    assert key in str(exc.value)


# ------------------------------------------------------------------ what is no keyword, and the modules' order
@pytest.mark.parametrize("env_id, kwargs", [
    ("FootstepDoor-v0", {"SIDE_SECTIONS": 5}), ("FootstepDoor-v0", {"Config": 1}),
    ("FootstepMix-v0", {"door": {"SIDE_SECTIONS": 5}}),
])
def test_class_constants_are_no_keywords(env_id, kwargs):
    """A config class's constants (``ScenarioConfig.SIDE_SECTIONS``) are neither accepted nor offered."""
    with pytest.raises(ConfigError) as exc:
        gym.make(env_id, **kwargs)
    message = str(exc.value)
    assert "unknown key(s) 'SIDE_SECTIONS'" in message or "unknown key(s) 'Config'" in message
    assert "did you mean" not in message
    known = message.split("known keys: ")[1].split(", ")
    assert "SIDE_SECTIONS" not in known and "door_speed" in known


def test_env_config_sits_below_the_env_and_the_tiers():
    """``tiers`` reads ``EnvConfig``'s fields from ``env_config``, which imports neither ``env`` nor ``tiers``; the env
    imports no tiers (tests/test_tiers.py) and the tiers import the env only to build one."""
    import ast

    import footstep_gym.env_config
    import footstep_gym.tiers

    def imported(module) -> set[str]:
        tree = ast.parse(open(module.__file__, encoding="utf-8").read())
        names = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
        names |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
        names |= {f"{node.module}.{alias.name}" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                  for alias in node.names}
        return names

    assert not {"footstep_gym.env", "footstep_gym.tiers"} & imported(footstep_gym.env_config)
    assert "footstep_gym.env_config" in imported(footstep_gym.tiers)
    # the tiers build an env only in make_env (gymnasium.make's entry point), importing it there, not at load
    top = ast.parse(open(footstep_gym.tiers.__file__, encoding="utf-8").read()).body
    assert not any(isinstance(n, ast.ImportFrom) and n.module == "footstep_gym.env" for n in top)


def test_fields_are_converted_by_their_declared_types():
    """Every config class resolves its fields to types with a converter; ``float`` fields are the numeric ones."""
    from footstep_gym.env_config import EnvConfig
    from footstep_gym.scenarios import SCENARIOS

    types = config.field_types(EnvConfig)
    assert types["n_obstacles_observed"] is int and types["sensing_max_range"] is float
    assert types["render_size"] == tuple[float, float] and types["compiled_sweep"] is bool
    for cls in [Robot, EnvConfig, *(s.Config for s in SCENARIOS.values())]:
        assert set(config.field_types(cls)) == {f.name for f in dataclasses.fields(cls)}
    door = SCENARIOS["door"].Config
    assert "door_speed" in door.numeric_keys() and "max_steps" not in door.numeric_keys()
    assert "goal" not in door.numeric_keys() and "max_door_speed" not in door.numeric_keys()


def test_a_field_type_without_a_converter_is_refused_by_name():
    @dataclasses.dataclass(frozen=True)
    class Odd:
        when: complex = config.plain()

    with pytest.raises(TypeError, match="Odd: no config converter.*when"):
        config.build(Odd, {"when": 1j}, "odd.yaml")


@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, -math.inf, "far", True])
def test_a_range_that_may_be_infinite_still_names_bad_values(value):
    with pytest.raises(ConfigError, match="sensing_max_range must be a number > 0"):
        gym.make("FootstepCrowd-v0", sensing_max_range=value)
    assert gym.make("FootstepCrowd-v0", sensing_max_range=math.inf).unwrapped.config.sensing_max_range == math.inf


@pytest.mark.parametrize("value, match", [(3.0, "must be a list of numbers"), ([0.1, "x"], "must be a number"),
                                          ([0.1, math.nan], "must be finite")])
def test_a_list_of_numbers_names_a_bad_item(value, match):
    @dataclasses.dataclass(frozen=True)
    class Grid:
        steps: tuple[float, ...] = config.plain()

    assert config.build(Grid, {"steps": [1, 2.5]}, "grid.yaml").steps == (1.0, 2.5)
    with pytest.raises(ConfigError, match=f"grid.yaml.steps {match}"):
        config.build(Grid, {"steps": value}, "grid.yaml")


# ------------------------------------------------------------------ defaults in the code
def _configs():
    from footstep_gym.env_config import EnvConfig
    from footstep_gym.planners.params import PlannerConfig

    return EnvConfig, Robot, PlannerConfig


def test_configs_are_made_without_a_file(tmp_path, monkeypatch):
    """EnvConfig, Robot and PlannerConfig have their defaults in the code: made (and validated through
    config.build) with the config folder empty; the shipped YAML states the same values (it documents them)."""
    from footstep_gym.env_config import EnvConfig
    from footstep_gym.planners.params import _SECTION_TYPES, load_planner_config

    shipped = (config.load(EnvConfig, "env.yaml"), load_robot(), load_planner_config())
    (tmp_path / "empty").mkdir()
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(tmp_path / "empty"))
    made = tuple(cls() for cls in _configs())
    assert made == shipped
    assert config.build(EnvConfig, {}, "env") == made[0] and config.build(Robot, {}, "robot") == made[1]
    for name, section in _SECTION_TYPES.items():
        assert config.build(section, {}, name) == getattr(made[2], name)
    assert made[1].omega == math.sqrt(9.81 / 0.23) and made[0].sensing_max_range == math.inf
    assert made[2].period_search.rollout_wait_steps is not type(made[2])().period_search.rollout_wait_steps


def test_the_yaml_overrides_the_defaults_and_may_leave_keys_out(tmp_path, monkeypatch):
    from footstep_gym.env_config import EnvConfig
    from footstep_gym.planners.params import load_planner_config

    folder = tmp_path / "configs"
    shutil.copytree(config_dir(), folder)
    (folder / "env.yaml").write_text("reward_time: -0.5\n", encoding="utf-8")
    (folder / "robot.yaml").write_text("com_height: 0.25\n", encoding="utf-8")
    (folder / "planner.yaml").write_text("rrt: {iterations: 7}\n", encoding="utf-8")
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(folder))
    env_cfg, robot, planner = config.load(EnvConfig, "env.yaml"), load_robot(), load_planner_config()
    assert env_cfg == dataclasses.replace(EnvConfig(), reward_time=-0.5)
    assert robot == dataclasses.replace(Robot(), com_height=0.25)
    assert planner.rrt.iterations == 7 and planner.pso == type(planner)().pso
    env = gym.make("FootstepDoor-v0").unwrapped
    assert env.config.reward_time == -0.5 and env.robot.com_height == 0.25
    (folder / "env.yaml").write_text("reward_time: high\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="env.yaml.reward_time must be a number, got 'high'"):
        config.load(EnvConfig, "env.yaml")


@pytest.mark.parametrize("scene", ["door", "crossing", "crowd"])
def test_a_scenario_config_is_built_in_code_and_its_yaml_documents_the_defaults(scene, tmp_path, monkeypatch):
    """Each scenario config has its defaults in code: built with no config folder at all (none can be read), it
    validates, takes keyword overrides, and equals what the shipped YAML (the defaults' documentation) gives."""
    cls = SCENARIOS[scene]
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(tmp_path / "nowhere"))
    in_code = cls.Config()
    in_code.validate()
    with pytest.raises(ConfigError, match="nowhere"):
        cls.load_config()
    assert cls.Config(max_steps=7).max_steps == 7 and cls.Config().randomize is not in_code.randomize
    monkeypatch.undo()
    assert in_code == cls.load_config()
    folder = tmp_path / "configs"  # a YAML that leaves a key out: the code's default
    shutil.copytree(config_dir(), folder)
    path = folder / cls.config_file
    data = yaml.safe_load(path.read_text())
    data.pop("max_steps")
    data["goal_tolerance"] = 0.2
    path.write_text(yaml.safe_dump(data))
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(folder))
    assert cls.load_config() == dataclasses.replace(in_code, goal_tolerance=0.2)
