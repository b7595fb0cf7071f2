"""Seeded episodes replay against a recorded trace.

``tests/data/replay_golden.json`` holds, for each env, seeds and commands (near-nominal walks
and random commands), a digest of each step's observation, reward, flags and every value of
``info`` (exact: JSON floats are ``repr``, which round-trips) beside a few values in clear
(reward, time, CoM, termination, scene) to show where a trace departs, and the versions it was
recorded with (:func:`versions`). It is recorded with

    PYTHONPATH=. python tests/test_replay_golden.py --record

on the versions that ``constraints.txt`` pins (and the Python CI runs), and only when the env is
meant to change what it does; the tests replay the same episodes.

**What is exact, and where.** The env's step computes its floats with libm (``math``, ``cmath``,
Chipmunk's C) and IEEE arithmetic, not with numpy's run-time-dispatched SIMD kernels (it replays the
trace bit for bit with any of numpy's CPU-feature levels disabled, ``NPY_DISABLE_CPU_FEATURES``). So
on any CPU, :func:`test_seeded_episodes_replay_the_golden_trace` requires every discrete value (when
episodes end and how, feasibility, scene) to be the recorded one, and the floats in clear to be within
a few ulps; :func:`test_seeded_episodes_replay_the_golden_trace_bit_for_bit` requires every value, bit
for bit, where libm rounds as it did on the recording machine (:data:`LIBM_PROBES`; glibc takes
another code path on a CPU without FMA, and other libm versions may round otherwise) and says why it is
skipped elsewhere. The first runs under any versions of Python, numpy, pymunk and gymnasium: a library
update that changes the episodes beyond a few ulps fails it (re-record only when the change is meant).
The second also needs the versions the file records, and skips (saying which differ) under others,
except under CI (``CI`` set, as ``.ci/run`` does), which installs them from ``constraints.txt``: there a
difference fails, so a lock that drifts from the recording cannot turn the test into a skip.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
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

#: libm's results (``float.hex``) on the machine that recorded the trace, at arguments where glibc's code
#: paths for CPUs with and without FMA round differently (as each does at one argument in 1,000 to 4,000):
#: where this machine's libm gives other bits, the episodes' floats may differ in their last bits too.
LIBM_PROBES = (
    ("exp", ("0x1.95ab2b5c0a276p+2",), "0x1.1afe6d01f9c91p+9"),
    ("exp", ("-0x1.17dc4effea86cp+2",), "0x1.9d6346f54606dp-7"),
    ("expm1", ("0x1.817d8b71f8f30p-2",), "0x1.d414d15f88312p-2"),
    ("expm1", ("0x1.248a67b0586d0p-2",), "0x1.529bbb45760a9p-2"),
    ("sin", ("-0x1.f274451749460p-2",), "-0x1.df0066d286a68p-2"),
    ("sin", ("0x1.7c9c140502e24p+1",), "0x1.569bbeae3741ap-3"),
    ("cos", ("0x1.039fe3513fee0p+1",), "-0x1.c45391c561503p-2"),
    ("cos", ("0x1.86167c2010b90p+0",), "0x1.8102d24b39be7p-5"),
    ("asin", ("-0x1.707aa32005684p-2",), "-0x1.78ef0e63fdd3bp-2"),
    ("atan2", ("-0x1.d6209da8d0420p-4", "0x1.1d7eec1244e94p+0"), "-0x1.a413d71669b52p-4"),
)
#: Where libm rounds otherwise, the floats in clear within 8 ulps of their scale: CoM [m] (|x| < 4 m), time [s]
#: (< 32 s), reward (its progress term is 10 per metre times a difference of two distances < 4 m). Measured with
#: glibc's code path for CPUs without FMA: CoM 4.4e-16 m (2 ulps), time identical, reward 4.4e-15.
CLEAR_ATOL = {"com": 8 * math.ulp(4.0), "time": 8 * math.ulp(32.0), "reward": 2 * 10.0 * 8 * math.ulp(4.0)}
#: Values in clear compared exactly on any CPU.
DISCRETE = ("termination", "feasible", "scene")


def libm_as_recorded() -> list[str]:
    """The probes of :data:`LIBM_PROBES` this machine's libm rounds otherwise (empty: as recorded)."""
    return [f"{name}({', '.join(args)})" for name, args, want in LIBM_PROBES
            if getattr(math, name)(*(float.fromhex(a) for a in args)).hex() != want]


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
    return json.loads(GOLDEN.read_text(encoding="utf-8"))


def version_differences(recorded: dict[str, str]) -> list[str]:
    """What differs between the versions the trace was recorded with and this interpreter's (empty: none)."""
    here = versions()
    return [f"{k} {recorded.get(k)} (recorded) != {here.get(k)}" for k in sorted(set(recorded) | set(here))
            if recorded.get(k) != here.get(k)]


def replay(golden: dict[str, Any], env_id: str, seed: int, kind: str) -> tuple[list[dict], list[dict]]:
    (expected,) = [t for t in golden["traces"] if (t["env_id"], t["seed"], t["kind"]) == (env_id, seed, kind)]
    got = json.loads(json.dumps(trace(env_id, seed, kind)))
    assert len(got["steps"]) > STEPS
    return expected["steps"], got["steps"]


@pytest.mark.parametrize("env_id, seed, kind", cases())
def test_seeded_episodes_replay_the_golden_trace(golden, env_id, seed, kind):
    """On any CPU: the discrete values exactly (steps, episode ends and restarts, termination, feasibility,
    scene), the reward, time and CoM within :data:`CLEAR_ATOL`."""
    expected, got = replay(golden, env_id, seed, kind)
    assert len(expected) == len(got)
    for i, (a, b) in enumerate(zip(expected, got)):
        assert [a[k] for k in DISCRETE] == [b[k] for k in DISCRETE], f"steps[{i}]: {a} != {b}"
        assert (a["reward"] is None) == (b["reward"] is None) and (a["com"] is None) == (b["com"] is None), i
        for key, atol in CLEAR_ATOL.items():
            if a[key] is not None:
                np.testing.assert_allclose(b[key], a[key], rtol=0, atol=atol, err_msg=f"steps[{i}].{key}")


@pytest.mark.parametrize("env_id, seed, kind", cases())
def test_seeded_episodes_replay_the_golden_trace_bit_for_bit(golden, env_id, seed, kind):
    """Every observation, reward, flag and ``info`` value bit for bit: where libm rounds as on the recording
    machine (the env's floats come from libm and IEEE arithmetic; numpy's SIMD kernels do not enter), with the
    versions it was recorded with (under CI, which installs them from ``constraints.txt``, a difference fails)."""
    other = version_differences(golden["versions"])
    if other:
        why = f"the golden trace was recorded with other versions: {'; '.join(other)}"
        if os.environ.get("CI"):
            pytest.fail(f"{why}. CI installs from constraints.txt, which must pin what the trace was recorded "
                        "with: re-record the trace on the locked versions (see this file's docstring) or fix the lock")
        pytest.skip(why + " (the floats may differ in their last bits; compared to a few ulps by "
                    "test_seeded_episodes_replay_the_golden_trace)")
    differs = libm_as_recorded()
    if differs:
        pytest.skip(f"libm rounds {len(differs)} of {len(LIBM_PROBES)} probes otherwise than on the recording "
                    f"machine (e.g. {differs[0]}): the floats may differ in their last bits here (compared to a "
                    "few ulps by test_seeded_episodes_replay_the_golden_trace)")
    expected, got = replay(golden, env_id, seed, kind)
    for i, (a, b) in enumerate(zip(expected, got)):
        clear = first_difference({k: v for k, v in a.items() if k != "digest"},
                                 {k: v for k, v in b.items() if k != "digest"}, f"steps[{i}]")
        assert clear is None, clear
        assert a["digest"] == b["digest"], f"steps[{i}]: an observation or info value differs (digest)"
    assert len(expected) == len(got)


@pytest.mark.parametrize("ci", ["", "true"])
def test_other_versions_skip_only_the_bit_for_bit_replay_and_fail_it_under_ci(golden, monkeypatch, ci):
    """Under other versions than recorded the cross-CPU replay still runs (and passes on these episodes), while
    the bit-for-bit one skips, naming the difference, or fails under CI."""
    recorded = golden["versions"]
    monkeypatch.setitem(globals(), "versions", lambda: {**recorded, "numpy": "0.0.0"})
    if ci:
        monkeypatch.setenv("CI", ci)
    else:
        monkeypatch.delenv("CI", raising=False)
    case = cases()[0]
    test_seeded_episodes_replay_the_golden_trace(golden, *case)
    outcome = pytest.fail.Exception if ci else pytest.skip.Exception
    with pytest.raises(outcome, match=rf"numpy {recorded['numpy']} \(recorded\) != 0\.0\.0"):
        test_seeded_episodes_replay_the_golden_trace_bit_for_bit(golden, *case)


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
