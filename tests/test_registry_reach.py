"""A scenario registered once reaches every list the evaluation keeps: the quick evaluation's scenes, the benchmark's
cells and its config hash, a benchmark run and the leaderboard built from it.

The toy scenario of ``test_scenarios_registry`` (its YAML in ``tmp_path``) is registered in this process and taken
out again by the fixture; the runs use one worker, this process, which is where it is registered.
"""

from __future__ import annotations

import json

import gymnasium as gym
import pytest

from footstep_gym.evaluation import benchmark, leaderboard, profiles
from footstep_gym.scenarios import SCENARIOS, register_scenario, unregister_scenario
from script_helpers import load_script
from test_scenarios_registry import TOY_ID, toy_class

PLANNER = "fixed-period"


@pytest.fixture
def toy(tmp_path):
    before = benchmark.env_configs_sha256()
    cls = toy_class(tmp_path)
    register_scenario("toy", cls)
    yield cls
    unregister_scenario("toy")
    assert "toy" not in SCENARIOS and TOY_ID not in gym.registry
    assert benchmark.env_configs_sha256() == before  # unregistered: the release's hash again


def test_the_quick_evaluation_runs_every_registered_scene(toy, tmp_path):
    assert profiles.PROFILES["quick"].envs == ("door", "crossing", "crowd", "toy")
    assert profiles.PROFILES["paper"].envs == ("door", "crossing", "crowd")  # the paper's protocol stays its own
    script = load_script("eval_planner")
    settings = script.parse_settings(["--policy", PLANNER, "--episodes", "1", "--out", str(tmp_path / "q")])
    assert settings.profile == "quick" and settings.envs[-1] == "toy"
    cells = profiles.make_cells(settings)
    assert [c.scenario for c in cells][-1] == "toy" and cells[-1].env_id == TOY_ID
    # The quick run itself, cut to the toy and one other scene to keep it short.
    out = tmp_path / "quick"
    assert script.main(["--env", "toy", "--env", "crossing", "--policy", PLANNER, "--episodes", "1",
                        "--workers", "1", "--out", str(out)]) == 0
    records = json.loads((out / "results.json").read_text())
    assert [r["scenario"] for r in records] == ["toy", "crossing"]
    assert (out / "figures" / "toy.png").is_file()


def test_the_config_hash_covers_a_registered_scenarios_yaml(toy):
    files = benchmark.env_config_files()
    assert files[-1] == toy.config_file and files[:-1] == [*benchmark.BASE_CONFIGS, "scenarios/door.yaml",
                                                           "scenarios/crossing.yaml", "scenarios/crowd.yaml"]
    first = benchmark.env_configs_sha256()
    path = toy.config_file
    with open(path, encoding="utf-8") as f:
        text = f.read()
    with open(path, "w", encoding="utf-8") as f:
        f.write(text.replace("toy_radius: 0.1", "toy_radius: 0.12"))
    assert benchmark.env_configs_sha256() != first  # the toy's YAML is part of the protocol


def test_a_benchmark_run_and_its_leaderboard_include_the_scenario(toy, tmp_path):
    cells = benchmark.benchmark_cells()
    assert [c.label for c in cells if c.scene == "toy"] == ["toy/paper/default"]  # the default tier covers it
    out = tmp_path / "bench"
    script = load_script("eval_planner")
    assert script.main(["--benchmark", "--policy", PLANNER, "--env", "toy", "--episodes", "2", "--workers", "1",
                        "--out", str(out)]) == 0
    doc = json.loads((out / "benchmark.json").read_text())
    assert doc["protocol"]["scenes"] == ["toy"] and doc["protocol"]["env_configs_sha256"] == \
        benchmark.env_configs_sha256()
    assert [(r["scene"], r["tier"], r["cell"], r["episodes"]) for r in doc["records"]] == [
        ("toy", "paper", "default", 2)]
    board = leaderboard.leaderboard([out], reps=50)
    assert board["scenes"] == ["toy"] and board["tier_cells"] == {"paper": ["toy/default"]}
    row = leaderboard.scene_markdown(board).splitlines()[2]
    assert [c.strip() for c in row.split("|")[1:4]] == ["paper", "toy", "1"]
