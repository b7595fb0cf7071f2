"""The scenario registry: a scenario is one module, one YAML and one entry, and everything else follows.

A toy scenario (a class here, its YAML in ``tmp_path`` named by an absolute path) is registered
in one call; ``footstep_gym.ENV_IDS``, ``gymnasium.make``, the mix, ``eval_planner.py``'s sweep
flags and cells pick it up, and the fixture's teardown takes it out again. The shipped
scenarios' fuzz ranges (the YAML's ``fuzz:`` section) are checked here too.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym
from footstep_gym.config import nonnegative, positive
from footstep_gym.errors import ConfigError
from footstep_gym.evaluation import profiles
from footstep_gym.evaluation.runner import Cell
from footstep_gym.scenarios import (SCENARIOS, Scenario, ScenarioConfig, register_scenario, resolve_env_id,
                                    scene_of, unregister_scenario, units)
from footstep_gym.world import World
from script_helpers import load_script

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "baselines" / "eval_planner.py"
TOY_ID = "FootstepToy-v0"


@dataclass(frozen=True)
class ToyConfig(ScenarioConfig):
    toy_speed: float = nonnegative(max_key="max_toy_speed", unit="m/s")  # [m/s] of the ball along -y
    toy_radius: float = positive()  # [m]
    toy_x: float = positive()  # [m] where the ball crosses the robot's path
    max_toy_speed: float = positive()  # [m/s]


class Toy(Scenario):
    """A ball rolling across the robot's path."""

    Config = ToyConfig
    env_id = TOY_ID
    sweep_axes = {"toy_speed": "m/s"}
    static_keys = ()

    def build(self, world: World) -> None:
        c = self.cfg
        world.add_circle("ball", (c.toy_x, 1.0), c.toy_radius, velocity=(0.0, -c.toy_speed))


TOY_YAML = """\
toy_speed: 0.1                # [m/s]
toy_radius: 0.1               # [m]
toy_x: 1.0                    # [m]
max_toy_speed: 2.0            # [m/s]
start: [0.0, 0.0]
start_yaw: 0.0
start_jitter: 0.0
goal: [2.0, 0.0]
goal_tolerance: 0.1
time_limit: 30.0
max_steps: 40
randomize: {}
fuzz:
  goal_tolerance: [0.05, 0.2]
  toy_speed: [0.0, .inf]      # up to max_toy_speed
"""


def toy_class(folder: Path, text: str = TOY_YAML) -> type[Toy]:
    """``Toy`` reading its YAML ``text`` from ``folder`` (an absolute path: no config folder needed)."""
    path = folder / "toy.yaml"
    path.write_text(text, encoding="utf-8")
    return type("Toy", (Toy,), {"config_file": str(path)})


@pytest.fixture
def toy(tmp_path):
    cls = toy_class(tmp_path)
    register_scenario("toy", cls)  # the one place
    yield cls
    unregister_scenario("toy")
    assert "toy" not in SCENARIOS and TOY_ID not in gym.registry


NOMINAL = np.array([0.0, 0.08, 0.0, 0.6, 0.2], dtype=np.float32)


# ---------------------------------------------------------------- a new scenario, registered once
def test_a_registered_scenario_gets_an_env_id_and_an_env(toy):
    assert footstep_gym.ENV_IDS["toy"] == TOY_ID and list(footstep_gym.ENV_IDS)[-1] == "toy"
    assert resolve_env_id("toy") == resolve_env_id("footsteptoy-v0") == TOY_ID and scene_of(TOY_ID) == "toy"
    env = gym.make(TOY_ID, toy_speed=0.3)
    assert env.spec.max_episode_steps == 40
    env.reset(seed=0)
    assert env.unwrapped.scenario_config.toy_speed == 0.3
    *_, info = env.step(NOMINAL)
    assert info["feasible"]
    assert units("toy") == {"toy_speed": "m/s"}
    with pytest.raises(ConfigError, match="fuzz"):
        gym.make(TOY_ID, fuzz={"toy_speed": [0, 1]})  # the YAML's side section is no keyword


def test_a_registered_scenario_joins_the_mix(toy):
    env = gym.make("FootstepMix-v0", toy={"toy_speed": 0.2, "max_steps": 5}, door={"door_speed": 8.0})
    assert env.unwrapped.scenes == ("door", "crossing", "crowd", "toy")
    assert env.unwrapped.envs["toy"].scenario_config.toy_speed == 0.2
    assert env.unwrapped.envs["door"].scenario_config.door_speed == 8.0
    only = gym.make("FootstepMix-v0", scenes=["toy"])
    _, info = only.reset(seed=1)
    assert info["scene"] == "toy"
    assert only.step(NOMINAL)[-1]["scene"] == "toy"


def test_a_registered_scenario_gets_its_sweep_flag_and_cells(toy, capsys):
    script = load_script("eval_planner")
    assert "--toy-speed M_S" in script.build_parser().format_help()
    settings = script.parse_settings(["--env", "toy", "--env", "door", "--toy-speed", "0.1", "--toy-speed", "0.3",
                                      "--door-speed", "8", "--policy", "fixed-period"])
    assert settings.envs == ("toy", "door")
    assert settings.sweeps["toy"] == {"toy_speed": (0.1, 0.3)} and settings.sweeps["door"] == {"door_speed": (8.0,)}
    cells = profiles.make_cells(settings)
    assert cells == [Cell(TOY_ID, "toy", "fixed-period", (("toy_speed", 0.1),)),
                     Cell(TOY_ID, "toy", "fixed-period", (("toy_speed", 0.3),)),
                     Cell("FootstepDoor-v0", "door", "fixed-period", (("door_speed", 8.0),))]
    assert [c.setting for c in cells] == ["toy_0.1", "toy_0.3", "door_8"]
    assert profiles.check_cells(cells) is None
    too_fast = profiles.make_cells(script.parse_settings(["--env", "toy", "--toy-speed", "5",
                                                          "--policy", "fixed-period"]))
    assert "--toy-speed 5" in profiles.check_cells(too_fast) and "max_toy_speed" in profiles.check_cells(too_fast)
    default = profiles.make_cells(script.parse_settings(["--env", "FootstepToy-v0", "--policy", "fixed-period"]))
    assert [c.params for c in default] == [()]  # no values: the YAML's toy_speed
    with pytest.raises(SystemExit):
        script.parse_settings(["--env", "door", "--toy-speed", "0.1"])
    assert "--toy-speed applies to the toy env only; add --env toy" in capsys.readouterr().err


def test_unregistering_takes_the_scenario_out_everywhere(tmp_path):
    script = load_script("eval_planner")
    register_scenario("toy", toy_class(tmp_path))
    unregister_scenario("toy")
    assert "toy" not in footstep_gym.ENV_IDS and TOY_ID not in gym.registry
    assert "--toy-speed" not in script.build_parser().format_help()
    assert gym.make("FootstepMix-v0").unwrapped.scenes == ("door", "crossing", "crowd")
    with pytest.raises(ValueError, match="unknown env 'toy'"):
        resolve_env_id("toy")


def test_two_axes_make_the_product_in_their_order(tmp_path):
    cls = type("Toy2", (toy_class(tmp_path),), {"sweep_axes": {"toy_speed": "m/s", "toy_x": "m"}})
    register_scenario("toy", cls)
    try:
        script = load_script("eval_planner")
        cells = profiles.make_cells(script.parse_settings(
            ["--env", "toy", "--toy-x", "1", "--toy-x", "2", "--toy-speed", "0.1", "--policy", "fixed-period"]))
        assert [c.params for c in cells] == [(("toy_speed", 0.1), ("toy_x", 1.0)), (("toy_speed", 0.1), ("toy_x", 2.0))]
        assert [c.setting for c in cells] == ["toy_0.1_1", "toy_0.1_2"]
    finally:
        unregister_scenario("toy")


@pytest.mark.parametrize("name, attrs, message", [
    ("all", {}, "not ('all', 'mix')"),
    ("Toy", {}, "lower-case"),
    ("toy", {"env_id": "FootstepDoor-v0"}, "is scenario 'door'"),
    ("toy", {"env_id": "toy"}, "env_id must look like"),
    ("toy", {"sweep_axes": {"toy_sped": "m/s"}}, "sweep axis 'toy_sped'"),
    ("toy", {"sweep_axes": {"max_toy_speed": "m/s"}}, "sweep axis 'max_toy_speed'"),
])
def test_a_bad_scenario_is_refused_and_nothing_registered(tmp_path, name, attrs, message):
    cls = type("Bad", (toy_class(tmp_path),), attrs)
    with pytest.raises(ConfigError, match=message.replace("(", r"\(").replace(")", r"\)")):
        register_scenario(name, cls)
    assert name not in SCENARIOS and list(SCENARIOS) == ["door", "crossing", "crowd"]


def test_a_name_is_registered_once(toy, tmp_path):
    register_scenario("toy", toy)  # the same class again: nothing happens
    with pytest.raises(ConfigError, match="registered already"):
        register_scenario("toy", toy_class(tmp_path))


def test_the_profiles_sweep_the_scenarios_axes():
    for name, profile in profiles.PROFILES.items():
        assert set(profile.envs) <= set(SCENARIOS), name
        for scene, sweep in profile.sweeps.items():
            assert set(sweep) <= set(SCENARIOS[scene].sweep_axes), (name, scene)
    assert {key: [s for s, _ in owners] for key, owners in profiles.sweep_axes().items()} == {
        "door_speed": ["door"], "crowd_speed": ["crowd"]}


# ---------------------------------------------------------------- the mix's keywords
def test_the_mix_takes_each_scenes_keywords_under_its_name():
    env = gym.make("FootstepMix-v0", door={"randomize": {"door_speed": [5.0, 20.0]}},
                   crowd={"randomize": {"crowd_speed": [0.12, 0.22]}})  # as configs/rl/ppo.yml
    assert env.unwrapped.envs["door"].scenario_config.randomize == {"door_speed": [5.0, 20.0]}
    assert env.unwrapped.envs["crossing"].scenario_config.randomize == {}
    with pytest.raises(ConfigError, match="'dor'.*door, crossing, crowd"):
        gym.make("FootstepMix-v0", dor={"door_speed": 8.0})
    with pytest.raises(ConfigError, match="door must be a mapping"):
        gym.make("FootstepMix-v0", door=8.0)


# ---------------------------------------------------------------- resolving names
def test_resolve_env_id_takes_names_and_ids():
    assert resolve_env_id(" Door ") == "FootstepDoor-v0"
    assert resolve_env_id("footstep_gym:FootstepCrowd-v0") == "FootstepCrowd-v0"
    assert resolve_env_id("fOOTSTEPcrossing-v0") == "FootstepCrossing-v0"
    for name in ("all", "mix", "FootstepMix-v0"):
        assert resolve_env_id(name, mix=True) == footstep_gym.MIX_ENV_ID
        with pytest.raises(ValueError, match="choose from door, crossing, crowd, FootstepDoor-v0"):
            resolve_env_id(name)
    assert dict(footstep_gym.ENV_IDS) == {"door": "FootstepDoor-v0", "crossing": "FootstepCrossing-v0",
                                          "crowd": "FootstepCrowd-v0"}


def test_train_rl_resolves_envs_with_the_package_function():
    try:
        module = load_script("train_rl")
    except ImportError as exc:  # its optional training dependencies
        pytest.skip(str(exc))
    assert module.env_id_of("crowd") == "FootstepCrowd-v0" and module.env_id_of("all") == "FootstepMix-v0"
    with pytest.raises(Exception, match="unknown env 'moon'"):
        module.env_id_of("moon")


# ---------------------------------------------------------------- fuzz ranges
def test_the_shipped_fuzz_ranges_are_valid_and_reach_the_bounds():
    for scene, cls in SCENARIOS.items():
        ranges = cls.fuzz_ranges()
        cfg = cls.load_config()
        assert list(ranges)[:4] == ["start_yaw", "start_jitter", "goal_tolerance", "time_limit"], scene
        for key, max_key in cls.Config.upper_bounds().items():
            if key in ranges:
                assert ranges[key][1] <= getattr(cfg, max_key)
        for axis in cls.sweep_axes:
            assert ranges[axis][1] == getattr(cfg, cls.Config.upper_bounds()[axis])  # .inf: up to the bound
    assert SCENARIOS["door"].fuzz_ranges()["door_speed"] == (0.0, 360.0)


def test_the_soak_draws_from_the_fuzz_ranges(toy):
    """The soak (``speedlib.soak``, behind ``baselines/soak.py``) keeps no table of its own: a scenario's
    ``randomize=`` settings are drawn from its ``fuzz_ranges()``, key by key in their order (a registered
    scenario's too), bounds as resolved there."""
    from speedlib import soak

    assert not hasattr(soak, "FUZZ_RANGES")
    ranges = toy.fuzz_ranges()
    assert ranges["toy_speed"] == (0.0, 2.0)  # .inf: up to max_toy_speed
    seen = set()
    rng = np.random.default_rng(0)
    for _ in range(100):
        spec = soak.random_randomize("toy", rng)
        for key, (a, b) in spec.items():
            lo, hi = ranges[key]
            assert lo <= a <= b <= hi, key
        seen.update(spec)
    assert seen == set(ranges)
    # The draws, one generator for all: per key in order, one number to decide, two for [a, b].
    mine, recipe = np.random.default_rng(7), np.random.default_rng(7)
    expected = {}
    for key, (lo, hi) in ranges.items():
        if recipe.random() < soak.P_RANDOMIZE_KEY:
            expected[key] = sorted(float(v) for v in recipe.uniform(lo, hi, 2))
    assert soak.random_randomize("toy", mine) == expected
    env, kwargs = soak.make_fuzzed_env(TOY_ID, np.random.default_rng(3))  # the env id's scene: scene_of
    assert kwargs == {"randomize": soak.random_randomize("toy", np.random.default_rng(3))}
    env.close()


@pytest.mark.parametrize("section, message", [
    ("  toy_sped: [0, 1]\n", "'toy_sped' is not a numeric key"),
    ("  max_toy_speed: [0, 1]\n", "'max_toy_speed' is not a numeric key"),
    ("  max_steps: [1, 5]\n", "'max_steps' is not a numeric key"),
    ("  toy_speed: [1.0, 0.5]\n", "lo <= hi"),
    ("  toy_speed: [0.0, 3.0]\n", "reaches 3, above max_toy_speed=2"),
    ("  toy_x: [0.5, .inf]\n", "must be finite"),
    ("  toy_speed: [0.1]\n", r"must be \[lo, hi\]"),
    ("  toy_speed: [a, 1]\n", "must be a number"),
    ("  toy_radius: [0.0, 0.1]\n", "field's range"),
])
def test_a_bad_fuzz_range_is_refused_by_name(tmp_path, section, message):
    cls = toy_class(tmp_path, TOY_YAML.split("fuzz:")[0] + "fuzz:\n" + section)
    with pytest.raises(ConfigError, match=message) as exc:
        cls.fuzz_ranges()
    assert "toy.yaml: fuzz" in str(exc.value)
    cls.load_config()  # the env's keys load whatever the fuzz section holds


def test_no_fuzz_section_means_no_ranges_and_a_bad_one_is_named(tmp_path):
    assert toy_class(tmp_path, TOY_YAML.split("fuzz:")[0]).fuzz_ranges() == {}
    with pytest.raises(ConfigError, match="must be a mapping"):
        toy_class(tmp_path, TOY_YAML.split("fuzz:")[0] + "fuzz: [1, 2]\n").fuzz_ranges()
