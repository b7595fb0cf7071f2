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
