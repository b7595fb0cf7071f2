"""The compute protocol for learned rows (footstep_gym/rl/compute.py, configs/compute.yaml) and the matched
hyperparameters of SB3 PPO and ppo-jax (footstep_gym/rl/matched.py).

The convergence rule is checked on hand-made curves and against a second formulation (every pair of the last three
points within the tolerance, in episodes); a row's training against tiny shipped-run folders; the matched config
against configs/rl/ppo.yml's values read directly, and the action map against Gymnasium's ``RescaleAction``.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from footstep_gym.errors import ConfigError
from footstep_gym.rl import compute


# ---------------------------------------------------------------- the rule
@pytest.mark.parametrize("episodes, wins", [(40, 4), (20, 3), (100, 5), (1, 1), (10, 2)])
def test_the_tolerance_is_the_worst_case_binomial_std_rounded_up_to_whole_episodes(episodes, wins):
    assert compute.plateau_tolerance(episodes) == wins / episodes
    # not below one point's noise at p = 0.5, and less than one episode above it
    assert wins / episodes >= math.sqrt(0.25 / episodes) > (wins - 1) / episodes


@pytest.mark.parametrize("curve, expected", [
    ([0.0, 0.5, 0.9, 0.95, 0.975], True),      # 36, 38, 39 of 40: a spread of 3 episodes
    ([0.0, 0.8, 0.9, 1.0], False),             # 32 .. 40: still rising by 8 episodes
    ([1.0, 1.0, 1.0], True),
    ([0.5, 0.6, 0.5], True),                   # 20, 24, 20: 4 episodes, the tolerance itself
    ([0.5, 0.625, 0.5], False),                # 20, 25, 20: 5 episodes
    ([0.9, 0.9], False),                       # two points show no plateau
    ([], False),
])
def test_plateaued_on_hand_made_curves_of_40_episodes(curve, expected):
    assert compute.plateaued(curve, 40) is expected


def test_plateaued_agrees_with_every_pair_within_the_tolerance():
    rng = np.random.default_rng(0)
    for episodes in (20, 40):
        tol = round(compute.plateau_tolerance(episodes) * episodes)
        for _ in range(300):
            wins = rng.integers(0, episodes + 1, size=rng.integers(3, 7))
            last = wins[-3:]
            pairs = all(abs(int(a) - int(b)) <= tol for a, b in itertools.combinations(last, 2))
            assert compute.plateaued([w / episodes for w in wins], episodes) is pairs


@pytest.mark.parametrize("curve, episodes", [([0.5, 0.33, 0.5], 40), ([1.2, 1.0, 1.0], 20), ([-0.05], 20)])
def test_a_rate_that_is_no_whole_number_of_episodes_is_refused(curve, episodes):
    with pytest.raises(ValueError, match="whole number of"):
        compute.plateaued(curve, episodes)


def test_bad_episodes_or_window_are_refused():
    with pytest.raises(ValueError, match="episodes"):
        compute.plateau_tolerance(0)
    with pytest.raises(ValueError, match="window"):
        compute.plateaued([1.0, 1.0], 20, window=1)
    assert compute.converged_count([[1.0, 1.0, 1.0], [0.0, 0.5, 1.0]], [20, 20]) == 1


# ---------------------------------------------------------------- the declared protocol
def test_the_shipped_protocol_declares_2e7_per_track():
    proto = compute.load_protocol()
    assert proto.budget_env_steps == {"generalisation": 20_000_000, "structure": 20_000_000, "noise": 20_000_000}
    assert proto.budget() == proto.budget("noise") == 20_000_000 and proto.budget("paper") is None
    assert (proto.window, proto.validation_episodes) == (3, 40)


@pytest.mark.parametrize("change, message", [
    ({"budget_env_steps": {"generalisation": 1, "structure": 1}}, "budget_env_steps must map exactly"),
    ({"budget_env_steps": {"generalisation": 0, "structure": 1, "noise": 1}}, "budget_env_steps.generalisation"),
    ({"convergence": {"window": 1, "validation_episodes": 40}}, "convergence.window"),
    ({"convergence": {"window": 3}}, "convergence must hold"),
])
def test_a_bad_protocol_file_names_its_key(tmp_path, change, message):
    data = {"budget_env_steps": {"generalisation": 5, "structure": 5, "noise": 5},
            "convergence": {"window": 3, "validation_episodes": 40}, **change}
    path = tmp_path / "compute.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=message):
        compute.load_protocol(path)


# ---------------------------------------------------------------- shipped runs
def shipped(root: Path, agent: str, name: str, timesteps: int | None, curve: list[float] | None,
            episodes: int = 40, cpu: float | None = None) -> Path:
    run = root / agent / name
    run.mkdir(parents=True)
    manifest = {"env_id": name.rsplit("_", 1)[0], "wall_time_s": 100.0, "cpu_time_s": cpu}
    if timesteps is not None:
        manifest["timesteps"] = timesteps
    (run / "manifest.json").write_text(json.dumps(manifest))
    if curve is not None:
        rows = [f"{i * 1000},{i:.1f},{s:.4f},{episodes}" for i, s in enumerate(curve)]
        (run / "validation.csv").write_text("timesteps,wall_time_s,success_rate,episodes\n" + "\n".join(rows) + "\n")
    return run


def test_a_rows_training_from_its_shipped_runs(tmp_path):
    agents = tmp_path / "agents"
    flat = shipped(agents, "ppo-x", "FootstepDoor-v0_1", 600_000, [0.2, 0.9, 0.925, 0.95], cpu=10.0)
    rising = shipped(agents, "ppo-x", "FootstepDoor-v0_2", 600_000, [0.2, 0.5, 0.8], cpu=20.0)
    shipped(agents, "ppo-x", "FootstepCrowd-v0_1", 300_000, None, cpu=5.0)
    st = compute.run_status(flat)
    assert (st["timesteps"], st["points"], st["episodes"], st["curve"], st["converged"]) == (
        600_000, 4, 40, "validation", True)
    assert compute.run_status(rising)["converged"] is False
    # the benchmark file names runs by the path of the machine that evaluated them
    runs = ["/elsewhere/baselines/agents/ppo-x/FootstepDoor-v0_1", "/elsewhere/baselines/agents/ppo-x/FootstepDoor-v0_2",
            "/elsewhere/baselines/agents/ppo-x/FootstepCrowd-v0_1", "/elsewhere/baselines/agents/ppo-x/FootstepCrowd-v0_9"]
    row = compute.row_training(runs, agents, 20_000_000)
    assert row["runs"] == 3 and row["missing_runs"] == [runs[3]]
    assert row["env_steps_per_run"] == [300_000, 600_000] and row["at_budget"] is False
    assert (row["converged"], row["with_curve"], row["cpu_time_s"], row["median_wall_time_s"]) == (1, 2, 35.0, 100.0)
    assert compute.training_text(row) == "3e5-6e5 steps/run (below 2e7), 1/2 converged (1 without a curve)"
    assert compute.row_training(runs[:1], agents, 600_000)["at_budget"] is True
    assert compute.training_text(compute.row_training(runs[:1], agents, 600_000)) == \
        "6e5 steps/run (at budget), 1/1 converged"


def test_a_manifest_without_steps_or_cpu_time_says_unknown(tmp_path):
    agents = tmp_path / "agents"
    shipped(agents, "old", "FootstepDoor-v0_1", None, [1.0, 1.0, 1.0], episodes=20)
    row = compute.row_training([agents / "old" / "FootstepDoor-v0_1"], agents, 20_000_000)
    assert row["env_steps_per_run"] == [] and row["unknown_steps"] == 1 and row["at_budget"] is None
    assert row["cpu_time_s"] is None
    assert compute.training_text(row) == "unknown steps/run, 1/1 converged"
    assert compute.training_text(None) == "unknown"
    with pytest.raises(FileNotFoundError, match="manifest.json"):
        compute.run_status(tmp_path)


def test_a_zoo_evaluation_curve_counts_its_own_episodes(tmp_path):
    run = shipped(tmp_path, "sac", "FootstepDoor-v0_1", 100_000, None)
    np.savez(run / "evaluations.npz", timesteps=np.array([1, 2, 3]), results=np.zeros((3, 5)),
             ep_lengths=np.ones((3, 5)), successes=np.array([[1, 1, 0, 0, 0], [1, 1, 1, 1, 0], [1, 1, 1, 1, 1.0]]))
    assert compute.run_curve(run) == ([0.4, 0.8, 1.0], 5, "zoo evaluation")
    assert compute.run_status(run)["converged"] is False  # 2, 4, 5 of 5: tolerance ceil(0.5 sqrt 5) = 2 episodes


# ---------------------------------------------------------------- matched hyperparameters
def test_the_matched_jax_config_has_sb3_ppos_values():
    from footstep_gym.config import config_dir
    from footstep_gym.rl import matched

    entry = yaml.safe_load((config_dir() / "rl" / "ppo.yml").read_text())["FootstepDoor-v0"]
    sb3 = matched.sb3_hyperparameters("FootstepDoor-v0")
    assert (sb3["n_envs"], sb3["n_steps"], sb3["batch_size"], sb3["n_epochs"]) == (
        entry["n_envs"], entry["n_steps"], entry["batch_size"], entry["n_epochs"])
    assert sb3["n_timesteps"] == int(entry["n_timesteps"]) and sb3["norm_obs"] and not sb3["norm_reward"]
    total, every = matched.schedule(sb3, sb3["n_timesteps"], 13)
    assert (total, every) == (614_400, 51_200)  # 300 updates of 4 x 512 steps, a validation every 25
    cfg = matched.matched_jax_config(sb3, "FootstepDoor-v0", {"tier": "train"}, sb3["n_timesteps"], 13, 40)
    assert cfg.num_envs == entry["n_envs"]
    assert cfg.steps_per_update == entry["n_envs"] * entry["n_steps"]          # one rollout per update
    assert cfg.batch_size * cfg.unroll_length == entry["batch_size"]          # the minibatch's transitions
    assert cfg.num_updates_per_batch == entry["n_epochs"]
    assert (cfg.learning_rate, cfg.discounting, cfg.gae_lambda, cfg.clipping_epsilon, cfg.entropy_cost) == (
        entry["learning_rate"], entry["gamma"], entry["gae_lambda"], entry["clip_range"], entry["ent_coef"])
    assert cfg.policy_hidden_layer_sizes == cfg.value_hidden_layer_sizes == (64, 64) and cfg.activation == "tanh"
    assert cfg.init_noise_std == pytest.approx(math.exp(-0.5)) and cfg.normalize_observations
    assert cfg.vf_loss_coefficient == 1.0 and cfg.max_grad_norm == 0.5       # SB3's vf_coef 0.5 x MSE, its default
    from footstep_gym.rl.ppo_jax import planned

    assert planned(cfg).num_timesteps == total and planned(cfg).num_evals == 13
    with pytest.raises(ValueError, match="unroll_length"):
        matched.matched_jax_config(sb3, "FootstepDoor-v0", {}, 4096, 3, 4, unroll_length=48)
    with pytest.raises(ValueError, match="validation points"):
        matched.schedule(sb3, 4096, 1)


def test_the_sb3_action_map_is_gymnasiums_rescale_action():
    import gymnasium as gym

    from footstep_gym.rl import matched
    from footstep_gym.rl.sb3_jax import FootstepSB3VecEnv

    venv = FootstepSB3VecEnv(2, "door", tier="train")
    sent = []
    venv.step_async = sent.append  # what the wrapper hands on
    wrapped = matched.rescaled_vec_env(venv)
    assert wrapped.action_space == gym.spaces.Box(-1.0, 1.0, (5,), np.float32)
    actions = np.random.default_rng(1).uniform(-1.5, 1.5, (2, 5)).astype(np.float32)
    wrapped.step_async(actions)
    ref = gym.wrappers.RescaleAction(gym.make("FootstepDoor-v0"), np.full(5, -1.0, np.float32),
                                     np.full(5, 1.0, np.float32))
    expected = np.stack([ref.action(np.clip(a, -1.0, 1.0)) for a in actions])
    np.testing.assert_array_equal(sent[0], expected)
    assert sent[0].dtype == expected.dtype == np.float32


# ---------------------------------------------------------------- what a run records
def test_ppo_jax_configs_may_drop_the_entropy_bonus_and_set_the_value_weight():
    from footstep_gym.rl import ppo_jax

    entry = yaml.safe_load(ppo_jax.default_config_path().read_text())["FootstepDoor-v0"]
    assert ppo_jax.parse_config(entry, "FootstepDoor-v0").vf_loss_coefficient == 0.5  # Brax's default, left out
    cfg = ppo_jax.parse_config({**entry, "entropy_cost": 0.0, "vf_loss_coefficient": 1.0}, "FootstepDoor-v0")
    assert (cfg.entropy_cost, cfg.vf_loss_coefficient) == (0.0, 1.0)
    for key in ("vf_loss_coefficient", "learning_rate"):
        with pytest.raises(ConfigError, match=f"{key} must be a number > 0"):
            ppo_jax.parse_config({**entry, key: 0.0}, "FootstepDoor-v0")
    with pytest.raises(ConfigError, match="entropy_cost must be a number >= 0"):
        ppo_jax.parse_config({**entry, "entropy_cost": -1e-3}, "FootstepDoor-v0")


def test_shipping_records_the_cpu_time_and_machine_train_measured(tmp_path):
    import os

    from test_agents import fake_run

    from footstep_gym.rl import training

    hw = training.hardware()
    assert hw["logical_cpus"] == os.cpu_count() and hw["machine"] and hw["system"]
    run = fake_run(tmp_path / "runs", 600_000, 1.0)
    (run / training.COST_FILE).write_text(json.dumps({"wall_time_s": 10.0, "cpu_time_s": 17.5, "hardware": hw}))
    dest = training.ship(run, tmp_path / "agents", 10.0)
    manifest = json.loads((dest / "manifest.json").read_text())
    assert manifest["cpu_time_s"] == 17.5 and manifest["hardware"] == hw and (dest / training.COST_FILE).is_file()
    older = training.ship(fake_run(tmp_path / "runs2", 600_000, 1.0, seed=2), tmp_path / "agents", 10.0)
    manifest = json.loads((older / "manifest.json").read_text())
    assert manifest["cpu_time_s"] is None and manifest["hardware"] is None  # not measured: unknown, not invented


def test_train_measures_the_childs_cpu_time():
    import subprocess
    import sys

    from footstep_gym.rl import training

    before = training._children_cpu_s()
    subprocess.run([sys.executable, "-c", "sum(i * i for i in range(3_000_000))"], check=True)
    assert training._children_cpu_s() - before > 0.05


def test_sb3_ppo_on_the_jax_scene_is_validated_after_whole_updates():
    """A tiny SB3 run (2 envs, 32 steps each per update): its points at 0, after 1 and after 2 updates, each the
    validation episodes' success in the reference env."""
    from footstep_gym.rl import matched

    sb3 = {**matched.sb3_hyperparameters("FootstepDoor-v0"), "n_envs": 2, "n_steps": 32, "batch_size": 32,
           "n_epochs": 1}
    seen = []
    model, curve = matched.train_sb3(sb3, "FootstepDoor-v0", {"tier": "train"}, 1, 100, 3, [10_000],
                                     progress=seen.append)
    assert [p[0] for p in curve] == [0, 64, 128] and seen == curve
    assert all(p[2] in (0.0, 1.0) for p in curve) and all(p[1] >= 0 and p[3] >= 0 for p in curve)
    assert model.n_envs == 2 and model.action_space.high.tolist() == [1.0] * 5


def _record(trainer: str, seed: int, successes: list[float], complete: bool = True) -> dict:
    return {"trainer": trainer, "env_id": "FootstepDoor-v0", "env_kwargs": {"tier": "train"}, "seed": seed,
            "episodes": 40, "complete": complete, "hyperparameters": {},
            "machine": {"python": "3.11.7", "machine": "x86_64", "logical_cpus": 2, "load_average_start": 1.0 + seed,
                        "load_average_end": 3.0 * seed},
            "curve": [[i * 51_200, 10.0 * i, s, 5.0 * i] for i, s in enumerate(successes)]}


def test_the_comparison_report_from_curve_files(tmp_path, capsys):
    from script_helpers import load_script

    runs = tmp_path / "runs"
    runs.mkdir()
    for rec in (_record("sb3", 1, [0.0, 0.5, 0.9, 0.925, 0.95]), _record("sb3", 2, [0.0, 0.25], complete=False),
                _record("jax", 1, [0.0, 0.75, 1.0, 1.0, 1.0]), _record("jax", 2, [0.0, 0.5, 0.8, 0.95, 1.0])):
        (runs / f"{rec['trainer']}_FootstepDoor-v0_{rec['seed']}.json").write_text(json.dumps(rec))
    script = load_script("sb3_vs_jax")
    assert script.main(["--report", "--runs-dir", str(runs), "--results", str(tmp_path / "out")]) == 0
    data = json.loads((tmp_path / "out" / "sb3_vs_jax_door.json").read_text())
    sb3, jax_ = data["summary"]["SB3 PPO"], data["summary"]["ppo-jax (Brax PPO)"]
    assert sb3["reached_steps"] == [204_800, 51_200] and sb3["plateaued"] == [True, False]
    assert sb3["mean_success"] == [0.0, 0.375, 0.9, 0.925, 0.95] and sb3["seeds_per_point"] == [2, 2, 1, 1, 1]
    assert jax_["steps_to_0.9"] == [102_400, 153_600] and jax_["cpu_s_to_0.9"] == [10.0, 15.0]
    md = (tmp_path / "out" / "sb3_vs_jax_door.md").read_text()
    assert "**Partial**" in md and "SB3 PPO seed 2 (51,200 env steps)" in md
    assert "| 102,400 | 0.900 (1) | 0.900 (2) |" in md
    assert "2-core machine whose load average was 2-6 during these runs" in md  # the runs' own load averages
    png = (tmp_path / "out" / "sb3_vs_jax_door.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and int.from_bytes(png[16:20], "big") <= 900
    with pytest.raises(SystemExit):
        script.main(["--report", "--trainer", "sb3"])
    assert "one of --trainer or --report" in capsys.readouterr().err
    before = (runs / "sb3_FootstepDoor-v0_1.json").read_text()
    with pytest.raises(SystemExit, match="already there, not replaced"):  # refused before any training
        script.main(["--trainer", "sb3", "--seeds", "1", "--runs-dir", str(runs)])
    assert (runs / "sb3_FootstepDoor-v0_1.json").read_text() == before
