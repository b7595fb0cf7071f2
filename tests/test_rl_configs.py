"""The zoo hyperparameter files of configs/rl/ that must agree with each other."""

from __future__ import annotations

import copy

import yaml

from footstep_gym.config import config_dir


def _load(name: str) -> dict:
    with open(config_dir() / "rl" / name, encoding="utf-8") as fh:
        return yaml.load(fh, Loader=yaml.UnsafeLoader)  # the zoo's own loader: !!float tags


def test_ppo_fixed_period_is_ppo_with_the_period_fixed():
    """The period ablation for agents: same budgets, hyperparameters and ranges; only fixed_period differs."""
    ppo, fixed = _load("ppo.yml"), _load("ppo-fixed-period.yml")
    scenes = [k for k in ppo if k.startswith("Footstep") and k != "FootstepMix-v0"]
    assert sorted(k for k in fixed if k.startswith("Footstep")) == sorted(scenes)
    for env_id in scenes:
        entry = copy.deepcopy(fixed[env_id])
        assert entry["env_kwargs"].pop("fixed_period") is True, env_id
        assert entry == ppo[env_id], env_id


def test_ppo_wide_is_ppo_on_wider_ranges():
    """ppo-wide: ppo's hyperparameters; each scene's ranges contain the train tier's and reach the shifted tier's."""
    from footstep_gym import tiers

    ppo, wide = _load("ppo.yml"), _load("ppo-wide.yml")
    scenes = {"FootstepDoor-v0": "door", "FootstepCrossing-v0": "crossing", "FootstepCrowd-v0": "crowd"}
    assert sorted(k for k in wide if k.startswith("Footstep")) == sorted(scenes)
    for env_id, scene in scenes.items():
        entry, base = copy.deepcopy(wide[env_id]), copy.deepcopy(ppo[env_id])
        kwargs, base_kwargs = entry.pop("env_kwargs"), base.pop("env_kwargs")
        entry.pop("n_timesteps"), base.pop("n_timesteps")
        assert entry == base, env_id
        ranges = kwargs["randomize"]
        for key, (lo, hi) in base_kwargs["randomize"].items():
            assert ranges[key][0] <= lo and ranges[key][1] >= hi, (env_id, key)
        assert {k: v for k, v in kwargs.items() if k != "randomize" and k in base_kwargs} == \
            {k: v for k, v in base_kwargs.items() if k != "randomize"}, env_id  # the stream's layout is train's
        for cell in tiers.cells(scene, "shifted"):
            for key, value in tiers.plain(cell.kwargs).get("randomize", {}).items():
                assert ranges[key][0] <= value[0] and ranges[key][1] >= value[1], (env_id, cell.name, key)


def test_ppo_noisy_and_ppo_lstm_are_ppo_on_the_noisy_scenes():
    """ppo-noisy: ppo's hyperparameters on each scene's train range sensed with the noise tier's profile (its
    "train" cell's); ppo-lstm: the same with an LSTM policy and, where ppo-noisy's budget is larger (the crossing's
    stream), at most as many steps (an LSTM step costs about 3x an MLP's); nothing else changed."""
    from footstep_gym import tiers

    scenes = {"FootstepDoor-v0": "door", "FootstepCrossing-v0": "crossing", "FootstepCrowd-v0": "crowd"}
    noisy_file, lstm_file, ppo_file = _load("ppo-noisy.yml"), _load("ppo-lstm.yml"), _load("ppo.yml")
    for data in (noisy_file, lstm_file):
        assert sorted(k for k in data if k.startswith("Footstep")) == sorted(scenes)
    for env_id, scene in scenes.items():
        ppo, noisy, lstm = ppo_file[env_id], copy.deepcopy(noisy_file[env_id]), copy.deepcopy(lstm_file[env_id])
        (cell,) = tiers.cells(scene, "noise", "train")
        noise = {k: v for k, v in tiers.plain(cell.kwargs).items() if k.startswith("sensing_")}
        assert noise and {k: v for k, v in noisy["env_kwargs"].items() if k.startswith("sensing_")} == noise, env_id
        assert {k: v for k, v in noisy["env_kwargs"].items() if not k.startswith("sensing_")} == ppo["env_kwargs"], \
            env_id
        strip = ("env_kwargs", "n_timesteps")
        assert {k: v for k, v in noisy.items() if k not in strip} == {k: v for k, v in ppo.items() if k not in strip}
        assert lstm.pop("policy") == "MlpLstmPolicy" and noisy.pop("policy") == "MlpPolicy"
        assert lstm.pop("policy_kwargs").replace(", lstm_hidden_size=64, enable_critic_lstm=True", "") == \
            noisy.pop("policy_kwargs")
        assert float(lstm.pop("n_timesteps")) <= float(noisy.pop("n_timesteps")), env_id
        assert lstm == noisy, env_id


def test_the_in_distribution_configs_are_their_generalisation_twins_on_a_tier():
    """ppo-structure and ppo-noise: ppo's hyperparameters; ppo-lstm-noise: ppo-lstm's; each trains on every cell of
    its tier (``env_kwargs: {tier: T}``, T the tier its registered agent is tested on) of every scene."""
    from footstep_gym.rl.registry import AGENTS

    scenes = ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"]
    for name, twin in (("ppo-structure", "ppo.yml"), ("ppo-noise", "ppo.yml"), ("ppo-lstm-noise", "ppo-lstm.yml")):
        entry = AGENTS[name]
        data, base = _load(f"{entry.config}.yml"), _load(twin)
        assert entry.tier in ("structure", "noise") and entry.eval_freq == -1
        assert sorted(k for k in data if k.startswith("Footstep")) == sorted(scenes), name
        for env_id in scenes:
            mine, theirs = copy.deepcopy(data[env_id]), copy.deepcopy(base[env_id])
            assert mine.pop("env_kwargs") == {"tier": entry.tier}, (name, env_id)
            theirs.pop("env_kwargs"), mine.pop("n_timesteps"), theirs.pop("n_timesteps")
            assert mine == theirs, (name, env_id)
