"""baselines/soak.py: a tiny run end to end (its summary), and its engine (speedlib.soak) catching a
broken env.

The soak itself (10^5-10^6 steps per env) is a command, not a test; here it runs 2,000
steps per env in a subprocess and its JSON is checked for the counts a fuzz must
produce. A deliberately broken env shows that each kind of fault is reported, and an env
that keeps memory at every reset that the soak fails it (exit status 1, saying why).
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

from speedlib import soak

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "baselines" / "soak.py"

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
        # ONE env instance for the whole run (a fresh env every few hundred episodes hid a leak tied to it).
        assert r["instances"] == 1 and r["remake_every"] == 0 and "env_remade" not in r["outcomes"]
        # Memory figures from /proc: the current RSS after the warm-up, sampled over the run, at the end; the peak.
        rss = r["rss"]
        for key in ("start", "middle", "end", "peak"):
            assert isinstance(rss[key], int) and rss[key] > 10 * 2**20, key
        assert rss["start_step"] <= rss["middle_step"] <= STEPS
        assert len(rss["samples"]) >= 10
        steps_sampled = [n for n, _ in rss["samples"]]
        assert steps_sampled == sorted(set(steps_sampled)) and steps_sampled[-1] == STEPS
        assert all(isinstance(v, int) and v > 10 * 2**20 for _, v in rss["samples"])
        assert rss["samples"][-1][1] == rss["end"] and isinstance(rss["slope"], float)
        assert r["rss_flat"] is True and r["rss_growth"] <= soak.DEFAULT_RSS_TOLERANCE_MIB * 2**20
        assert r["failures"] == []
    long_episodes = sum(r["outcomes"].get(k, 0) for r in data["envs"] for k in ("goal", "collision", "truncated"))
    assert long_episodes > 0
    for env_id in ENV_IDS:
        assert env_id in md and env_id in stderr  # the table, and the progress bars
    assert "PASS" in md and "FAIL" not in md
    assert "current RSS [MiB] at steps" in md and "One env instance" in md
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
    base = {"unexpected_errors": {}, "check_failures": {}, "steps": 1000, "instances": 1}
    flat = soak.verdict({**base, "rss": {"start": 100 << 20, "end": 101 << 20, "peak": 102 << 20}}, 16.0)
    assert flat["rss_flat"] and flat["passed"] and flat["rss_growth"] == 1 << 20 and flat["failures"] == []
    leak = soak.verdict({**base, "rss": {"start": 100 << 20, "start_step": 100, "end": 130 << 20,
                                         "peak": 130 << 20}}, 16.0)
    assert leak["rss_flat"] is False and not leak["passed"]
    assert "RSS grew 30.0 MiB after the warm-up" in leak["failures"][0] and "16 MiB" in leak["failures"][0]
    # The end back within the tolerance, the peak not: still a failure, said so.
    spike = soak.verdict({**base, "rss": {"start": 100 << 20, "end": 101 << 20, "peak": 130 << 20}}, 16.0)
    assert not spike["passed"] and "peak RSS" in spike["failures"][0]
    # The default tolerance is small: a leak of 10 B per step over 10^6 steps fails it.
    default = soak.verdict({**base, "rss": {"start": 100 << 20, "end": (100 << 20) + 10 * 900_000,
                                            "peak": (100 << 20) + 10 * 900_000}}, soak.DEFAULT_RSS_TOLERANCE_MIB)
    assert not default["passed"]


def test_soak_fails_an_env_that_keeps_memory(tmp_path):
    """The whole command, on an env that keeps 64 KiB at every reset: status 1, and why, on stderr."""
    proc = subprocess.run([sys.executable, str(SCRIPT), "--steps", "1000", "--envs", "FootstepCrowd-v0",
                           "--out", str(tmp_path), "--no-progress", "--_inject-leak-kib", "64"],
                          capture_output=True, text=True, timeout=600, cwd=str(ROOT))
    assert proc.returncode == 1, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "FootstepCrowd-v0: FAIL: RSS grew" in proc.stderr and "--rss-tolerance-mib=8 MiB" in proc.stderr
    data = json.loads((tmp_path / "soak.json").read_text())
    (r,) = data["envs"]
    assert data["passed"] is False and r["rss_flat"] is False and r["instances"] == 1
    assert r["unexpected_errors"] == {} and r["check_failures"] == {}  # the memory alone failed it
    assert r["rss_growth"] > 8 * 2**20 and r["rss"]["slope"] > 5000
    assert "**FootstepCrowd-v0 FAIL**: RSS grew" in (tmp_path / "soak.md").read_text()


def test_soak_remake_every_makes_fresh_envs():
    res = soak.soak_env("FootstepCrossing-v0", 300, seed=0, progress=False, remake_every=3)
    assert res["remake_every"] == 3 and res["instances"] >= 5
    assert res["outcomes"]["env_remade"] == res["instances"] - 1
    assert soak.verdict(res, soak.DEFAULT_RSS_TOLERANCE_MIB)["passed"]


@pytest.mark.parametrize("bad, said", [(["--rss-tolerance-mib", "-1"], "--rss-tolerance-mib"),
                                       (["--rss-tolerance-mib", "nan"], "--rss-tolerance-mib"),
                                       (["--remake-every", "-2"], "--remake-every"), (["--steps", "0"], "--steps"),
                                       (["--envs", "FootstepMoon-v0"], "unknown env id(s) ['FootstepMoon-v0']")])
def test_soak_rejects_bad_options(bad, said, tmp_path):
    proc = subprocess.run([sys.executable, str(SCRIPT), *bad, "--out", str(tmp_path)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode != 0 and said in proc.stderr
    assert not (tmp_path / "soak.json").exists()


def test_random_randomize_draws_from_the_scenarios_fuzz_ranges():
    """The soak's ``randomize=`` settings come from ``Scenario.fuzz_ranges()`` (the YAML's ``fuzz:`` section): every
    key it sets is one of them, in their order, its ``[a, b]`` inside the range; accepted by the config."""
    from footstep_gym.scenarios import SCENARIOS

    rng = np.random.default_rng(0)
    seen = set()
    for _ in range(200):
        for scene, cls in SCENARIOS.items():
            ranges = cls.fuzz_ranges()
            spec = soak.random_randomize(scene, rng)
            assert list(spec) == [k for k in ranges if k in spec]  # in the ranges' order
            for key, (a, b) in spec.items():
                lo, hi = ranges[key]
                assert lo <= a <= b <= hi, (scene, key)
            cfg = cls.load_config()
            for key, max_key in cls.Config.upper_bounds().items():
                if key in spec:
                    assert spec[key][1] <= getattr(cfg, max_key)
            seen.update(f"{scene}.{k}" for k in spec)
            cls.load_config({"randomize": spec})  # accepted
    assert {"door.door_speed", "crossing.obstacle_speed", "crowd.crowd_speed"} <= seen
    assert seen == {f"{scene}.{k}" for scene, cls in SCENARIOS.items() for k in cls.fuzz_ranges()}


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


def test_soak_ends_when_the_env_cannot_be_made():
    """A config that breaks mid-run (e.g. a YAML key the running code does not know) fails the soak, not hangs it."""
    calls = []

    def make(rng):
        calls.append(1)
        if len(calls) > 1:
            raise ValueError("configs/env.yaml: unknown key(s) 'new_key'")
        return Broken(gym.make("FootstepCrossing-v0")), {}  # its 11th step raises: the soak makes a fresh env

    res = soak.verdict(soak.soak_env("FootstepCrossing-v0", 400, seed=0, make=make, progress=False), 16.0)
    assert not res["passed"] and res["steps"] == 11 and len(calls) == 1 + soak.MAX_MAKE_FAILURES
    assert "attempts in a row to make the env failed" in res["aborted"] and "new_key" in res["aborted"]
    assert res["failures"][0].startswith("aborted at step 11")
    assert res["unexpected_errors"] == {"RuntimeError": 1, "ValueError": soak.MAX_MAKE_FAILURES}
