"""Benchmark tiers (configs/benchmark.yaml, footstep_gym/tiers.py), their rules, the null rule, and the scene options
the structure tier uses.

Every tier of every scene (and of the mix) makes, resets, steps and replays from its seed bit for bit; unknown
tiers and cells are refused by name; the paper tier is the env without a tier; the train tier is what the shipped
agents trained on (their manifests and configs/rl, which write its ranges out), so it makes their training episodes
bit for bit; keywords given with a tier apply on top of it unless a cell sets them. Every cell is made from
its entry by its tier's rule, and a broken rule is refused when the file is read; no null baseline solves a cell
outside the paper tier on validation seeds. The second revolving door and the two-way traffic are checked with
plain geometry written here, and with gymnasium's own env checker.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
import shutil
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml
from gymnasium.utils.env_checker import check_env

import footstep_gym
from footstep_gym import tiers
from footstep_gym.config import config_dir
from footstep_gym.errors import ConfigError

from env_helpers import NOMINAL, moving, read_yaml

SCENES = ("door", "crossing", "crowd")
ROOT = Path(__file__).resolve().parent.parent
STEPS = 8


def benchmark() -> dict:
    with open(config_dir() / "benchmark.yaml", encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def tier_scene_cells() -> list[tuple[str, str, str]]:
    """(tier, scene, cell) of every cell in the file, read directly."""
    data = benchmark()
    return [(t, s, c) for t, body in data.items() if not t.startswith("x-")
            for s, cells in body.items() if s not in ("about", "rule") for c in cells]


def episode(env: gym.Env, seed: int, steps: int = STEPS, cell: bool = True) -> list:
    """Observations, rewards, flags and info of a seeded episode of random (seeded) and nominal commands
    (``cell=False``: without the reset info's ``tier_cell``)."""
    obs, info = env.reset(seed=seed)
    if not cell:
        info.pop("tier_cell", None)
    out = [(obs.tobytes(), repr(sorted(info.items())))]
    rng = np.random.default_rng(seed)
    box = env.action_space
    for k in range(steps):
        action = NOMINAL if k % 2 else rng.uniform(box.low, box.high).astype(np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        out.append((obs.tobytes(), reward, terminated, truncated, repr(sorted(info.items()))))
        if terminated or truncated:
            break
    return out


# ------------------------------------------------------------------ the file
def test_every_tier_lists_every_scene_and_the_paper_tier_sets_nothing():
    data = benchmark()
    assert list(tiers.tier_names()) == [t for t in data if not t.startswith("x-")]
    assert tiers.tier_names() == ["paper", "train", "shifted", "structure", "noise"]
    for name in tiers.tier_names():
        assert set(tiers.tier(name).scenes) == set(SCENES), name
        assert tiers.tier(name).about, name
    assert {s: [(c.name, dict(c.kwargs)) for c in tiers.cells(s, "paper")] for s in SCENES} == \
        {s: [("default", {})] for s in SCENES}


@pytest.mark.parametrize("tier, scene, cell", tier_scene_cells())
def test_every_cell_builds_and_its_keys_reach_the_episode(tier, scene, cell):
    """Each cell's keys are valid for its scene (values included) and are the episode's config."""
    env = gym.make(footstep_gym.ENV_IDS[scene], tier=tier, tier_cell=cell)
    _, info = env.reset(seed=3)
    base = env.unwrapped
    assert base.tier == tier and base.tier_cell == cell
    assert info["tier_cell"] == cell
    kwargs = tiers.plain(tiers.cells(scene, tier, cell)[0].kwargs)
    randomize = kwargs.pop("randomize", {})
    for key, value in kwargs.items():
        holder = base.config if hasattr(base.config, key) else base.episode_config
        got = getattr(holder, key)
        assert (list(got) if isinstance(got, tuple) else got) == value, key
    for key, (lo, hi) in randomize.items():
        assert lo <= getattr(base.episode_config, key) <= hi, key
    env.close()


# ------------------------------------------------------------------ replays
@pytest.mark.parametrize("tier", ["paper", "train", "shifted", "structure", "noise"])
@pytest.mark.parametrize("env_id", [*footstep_gym.ENV_IDS.values(), footstep_gym.MIX_ENV_ID])
def test_every_tier_replays_bit_for_bit_from_its_seed(env_id, tier):
    """A fresh env and a used one (other episodes, other cells before) give the same episode for a seed."""
    fresh = [episode(gym.make(env_id, tier=tier), seed) for seed in (11, 12, 13)]
    used = gym.make(env_id, tier=tier)
    for seed in (13, 12, 11, 40):
        episode(used, seed)
    for seed, want in zip((11, 12, 13), fresh):
        assert episode(used, seed) == want, seed


@pytest.mark.parametrize("env_id", footstep_gym.ENV_IDS.values())
def test_the_paper_tier_is_the_env_without_a_tier(env_id):
    """Same observations, rewards and info, and the same random numbers left in the generator."""
    for seed in (0, 5):
        plain_env, paper = gym.make(env_id), gym.make(env_id, tier="paper")
        assert episode(plain_env, seed) == episode(paper, seed, cell=False)
        assert plain_env.unwrapped.np_random.bit_generator.state == paper.unwrapped.np_random.bit_generator.state
        assert paper.unwrapped.cells == {"default": {}} and paper.unwrapped.tier == "paper"
    assert gym.make(env_id, tier=None).unwrapped.tier is None


def test_a_tier_of_several_cells_draws_its_cell_per_episode_from_the_seed():
    env = gym.make("FootstepCrowd-v0", tier="structure")
    names = list(env.unwrapped.cells)
    assert len(names) > 1
    drawn = []
    for seed in range(30):
        _, info = env.reset(seed=seed)
        drawn.append(info["tier_cell"])
        assert env.unwrapped.tier_cell == info["tier_cell"]
    assert set(drawn) == set(names)  # every cell comes up
    again = [gym.make("FootstepCrowd-v0", tier="structure").reset(seed=s)[1]["tier_cell"] for s in range(30)]
    assert again == drawn  # and the seed fixes which
    one = gym.make("FootstepCrowd-v0", tier="structure", tier_cell="counter_flow")
    assert {one.reset(seed=s)[1]["tier_cell"] for s in range(5)} == {"counter_flow"}


# ------------------------------------------------------------------ errors
def test_unknown_tier_is_refused_naming_the_known_ones():
    for env_id in (*footstep_gym.ENV_IDS.values(), footstep_gym.MIX_ENV_ID):
        with pytest.raises(ConfigError) as exc:
            gym.make(env_id, tier="expert")
        assert "'expert'" in str(exc.value)
        assert all(name in str(exc.value) for name in ("paper", "train", "shifted", "structure", "noise"))


def test_unknown_tier_cell_is_refused_naming_the_tiers_cells():
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepDoor-v0", tier="structure", tier_cell="slow")
    assert "'slow'" in str(exc.value) and "two_doors" in str(exc.value) and "any_phase" in str(exc.value)


@pytest.mark.parametrize("override", [{"door_speed": 10.0}, {"randomize": {"door_speed": [5.0, 6.0]}}])
def test_an_override_of_a_key_the_tier_sets_is_refused(override):
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepDoor-v0", tier="train", **override)
    assert "door_speed" in str(exc.value) and "'train'" in str(exc.value) and "paper" in str(exc.value)


def test_other_overrides_apply_on_top_of_the_tier():
    env = gym.make("FootstepDoor-v0", tier="train", door_angle_jitter=0.0, reward_time=-0.2,
                   randomize={"door_radius": [0.45, 0.5]})
    base = env.unwrapped
    env.reset(seed=0)
    assert base.episode_config.door_angle_jitter == 0.0 and base.config.reward_time == -0.2
    assert base.scenario_config.randomize == {"door_speed": [5.0, 20.0], "door_radius": [0.45, 0.5]}
    assert 0.45 <= base.episode_config.door_radius <= 0.5
    # The paper tier sets nothing: every key is free, as without a tier.
    assert gym.make("FootstepDoor-v0", tier="paper", door_speed=8.0).unwrapped.scenario_config.door_speed == 8.0


def _with_benchmark(tmp_path, monkeypatch, edit) -> None:
    folder = tmp_path / "configs"
    shutil.copytree(config_dir(), folder)
    data = benchmark()
    edit(data)
    (folder / "benchmark.yaml").write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(folder))


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["train"]["door"]["train"].update(door_sped=3.0), ["door_sped", "door_speed"]),
    (lambda d: d["structure"]["door"]["any_phase"]["set"].update(robot={"com_height": 0.3}), ["robot"]),
    (lambda d: d["train"]["door"]["train"].update(sensing_range=1.0), ["sensing_range"]),
    (lambda d: d["train"]["door"]["train"]["randomize"].update(door_count=[1, 2]), ["door_count"]),
    (lambda d: d["shifted"].update(kitchen={"a": {}}), ["kitchen", "door"]),
])
def test_a_bad_key_in_the_file_is_refused_when_read(tmp_path, monkeypatch, edit, words):
    _with_benchmark(tmp_path, monkeypatch, edit)
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepCrowd-v0", tier="paper")  # read, and checked whole, even for another tier
    assert all(w in str(exc.value) for w in words), str(exc.value)


def test_a_bad_value_in_a_cell_is_refused_when_its_tier_is_made(tmp_path, monkeypatch):
    _with_benchmark(tmp_path, monkeypatch,
                    lambda d: d["structure"]["door"]["any_phase"]["set"].update(door_radius=-1.0))
    gym.make("FootstepDoor-v0", tier="train")  # another tier is made
    with pytest.raises(ConfigError, match="door_radius"):
        gym.make("FootstepDoor-v0", tier="structure")


def test_the_paper_tier_needs_no_file(tmp_path, monkeypatch):
    """A config folder from before the tiers still makes the paper's scenes."""
    folder = tmp_path / "configs"
    shutil.copytree(config_dir(), folder)
    (folder / "benchmark.yaml").unlink()
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(folder))
    gym.make("FootstepDoor-v0").reset(seed=0)
    with pytest.raises(ConfigError, match="benchmark"):
        gym.make("FootstepDoor-v0", tier="train")


# ------------------------------------------------------------------ the train tier and the shipped agents
#: The shipped agents trained on the train tier (the others, e.g. ppo-wide or ppo-noisy, on distributions of their
#: own: configs/rl/<agent>.yml says which).
TRAIN_TIER_AGENTS = ("ppo", "ppo-fixed-period", "sac", "td3", "td3-b2048", "sac-sb3")


def _manifests() -> list[Path]:
    return sorted(p for a in TRAIN_TIER_AGENTS for p in (ROOT / "baselines" / "agents" / a).glob("*/manifest.json"))


#: The crossing's train cell of protocol 1 (one timed car): protocol 2's crosses a stream with a moving gap instead (a
#: blind walker solved the timed car), and the crossing's agents were retrained there (docs/benchmark.md, "History"),
#: but for the mix (ppo-all, listed in PROTOCOL_1_CROSSING_AGENTS), still protocol 1's (its row says so).
PROTOCOL_1_CROSSING = {"randomize": {"obstacle_speed": [0.15, 0.35], "arrival_speed": [0.09, 0.16]}}
PROTOCOL_1_CROSSING_AGENTS: frozenset[str] = frozenset({"ppo-all"})


def _train_kwargs(scene: str, fixed_period: bool = False, protocol_1: bool = False) -> dict:
    """What the shipped agents of ``scene`` trained on: the train tier's cell (``protocol_1``: protocol 1's for the
    crossing)."""
    (cell,) = tiers.cells(scene, "train")
    kwargs = PROTOCOL_1_CROSSING if scene == "crossing" and protocol_1 else cell.kwargs
    return {**tiers.plain(kwargs), **({"fixed_period": True} if fixed_period else {})}


def test_the_crossings_train_cell_is_protocol_2s_stream():
    (cell,) = tiers.cells("crossing", "train")
    assert tiers.plain(cell.kwargs) != PROTOCOL_1_CROSSING and cell.kwargs["traffic_lanes"] == 1


def test_the_train_tier_is_what_the_shipped_agents_trained_on():
    manifests = _manifests()
    assert len(manifests) >= 10
    for path in manifests:
        m = json.loads(path.read_text(encoding="utf-8"))
        fixed = bool(m["env_kwargs"].get("fixed_period", False))
        old = path.parents[1].name in PROTOCOL_1_CROSSING_AGENTS or m["env_id"] == footstep_gym.MIX_ENV_ID
        if m["env_id"] == footstep_gym.MIX_ENV_ID:
            want = {s: _train_kwargs(s, protocol_1=True) for s in SCENES}
        else:
            want = _train_kwargs(footstep_gym.scenarios.scene_of(m["env_id"]), fixed, protocol_1=old)
        assert m["env_kwargs"] == want, path


def test_the_rl_configs_train_on_the_train_tier():
    """configs/rl/*.yml write the train tier's ranges out (so a run's config.yml and manifest say what it trained
    on whatever benchmark.yaml later says): the same keys, ranges and order (the order of the draws)."""
    for name in ("ppo.yml", "ppo-fixed-period.yml", "sac.yml", "sac_sbx.yml", "td3_sbx.yml"):
        with open(config_dir() / "rl" / name, encoding="utf-8") as fh:
            zoo = yaml.load(fh, Loader=yaml.UnsafeLoader)
        for env_id, entry in zoo.items():
            if not env_id.startswith("Footstep"):
                continue
            kwargs = {k: v for k, v in entry["env_kwargs"].items() if k != "fixed_period"}
            if env_id == footstep_gym.MIX_ENV_ID:  # ppo-all's, not retrained: protocol 1's crossing
                want = {s: _train_kwargs(s, protocol_1=True) for s in SCENES}
                assert set(kwargs) == set(want), name
                for scene in SCENES:
                    assert list(kwargs[scene]["randomize"].items()) == list(want[scene]["randomize"].items())
            else:
                want = _train_kwargs(footstep_gym.scenarios.scene_of(env_id))
                assert kwargs == want and list(kwargs["randomize"].items()) == list(want["randomize"].items()), \
                    (name, env_id)


#: What configs/rl/ppo.yml gave gym.make, in its order: the keys of a randomize range are drawn in their order, and
#: rl_zoo3 passed ppo.yml's (the runs' config.yml and manifests are key-sorted).
TRAINED_ON = {
    "FootstepDoor-v0": {"randomize": {"door_speed": [5.0, 20.0]}},
    "FootstepCrossing-v0": {"traffic_lanes": 1, "traffic_spacing": 0.9, "traffic_extent": 5.0, "time_limit": 90.0,
                            "randomize": {"traffic_gap": [1.5, 1.7], "traffic_speed": [0.2, 0.3]}},
    "FootstepCrowd-v0": {"randomize": {"crowd_speed": [0.12, 0.22]}},
}


@pytest.mark.parametrize("env_id", ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"])
def test_the_train_tier_makes_the_shipped_agents_training_episodes(env_id):
    """gym.make(id, tier="train") and the ranges the agents trained with give the same episodes, bit for bit."""
    path = ROOT / "baselines" / "agents" / "ppo" / f"{env_id}_1" / "manifest.json"
    assert json.loads(path.read_text(encoding="utf-8"))["env_kwargs"] == TRAINED_ON[env_id]
    tiered, written_out = gym.make(env_id, tier="train"), gym.make(env_id, **TRAINED_ON[env_id])
    for seed in (1, 2, 3):
        assert episode(tiered, seed, 12, cell=False) == episode(written_out, seed, 12), seed


# ------------------------------------------------------------------ the mix
def test_the_mix_passes_the_tier_to_every_scene():
    env = gym.make(footstep_gym.MIX_ENV_ID, tier="shifted")
    assert {s: e.tier for s, e in env.unwrapped.envs.items()} == {s: "shifted" for s in SCENES}
    env = gym.make(footstep_gym.MIX_ENV_ID, tier="shifted", crowd={"tier": "noise", "tier_cell": "train"})
    assert env.unwrapped.envs["crowd"].tier == "noise" and env.unwrapped.envs["door"].tier == "shifted"
    assert list(env.unwrapped.envs["crowd"].cells) == ["train"]
    _, info = env.reset(seed=0)
    assert info["scene"] in SCENES and "tier_cell" in info


# ------------------------------------------------------------------ the second revolving door
TWO_DOORS = dict(door_count=2, goal=[3.0, -0.33], second_door_offset=1.8, second_door_speed=9.0,
                 second_door_start_angle=30.0)


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    d = b - a
    u = 0.0 if not d.any() else float(np.clip(np.dot(p - a, d) / np.dot(d, d), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + u * d)))


def test_one_door_by_default():
    door = read_yaml("scenarios/door.yaml")
    assert door["door_count"] == 1
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    assert [o.name for o in moving(env)] == ["door"]
    assert not any(o.name.startswith(("drum2", "wall_top_middle")) for o in env.unwrapped.world.obstacles)


def test_two_doors_turn_independently_at_their_own_speeds_and_phases():
    door = read_yaml("scenarios/door.yaml")
    env = gym.make("FootstepDoor-v0", door_speed=14.0, **TWO_DOORS)
    first_angles = []
    for seed in range(6):
        env.reset(seed=seed)
        rods = {o.name: o for o in moving(env)}
        assert set(rods) == {"door", "door_2"}
        assert rods["door"].position == pytest.approx(tuple(door["door_centre"]))
        assert rods["door_2"].position == pytest.approx((door["door_centre"][0] + 1.8, door["door_centre"][1]))
        assert rods["door"].angular_velocity == pytest.approx(-math.radians(14.0))
        assert rods["door_2"].angular_velocity == pytest.approx(-math.radians(9.0))
        assert abs(math.degrees(rods["door_2"].angle) - 30.0) <= door["second_door_angle_jitter"] + 1e-9
        first_angles.append(rods["door"].angle)
        before = {k: v.angle for k, v in rods.items()}
        env.step(NOMINAL)
        after = {o.name: o.angle for o in moving(env)}
        assert math.degrees(before["door"] - after["door"]) / 0.8 == pytest.approx(14.0, rel=1e-9)
        assert math.degrees(before["door_2"] - after["door_2"]) / 0.8 == pytest.approx(9.0, rel=1e-9)
    # The first door draws what it drew with one door: its angle per seed is unchanged by the second.
    one = gym.make("FootstepDoor-v0", door_speed=14.0)
    for seed, angle in enumerate(first_angles):
        one.reset(seed=seed)
        assert moving(one)[0].angle == angle


@pytest.mark.parametrize("offset", [1.2, 1.8, 2.5])
def test_the_walls_stay_clear_of_both_rods_sweeps_and_close_both_drums(offset):
    door = read_yaml("scenarios/door.yaml")
    env = gym.make("FootstepDoor-v0", **{**TWO_DOORS, "second_door_offset": offset})
    env.reset(seed=0)
    world = env.unwrapped.world
    cx, cy = door["door_centre"]
    centres = [np.array([cx, cy]), np.array([cx + offset, cy])]
    tip = door["door_radius"] + 0.5 * door["door_thickness"]  # the rods' tips sweep this circle
    walls = [o for o in world.obstacles if o.static]
    for wall in walls:
        a, b = np.array(wall.shape.a), np.array(wall.shape.b)
        for c in centres:
            assert _segment_distance(c, a, b) - wall.radius > tip + 1e-9, (wall.name, offset)
    # The two sweeps leave room between them, and each upper half is closed: the drum's chain runs from the
    # upper wall on one side to the upper wall on the other, with no gap.
    assert offset - 2 * tip > 0
    for prefix, c in (("drum", centres[0]), ("drum2", centres[1])):
        drum = sorted((o for o in walls if o.name.startswith(prefix + "_")), key=lambda o: int(o.name.split("_")[1]))
        assert len(drum) == door["drum_segments"]
        for s, t in zip(drum, drum[1:]):
            assert tuple(s.shape.b) == pytest.approx(tuple(t.shape.a))
        ends = [tuple(drum[0].shape.a), tuple(drum[-1].shape.b)]
        tops = [o for o in walls if o.name.startswith("wall_top")]
        for end in ends:
            assert any(min(math.dist(end, tuple(o.shape.a)), math.dist(end, tuple(o.shape.b))) < 1e-9 or
                       _segment_distance(np.array(end), np.array(o.shape.a), np.array(o.shape.b)) < 1e-9
                       for o in tops), (prefix, end)
    bottom = next(o for o in walls if o.name == "wall_bottom")
    assert bottom.shape.b.x == pytest.approx(cx + offset + door["corridor_x"][1])  # runs on past the second door


def test_a_used_env_rebuilds_the_walls_when_the_second_door_moves():
    env = gym.make("FootstepDoor-v0", door_count=2, goal=[3.2, -0.33], randomize={"second_door_offset": [1.2, 2.0]})
    ends = set()
    for seed in range(3):
        env.reset(seed=seed)
        (middle,) = [o for o in env.unwrapped.world.obstacles if o.name == "wall_top_middle"]
        (rod,) = [o for o in moving(env) if o.name == "door_2"]
        assert middle.shape.b.x == pytest.approx(rod.position[0] - env.unwrapped.episode_config.drum_radius)
        ends.add(middle.shape.b.x)
    assert len(ends) == 3


@pytest.mark.parametrize("kwargs, words", [
    (dict(door_count=3), ["door_count"]),
    (dict(door_count=2, second_door_offset=0.9), ["second_door_offset", "overlap"]),
    (dict(door_count=2, corridor_x=[-1.8, 0.3]), ["corridor_x"]),
    (dict(door_count=2, second_door_speed=400.0), ["second_door_speed", "max_door_speed"]),
])
def test_bad_second_door_settings_are_refused_by_name(kwargs, words):
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepDoor-v0", **kwargs)
    assert all(w in str(exc.value) for w in words), str(exc.value)


# ------------------------------------------------------------------ two-way traffic
TRAFFIC = dict(traffic_lanes=3, traffic_lane_width=0.6, traffic_spacing=1.5, traffic_speed=0.3, traffic_extent=2.5,
               goal=[2.5, 0.0])


def test_one_timed_car_by_default():
    assert read_yaml("scenarios/crossing.yaml")["traffic_lanes"] == 0
    env = gym.make("FootstepCrossing-v0")
    env.reset(seed=0)
    assert [o.name for o in moving(env)] == ["car"]
    assert type(env.unwrapped.scenario).__name__ == "Crossing"


def test_traffic_lanes_alternate_directions_and_keep_their_spacing():
    cfg = read_yaml("scenarios/crossing.yaml")
    env = gym.make("FootstepCrossing-v0", **TRAFFIC)
    env.reset(seed=0)
    cars = moving(env)
    per_lane = math.ceil(2 * 2.5 / 1.5)
    assert len(cars) == 3 * per_lane
    for lane in range(3):
        mine = [c for c in cars if c.name.startswith(f"car_{lane}_")]
        x = cfg["start"][0] + cfg["crossing_x"] + (lane - 1) * 0.6
        assert all(c.position[0] == pytest.approx(x) for c in mine)
        assert all(c.velocity == pytest.approx((0.0, 0.3 if lane % 2 == 0 else -0.3)) for c in mine)  # alternating
        ys = sorted(c.position[1] for c in mine)
        gaps = np.diff(ys + [ys[0] + per_lane * 1.5])  # around the lane's loop
        assert gaps == pytest.approx(np.full(per_lane, 1.5))


def test_cars_reenter_their_lane_after_driving_past_its_end():
    env = gym.make("FootstepCrossing-v0", **{**TRAFFIC, "start": [-3.0, 0.0], "goal": [-2.0, 5.0],
                                            "time_limit": 100.0, "max_steps": 60})  # the robot far from the lanes
    env.reset(seed=1)
    loop = math.ceil(2 * 2.5 / 1.5) * 1.5
    lo, hi = -0.5 * loop, 0.5 * loop  # about the start's y
    start = {c.name: c.position[1] for c in moving(env)}
    wrapped = set()
    for _ in range(30):  # 30 x 0.8 s: every car drives 7.2 m, more than a loop
        _, _, terminated, truncated, _ = env.step(np.array([0.0, 0.08, 0.0, 0.6, 0.2]))
        assert not terminated and not truncated
        env.unwrapped.scenario.before_step(env.unwrapped.world, env.unwrapped.time, 0.8)  # place them as a step does
        t = env.unwrapped.time
        for c in moving(env):
            lane = int(c.name.split("_")[1])
            direction = 1.0 if lane % 2 == 0 else -1.0
            assert lo - 1e-9 <= c.position[1] < hi + 1e-9  # within the loop
            straight = start[c.name] + direction * 0.3 * t
            if abs(c.position[1] - straight) > 1e-6:  # re-entered: a whole number of loops back
                k = (straight - c.position[1]) / loop
                assert k == pytest.approx(round(k)) and round(k) != 0
                wrapped.add(lane % 2)
    assert wrapped == {0, 1}  # in both directions


def test_the_traffic_scene_replays_and_its_phases_are_drawn_per_episode():
    env = gym.make("FootstepCrossing-v0", **TRAFFIC)
    assert episode(env, 4, 12) == episode(gym.make("FootstepCrossing-v0", **TRAFFIC), 4, 12)
    phases = set()
    for seed in range(5):
        env.reset(seed=seed)
        phases.add(round(next(c for c in moving(env) if c.name == "car_0_0").position[1], 9))
    assert len(phases) == 5


@pytest.mark.parametrize("kwargs, words", [
    (dict(traffic_lanes=2, traffic_spacing=0.4), ["traffic_spacing", "obstacle_length"]),
    (dict(traffic_lanes=2, traffic_lane_width=0.2), ["traffic_lane_width", "obstacle_width"]),
    (dict(traffic_lanes=2, traffic_speed=6.0), ["traffic_speed", "max_obstacle_speed"]),
    (dict(traffic_lanes=2, randomize={"traffic_spacing": [0.3, 1.5]}), ["traffic_spacing"]),
])
def test_bad_traffic_settings_are_refused_by_name(kwargs, words):
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepCrossing-v0", **kwargs)
    assert all(w in str(exc.value) for w in words), str(exc.value)


# ------------------------------------------------------------------ gymnasium's checker
@pytest.mark.parametrize("env_id, kwargs", [
    ("FootstepDoor-v0", TWO_DOORS),
    ("FootstepCrossing-v0", TRAFFIC),
    ("FootstepDoor-v0", {"tier": "structure"}),
    ("FootstepCrossing-v0", {"tier": "structure"}),
    ("FootstepCrossing-v0", {"tier": "noise"}),
    ("FootstepCrowd-v0", {"tier": "shifted"}),
    (footstep_gym.MIX_ENV_ID, {"tier": "structure"}),
])
def test_gymnasiums_env_checker_passes(env_id, kwargs):
    env = gym.make(env_id, **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the observation box's infinite bounds (the env's docstring)
        check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", ["FootstepDoor-v0", "FootstepCrossing-v0"])
def test_a_pickled_tier_env_goes_on_as_the_original(env_id):
    """Tier envs (their cells, the second door, the traffic's schedule) survive pickling mid-episode."""
    import pickle

    env = gym.make(env_id, tier="structure")
    env.reset(seed=21)
    for _ in range(3):
        env.step(NOMINAL)
    twin = pickle.loads(pickle.dumps(env))
    assert twin.unwrapped.tier_cell == env.unwrapped.tier_cell
    for _ in range(4):
        a, b = env.step(NOMINAL), twin.step(NOMINAL)
        assert a[0].tobytes() == b[0].tobytes() and a[1:4] == b[1:4]
        if a[2] or a[3]:
            break
    assert episode(env, 5) == episode(twin, 5)


# ------------------------------------------------------------------ cells by rules
def _shifted_base(scene: str) -> dict:
    (cell,) = tiers.cells(scene, "train")
    return tiers.plain(cell.kwargs)


def test_each_cell_is_what_its_tiers_rule_makes_of_its_entry():
    """Recomputed here from the file's entries with the header's arithmetic, independently of tiers.derive_cell."""
    data = benchmark()
    noise = data[data["noise"]["rule"]["profile"]]
    band = data["shifted"]["rule"]["band"]
    for scene in SCENES:
        assert [c.kwargs for c in tiers.cells(scene, "paper")] == [{}]
        train = _shifted_base(scene)
        for name, entry in data["shifted"][scene].items():
            want = copy.deepcopy(train)
            for key, direction in entry["shift"].items():
                lo, hi = train["randomize"][key]
                width = band * (hi - lo)
                want["randomize"][key] = [hi, hi + width] if direction == "up" else [lo - width, lo]
            got = tiers.plain(tiers.cells(scene, "shifted", name)[0].kwargs)
            assert got.keys() == want.keys() and got["randomize"].keys() == want["randomize"].keys()
            for key in want["randomize"]:
                assert got["randomize"][key] == pytest.approx(want["randomize"][key]), (scene, name, key)
        for name, entry in data["structure"][scene].items():
            want = {**copy.deepcopy(train), **{k: v for k, v in entry["set"].items() if k != "randomize"}}
            want["randomize"] = {**train["randomize"], **entry["set"].get("randomize", {})}
            assert tiers.plain(tiers.cells(scene, "structure", name)[0].kwargs) == want, (scene, name)
            assert entry["change"] in tiers.cells(scene, "structure", name)[0].rule
        for name, entry in data["noise"][scene].items():
            tier, cell = entry["base"].split("/")
            want = {**tiers.plain(tiers.cells(scene, tier, cell)[0].kwargs), **noise}
            assert tiers.plain(tiers.cells(scene, "noise", name)[0].kwargs) == want, (scene, name)
    # the shift tier moves every range of the train tier, each by one cell, unless the rule says why it dropped it
    dropped = data["shifted"]["rule"].get("dropped", {})
    for scene in SCENES:
        shifted = {k for e in data["shifted"][scene].values() for k in e["shift"]}
        gone = {k.split("/")[1] for k in dropped if k.startswith(scene + "/")}
        assert shifted | gone == set(_shifted_base(scene)["randomize"]) and not shifted & gone, scene
    assert all("oracle" in why or "null" in why for why in dropped.values())


def test_next_band_is_the_band_just_beyond_the_range():
    assert tiers.next_band(5.0, 20.0, 0.25, "up") == [20.0, 23.75]
    assert tiers.next_band(1.5, 1.7, 0.25, "down") == [1.45, 1.5]
    assert tiers.next_band(0.12, 0.22, 1.0, "up") == [0.22, 0.32]


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["shifted"].pop("rule"), ["shifted.rule", "missing"]),
    (lambda d: d["shifted"].update(rule={"kind": "guess"}), ["kind", "structure", "noise"]),
    (lambda d: d["shifted"]["rule"].update(band=2.0), ["band", "(0, 1]"]),
    (lambda d: d["shifted"]["rule"].update(base="noise"), ["'noise'", "no tier above"]),
    (lambda d: d["shifted"]["door"]["fast"].update(shift={"door_radius": "up"}), ["door_radius", "door_speed"]),
    (lambda d: d["shifted"]["door"]["fast"].update(shift={"door_speed": "sideways"}), ["sideways", "up", "down"]),
    (lambda d: d["shifted"]["rule"].pop("dropped"), ["traffic_speed", "shift"]),
    (lambda d: d["shifted"]["rule"]["dropped"].update({"door/door_speed": "x"}), ["door_speed", "dropped"]),
    (lambda d: d["shifted"]["rule"].update(dropped={"crossing/traffic_speed": ""}), ["dropped", "reason"]),
    (lambda d: d["shifted"]["door"]["fast"].update(randomize={"door_speed": [20.0, 30.0]}), ["exactly", "shift"]),
    (lambda d: d["structure"]["door"]["any_phase"]["set"].update(randomize={"door_speed": [8.0, 9.0]}),
     ["door_speed", "draws"]),
    (lambda d: d["structure"]["door"]["any_phase"].update(change=""), ["change", "words"]),
    (lambda d: d["noise"]["door"]["train"].update(base="structure/three_doors"), ["three_doors", "two_doors"]),
    (lambda d: d["noise"]["rule"].update(profile="x-quiet"), ["profile", "x-quiet"]),
    (lambda d: d["x-noise"].update(sensing_range=1.0), ["sensing_range", "sensing key"]),
    (lambda d: d["paper"]["door"].update(default={"door_speed": 9.0}), ["paper", "sets nothing"]),
    (lambda d: d["train"]["crowd"]["train"].pop("randomize"), ["distribution", "randomize"]),
])
def test_a_broken_rule_is_refused_when_the_file_is_read(tmp_path, monkeypatch, edit, words):
    _with_benchmark(tmp_path, monkeypatch, edit)
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepCrowd-v0", tier="paper")
    assert all(w in str(exc.value) for w in words), str(exc.value)


# ------------------------------------------------------------------ the null rule
#: Validation seeds per cell and null baseline: a few (the calibration's 30 are in docs/benchmark.md).
NULL_SEEDS = 4


def _ruled_cells():
    from footstep_gym.evaluation.benchmark import benchmark_cells
    from footstep_gym.evaluation.calibration import EXEMPT_TIERS

    return [c for c in benchmark_cells() if c.tier not in EXEMPT_TIERS]


@pytest.mark.parametrize("cell", _ruled_cells(), ids=lambda c: c.label)
def test_no_null_baseline_solves_a_cell_outside_the_paper_tier(cell):
    """Every null baseline on the cell's first validation seeds: the best succeeds in at most 0.1 of them."""
    from footstep_gym.evaluation import calibration

    scores = calibration.score([cell], calibration.null_policies(), NULL_SEEDS, progress=False)
    assert len(scores) == len(calibration.null_policies()) >= 11
    best = calibration.best_null(scores)[cell.label]
    assert best.rate <= calibration.NULL_MAX, (best.policy, best.successes)
    assert not calibration.broken(scores)


def test_the_null_rule_sees_a_trivial_cell():
    """The check can fail: on the paper's crossing (exempt, a timed car) a blind walker reaches the goal."""
    from footstep_gym.evaluation import calibration
    from footstep_gym.evaluation.benchmark import benchmark_cells

    (paper,) = benchmark_cells(["crossing"], ["paper"])
    scores = calibration.score([paper], ["null-walk-2cm-0.4s", "null-stand"], 2, progress=False)
    assert calibration.best_null(scores)[paper.label].rate == 1.0
    assert calibration.broken(scores) == []  # exempt
    as_train = dataclasses.replace(scores[0], cell=dataclasses.replace(paper, tier="train"))
    assert calibration.broken([as_train]) and "null-walk-2cm-0.4s" in calibration.broken([as_train])[0]


# ------------------------------------------------------------------ the crossing's stream with a moving gap
STREAM = dict(traffic_lanes=1, traffic_spacing=0.9, traffic_extent=3.0, traffic_gap=1.6, traffic_speed=0.25)


def test_a_stream_has_one_gap_per_loop_and_its_phase_moves_it():
    env = gym.make("FootstepCrossing-v0", **STREAM)
    per_lane = math.ceil(2 * 3.0 / 0.9)
    loop = (per_lane - 1) * 0.9 + 1.6
    where = set()
    for seed in range(6):
        env.reset(seed=seed)
        ys = sorted(c.position[1] for c in moving(env))
        assert len(ys) == per_lane
        gaps = np.diff(ys + [ys[0] + loop])  # around the loop
        assert sorted(gaps) == pytest.approx([0.9] * (per_lane - 1) + [1.6])
        where.add(round(float(ys[int(np.argmax(gaps))]), 6))
    assert len(where) == 6  # the gap is somewhere else every episode


def test_a_gap_no_longer_than_a_car_is_refused():
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepCrossing-v0", **{**STREAM, "traffic_gap": 0.4})
    assert "traffic_gap" in str(exc.value) and "obstacle_length" in str(exc.value)


# ------------------------------------------------------------------ splits and the protocol's version
def test_protocol_3_has_a_fresh_test_split_and_the_earlier_test_seeds_in_validation():
    from footstep_gym.evaluation import benchmark, splits

    assert splits.PROTOCOL_VERSION == benchmark.PROTOCOL_VERSION == 3
    lo, hi = splits.SPLITS["validation"]
    # protocol 1's test seeds (20000-29999) and protocol 2's run ones (30000-30099) were looked at: validation now
    assert lo <= 20000 and hi >= 30100
    t0, t1 = splits.SPLITS["test"]
    assert t0 >= hi and t1 > t0
    assert benchmark.seeds(3, "test", release=True) == [t0, t0 + 1, t0 + 2]
    assert benchmark.seeds(3) == [lo, lo + 1, lo + 2]  # a run without --release is a development run
    with pytest.raises(Exception, match="release"):
        benchmark.seeds(3, "test")


def test_a_trainer_on_any_tier_takes_train_seeds():
    from footstep_gym.evaluation import splits

    stream = splits.train_seed_stream(9998)
    first, end = splits.SPLITS["train"]
    assert [next(stream) for _ in range(3)] == [first + 9998, first + 9999, first]
    env = gym.make("FootstepCrossing-v0", tier="noise")
    _, info = env.reset(seed=next(splits.train_seed_stream()))
    assert info["tier_cell"] in ("train", "wide_cars")
    with pytest.raises(ValueError, match="train split"):
        next(splits.train_seed_stream(end))


# ------------------------------------------------------------------ the env knows nothing of the tiers
def test_env_py_imports_nothing_of_the_benchmark_layer():
    """footstep_gym/env.py (and the mix) import neither the tiers nor the evaluation (read from their source)."""
    import ast

    for module in ("env", "mix", "env_config"):
        tree = ast.parse((ROOT / "footstep_gym" / f"{module}.py").read_text(encoding="utf-8"))
        imported = set()
        for node in tree.body:  # module-level imports only (the mix builds a tier's scene envs lazily)
            if isinstance(node, ast.ImportFrom):
                imported |= {node.module or ""} | {f"{node.module}.{a.name}" for a in node.names}
            elif isinstance(node, ast.Import):
                imported |= {a.name for a in node.names}
        bad = sorted(m for m in imported if m.startswith(("footstep_gym.tiers", "footstep_gym.evaluation")))
        assert not bad, (module, bad)


@pytest.fixture
def broken_tiers(tmp_path, monkeypatch):
    """A copy of configs/ whose benchmark.yaml is not YAML, as FOOTSTEP_GYM_CONFIG_DIR."""
    folder = tmp_path / "configs"
    shutil.copytree(config_dir(), folder)
    (folder / tiers.TIERS_FILE).write_text("paper: [door: {\n  about: nope\n", encoding="utf-8")
    monkeypatch.setenv("FOOTSTEP_GYM_CONFIG_DIR", str(folder))
    return folder / tiers.TIERS_FILE


@pytest.mark.parametrize("env_id", [*footstep_gym.ENV_IDS.values(), footstep_gym.MIX_ENV_ID])
def test_an_env_without_a_tier_never_reads_the_tiers_file(broken_tiers, env_id):
    env = gym.make(env_id, tier=None)
    obs, info = env.reset(seed=0)
    assert "tier_cell" not in info and env.unwrapped.tier is None
    env.step(np.asarray(NOMINAL, dtype=np.float32))
    env.close()
    with pytest.raises(ConfigError) as exc:
        gym.make(env_id, tier="train")
    text = str(exc.value)
    assert text.startswith(f"{broken_tiers}: the benchmark tiers' file is not valid YAML (line ") and "\n" not in text


def test_the_env_takes_plain_cells_and_a_label():
    """The class itself: cells of env keywords and the label they came under, no tiers' file; a tier without its
    cells, or keywords beside the cells, is refused in one line."""
    from footstep_gym.env import FootstepEnv

    env = FootstepEnv("door", cells={"slow": {"door_speed": 8.0}, "fast": {"door_speed": 16.0}}, tier="mine")
    drawn = {env.reset(seed=s)[1]["tier_cell"] for s in range(12)}
    assert drawn == {"slow", "fast"} and env.tier == "mine"
    assert env.episode_config.door_speed == {"slow": 8.0, "fast": 16.0}[env.tier_cell]
    with pytest.raises(ConfigError, match="tier='train' names the cells given with it"):
        FootstepEnv("door", tier="train")
    with pytest.raises(ConfigError, match="give the keywords 'max_steps' inside each of the cells"):
        FootstepEnv("door", cells={"a": {}}, max_steps=5)
    made = gym.make("FootstepDoor-v0", tier="train").unwrapped
    assert made.cells == tiers.env_kwargs("door", "train")["cells"] and made.tier == "train"
