"""baselines/soak.py: a tiny run end to end (its summary), and its checks catching a broken env.

The soak itself (10^5-10^6 steps per env) is a command, not a test; here it runs 2,000
steps per env in a subprocess and its JSON is checked for the counts a fuzz must
produce. A deliberately broken env shows that each kind of fault is reported.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "baselines" / "soak.py"
sys.path.insert(0, str(SCRIPT.parent))

import soak  # noqa: E402

STEPS = 2000
ENV_IDS = ("FootstepDoor-v0", "FootstepMix-v0")  # the mix runs the three scenes


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("soak")
    proc = subprocess.run([sys.executable, str(SCRIPT), "--steps", str(STEPS), "--envs", ",".join(ENV_IDS),
                           "--out", str(out)], capture_output=True, text=True, timeout=1800, cwd=str(ROOT))
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    data = json.loads((out / "soak.json").read_text())
    partial = {e: json.loads((out / "partial" / f"{e}.json").read_text()) for e in ENV_IDS}
    return data, (out / "soak.md").read_text(), proc.stderr, partial


def test_tiny_soak_passes_every_env(tiny):
    data, md, stderr, partial = tiny
    assert data["passed"] is True
    assert [r["env_id"] for r in data["envs"]] == list(ENV_IDS)
    assert data["meta"]["steps_per_env"] == STEPS
    for r in data["envs"]:
        assert r["passed"] and r["steps"] == STEPS
        assert r["unexpected_errors"] == {} and r["check_failures"] == {}
        assert r["steps_per_s"] > 0 and r["wall_s"] > 0
        assert r["episodes"] > 20
        # The fuzz reached every kind of input it promises.
        assert r["expected_errors"]["ActionError"] > 50       # bad actions
        assert r["expected_errors"]["ResetNeeded"] > 3        # steps after the end
        assert r["outcomes"]["clipped"] > 10                  # commands outside the box
        assert r["outcomes"]["fall"] > 10
        assert r["outcomes"]["style_walk"] > 5 and r["outcomes"]["style_fuzz"] > 5
        assert r["outcomes"].get("env_remade", 0) >= 1 or r["episodes"] < soak.REMAKE_EVERY_EPISODES
        # Memory figures from /proc.
        rss = r["rss"]
        for key in ("start", "middle", "end", "peak"):
            assert isinstance(rss[key], int) and rss[key] > 10 * 2**20, key
        assert rss["start_step"] <= rss["middle_step"] <= STEPS
        assert len(rss["samples"]) >= 10
        assert r["rss_flat"] is True and abs(r["rss_growth"]) < 2**30
    long_episodes = sum(r["outcomes"].get(k, 0) for r in data["envs"] for k in ("goal", "collision", "truncated"))
    assert long_episodes > 0
    for env_id in ENV_IDS:
        assert env_id in md and env_id in stderr  # the table, and the progress bars
    assert "PASS" in md and "FAIL" not in md
    # The figures so far, written while it ran, end close to the final ones.
    for r in data["envs"]:
        p = partial[r["env_id"]]
        assert p["partial"] is True and p["passed"] is True
        assert 0.9 * STEPS <= p["steps"] <= STEPS and p["episodes"] <= r["episodes"]


class Broken(gym.Wrapper):
    """Every 7th step: a NaN in the observation; every 11th: a RuntimeError; bad actions accepted."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.calls = 0

    def step(self, action):
        self.calls += 1
        if self.calls % 11 == 0:
            raise RuntimeError("boom")
        try:
            obs, reward, terminated, truncated, info = self.env.step(action)
        except gym.error.ResetNeeded:
            raise
        except ValueError:  # the broken env takes bad actions silently
            obs, reward, terminated, truncated, info = self.env.step(np.array([0.0, 0.08, 0.0, 0.6, 0.2]))
        if self.calls % 7 == 0:
            obs = obs.copy()
            obs[0] = np.nan
        return obs, reward, terminated, truncated, info


def test_soak_reports_every_kind_of_fault():
    def make(rng):
        return Broken(gym.make("FootstepCrossing-v0")), {}

    res = soak.verdict(soak.soak_env("FootstepCrossing-v0", 400, seed=0, make=make, progress=False), 16.0)
    assert not res["passed"]
    assert res["unexpected_errors"]["RuntimeError"] >= 20
    assert "boom" in res["unexpected_examples"]["RuntimeError"][0]
    assert res["check_failures"]["non-finite observation"] >= 20
    assert res["check_failures"]["bad action accepted"] >= 5


def test_soak_rss_verdict():
    base = {"unexpected_errors": {}, "check_failures": {}}
    flat = soak.verdict({**base, "rss": {"start": 100 << 20, "end": 101 << 20, "peak": 102 << 20}}, 16.0)
    assert flat["rss_flat"] and flat["passed"] and flat["rss_growth"] == 1 << 20
    leak = soak.verdict({**base, "rss": {"start": 100 << 20, "end": 130 << 20, "peak": 130 << 20}}, 16.0)
    assert leak["rss_flat"] is False and not leak["passed"]


def test_random_randomize_stays_within_the_bounds():
    from footstep_gym.scenarios import SCENARIOS

    rng = np.random.default_rng(0)
    seen = set()
    for _ in range(200):
        for scene, cls in SCENARIOS.items():
            spec = soak.random_randomize(scene, rng)
            cfg = cls.load_config()
            for key, max_key in cls.Config.upper_bounds().items():
                if key in spec:
                    assert spec[key][1] <= getattr(cfg, max_key)
            seen.update(f"{scene}.{k}" for k in spec)
            cls.load_config({"randomize": spec})  # accepted
    assert {"door.door_speed", "crossing.obstacle_speed", "crowd.crowd_speed"} <= seen


def test_fuzzed_actions_are_what_they_claim():
    rng = np.random.default_rng(1)
    env = gym.make("FootstepDoor-v0").unwrapped
    low, high = env.robot.command_low, env.robot.command_high
    for kind in ("inside", "bounds", "outside", "walk", "list", "bad"):
        for _ in range(100):
            action, clipped = soak.fuzz_action(kind, low, high, rng)
            if kind == "bad":
                assert clipped is None
                continue
            a = np.asarray(action, dtype=np.float64)
            assert a.shape == (5,) and np.all(np.isfinite(a))
            command, was_clipped = env._validate_action(action)
            command = np.asarray(command)
            assert was_clipped is clipped, (kind, action)
            assert not math.isnan(command.sum())
