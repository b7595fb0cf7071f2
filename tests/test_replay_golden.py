"""Seeded episodes replay bit for bit against a trace recorded before the env's step was sped up.

``tests/data/replay_golden.json`` holds, for each env, seeds and commands (near-nominal walks
and random commands), a digest of each step's observation, reward, flags and every value of
``info`` (exact: JSON floats are ``repr``, which round-trips) beside a few values in clear
(reward, time, CoM, termination, scene) to show where a trace departs. It was recorded with

    PYTHONPATH=. python tests/test_replay_golden.py --record

before the speed-ups of the env's step (issue 10 §1), and recorded again when ``info``
gained ``clearance`` and ``zmp_margin`` (checked first: without those two keys the env
replayed the old trace exactly); the test replays the same episodes and requires every
value to be identical. Floating-point results may differ on another
CPU/libm or another numpy/pymunk version; the file records the versions it was made with,
and the test is skipped (saying so) where they differ.
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import footstep_gym  # noqa: F401

GOLDEN = Path(__file__).resolve().parent / "data" / "replay_golden.json"
ENV_IDS = ("FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0", "FootstepMix-v0")
SEEDS = (0, 7)
STEPS = 40
SETTINGS = {"FootstepDoor-v0": {"randomize": {"door_speed": [8.0, 30.0]}}}  # + per-episode draws


def versions() -> dict[str, str]:
    """What the bits depend on besides our code."""
    return {"python": platform.python_version(), "machine": platform.machine(), "numpy": np.__version__,
            "pymunk": metadata.version("pymunk"), "gymnasium": metadata.version("gymnasium")}


def commands(kind: str, seed: int, low: np.ndarray, high: np.ndarray) -> list[list[float]]:
    """``STEPS`` commands: a near-nominal walk (float64) or uniform in the box (float32 values)."""
    rng = np.random.default_rng(1000 + seed)
    if kind == "walk":
        return [[rng.uniform(0.0, 0.06), rng.uniform(0.075, 0.09), rng.uniform(-0.05, 0.05),
                 rng.uniform(0.45, 0.6), rng.uniform(0.15, 0.25)] for _ in range(STEPS)]
    return [[float(v) for v in rng.uniform(low, high).astype(np.float32)] for _ in range(STEPS)]


def plain(x: Any) -> Any:
    """JSON-able copy with floats kept exact (ints, bools, None and strings as they are)."""
    if isinstance(x, dict):
        return {str(k): plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return [float(v) for v in x.ravel()]
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x


def summary(step: dict[str, Any]) -> dict[str, Any]:
    """One step as stored: a digest of all of it, and a few of its values in clear."""
    info = step["info"]
    blob = json.dumps(step, sort_keys=True).encode()
    return {"digest": hashlib.sha256(blob).hexdigest()[:20], "reward": step.get("reward"),
            "time": info.get("time"), "com": info.get("com"), "termination": info.get("termination"),
            "feasible": info.get("feasible"), "scene": info.get("scene")}


def trace(env_id: str, seed: int, kind: str) -> dict[str, Any]:
    env = gym.make(env_id, **SETTINGS.get(env_id, {}))
    low, high = env.unwrapped.robot.command_low, env.unwrapped.robot.command_high
    acts = commands(kind, seed, low, high)
    obs, info = env.reset(seed=seed)
    steps = [{"obs": plain(obs), "info": plain(info)}]
    for a in acts:
        action = np.array(a, dtype=np.float32 if kind == "random" else np.float64)
        obs, reward, terminated, truncated, info = env.step(action)
        steps.append({"obs": plain(obs), "reward": reward, "terminated": terminated, "truncated": truncated,
                      "info": plain(info)})
        if terminated or truncated:
            obs, info = env.reset()
            steps.append({"obs": plain(obs), "info": plain(info)})
    env.close()
    return {"env_id": env_id, "seed": seed, "kind": kind, "steps": [summary(json.loads(json.dumps(st))) for st in steps]}


def cases() -> list[tuple[str, int, str]]:
    return [(e, s, k) for e in ENV_IDS for s in SEEDS for k in ("walk", "random")]


def record() -> None:
    GOLDEN.parent.mkdir(parents=True, exist_ok=True)
    data = {"versions": versions(), "traces": [trace(*c) for c in cases()]}
    GOLDEN.write_text(json.dumps(data, separators=(",", ":")) + "\n", encoding="utf-8")
    print(f"wrote {GOLDEN} ({GOLDEN.stat().st_size / 1024:.0f} KiB)")


def first_difference(a: Any, b: Any, path: str = "") -> str | None:
    """Where two traces differ, bit for bit (NaN equal to NaN), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        if list(a) != list(b):
            return f"{path}: keys {list(a)} != {list(b)}"
        for k in a:
            d = first_difference(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{path}: length {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_difference(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    if type(a) is not type(b):
        return f"{path}: {a!r} ({type(a).__name__}) != {b!r} ({type(b).__name__})"
    if isinstance(a, float) and not (a == b or (math.isnan(a) and math.isnan(b))):
        return f"{path}: {a!r} != {b!r}"
    if not isinstance(a, float) and a != b:
        return f"{path}: {a!r} != {b!r}"
    return None


@pytest.fixture(scope="module")
def golden() -> dict[str, Any]:
    data = json.loads(GOLDEN.read_text(encoding="utf-8"))
    if data["versions"] != versions():
        pytest.skip(f"golden trace recorded with {data['versions']}, running {versions()}")
    return data


@pytest.mark.parametrize("env_id, seed, kind", cases())
def test_seeded_episodes_replay_the_golden_trace_bit_for_bit(golden, env_id, seed, kind):
    (expected,) = [t for t in golden["traces"] if (t["env_id"], t["seed"], t["kind"]) == (env_id, seed, kind)]
    got = json.loads(json.dumps(trace(env_id, seed, kind)))
    assert len(got["steps"]) > STEPS
    for i, (a, b) in enumerate(zip(expected["steps"], got["steps"])):
        clear = first_difference({k: v for k, v in a.items() if k != "digest"},
                                 {k: v for k, v in b.items() if k != "digest"}, f"steps[{i}]")
        assert clear is None, clear
        assert a["digest"] == b["digest"], f"steps[{i}]: an observation or info value differs (digest)"
    assert len(expected["steps"]) == len(got["steps"])


def test_golden_traces_cover_walks_episode_ends_and_every_scene(golden):
    ends = {s["termination"] for t in golden["traces"] for s in t["steps"] if s["reward"] is not None}
    assert {"fall", "collision", None} <= ends
    scenes = {s["scene"] for t in golden["traces"] for s in t["steps"]} - {None}
    assert scenes == {"door", "crossing", "crowd"}
    walked = [sum(1 for s in t["steps"] if s["feasible"])
              for t in golden["traces"] if t["kind"] == "walk"]
    assert min(walked) >= 5 and sum(walked) > 300


if __name__ == "__main__":
    if sys.argv[1:] == ["--record"]:
        record()
    else:
        raise SystemExit("usage: python tests/test_replay_golden.py --record")
