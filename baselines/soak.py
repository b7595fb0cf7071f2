"""Soak: millions of fuzzed steps per env, checking that nothing unexpected ever happens.

    python baselines/soak.py                      # 10^6 steps per env (1-5 minutes per env here)
    python baselines/soak.py --steps 100000       # 10^5 per env
    python baselines/soak.py --envs FootstepDoor-v0 --steps 20000 --out runs/soak-door
    python baselines/soak.py --remake-every 300   # a fresh env every 300 episodes (the old mode)

Each env runs in its own subprocess (so its memory figures are its own), with a tqdm
progress bar on stderr, and keeps **one env instance** for its whole run (made with random
``randomize=`` settings, reset at every episode's end), as a training run does: a leak
tied to the env instance (issue 17: pymunk kept every shape removed at reset) shows only
there. ``--remake-every N`` makes a fresh env every N episodes instead, the mode this
script used to run in, which hid that leak. Every ``env.step`` call counts as a step. The
fuzz, drawn from one seeded generator:

* three episodes in four are "fuzz" episodes: commands uniform **inside** the box, **at its
  bounds** (each field at its low or high end, or inside), **outside** it (finite; the env
  must clip and say so in ``info["clipped"]``), as float32 or float64 arrays or plain
  lists (these fall within a few steps); the others "walk" on near-nominal commands
  (long episodes that reach goals, collisions and truncations);
* **bad** commands (NaN / inf fields, wrong shapes, strings): each must raise
  ``ActionError`` and leave the episode as it was;
* ``step`` after the episode ended, without ``reset``: must raise ``ResetNeeded``;
* resets with random seeds (or none); the env is made with random ``randomize=``
  settings within the allowed ranges (speeds up to the scenario's ``max_*`` bounds), so its
  episodes draw their speeds and sizes from those ranges (with ``--remake-every``, each
  fresh env draws new ranges).

Checked after every step: the observation has the space's shape and dtype and is finite,
the reward is a finite float, the flags are bools, ``info``'s time, CoM and ZMP are finite
and ``info["clipped"]`` is what the command asks. Any other exception is counted by type
(and the env is made afresh: ``instances`` counts the envs made). Memory: the current RSS
(``/proc/self/statm``) after the warm-up (10 % of the steps: "start"), at the middle and at
the end, sampled ``RSS_SAMPLES`` times in between (``rss.samples``: ``[step, bytes]``, and their
least-squares slope in bytes per step), and the peak since the warm-up (``VmHWM``). "Flat"
means the end RSS, and the peak, exceed the start by at most ``--rss-tolerance-mib``
(default 8 MiB: over 10^6 steps a leak of ~10 B per step fails it; a leak-free env's RSS
rises 1-2 MiB after the warm-up, in one-off steps of the allocators, then stays put; the
leak of issue 17 grew it by 0.4-3.4 KB per step); an env whose RSS is not flat FAILs. If
the env cannot be made ``MAX_MAKE_FAILURES`` times in a row, the run ends there and fails.

Writes ``<out>/soak.json`` and ``<out>/soak.md`` (steps/s, outcomes, exceptions by type,
RSS figures); exits with status 1 if any env failed a check, saying which and why on stderr.
While it runs, each env's figures so far are in ``<out>/partial/<env id>.json`` (updated 20
times per env), so a run stopped early still says how far it got and what it saw.
"""

from __future__ import annotations

import argparse
import bisect
import json
import math
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import footstep_gym  # noqa: E402
from bench_utils import (RssPeak, finite_json, fmt_bytes, fmt_num, loadavg, machine_info, markdown_table,
                         rss_bytes)  # noqa: E402
from footstep_gym.errors import ActionError  # noqa: E402

ENV_IDS = (*footstep_gym.ENV_IDS.values(), footstep_gym.MIX_ENV_ID)
SCENE_OF = {v: k for k, v in footstep_gym.ENV_IDS.items()}
DEFAULT_STEPS = 1_000_000
DEFAULT_RSS_TOLERANCE_MIB = 8.0  # largest growth of the RSS after the warm-up still called flat (--rss-tolerance-mib)
WARMUP_FRACTION = 0.1  # RSS "start" is taken after this fraction of the steps
RSS_SAMPLES = 20  # current-RSS samples over the run (after the warm-up)
#: Episodes per env instance (--remake-every); 0: one instance for the whole run (unless an unexpected error).
DEFAULT_REMAKE_EVERY = 0
EXAMPLES_KEPT = 5  # tracebacks kept per unexpected exception type
MAX_MAKE_FAILURES = 20  # env makes failing in a row end the run (a broken config would otherwise loop for ever)
PROGRESS_EVERY = 500  # steps between progress-bar updates

#: Episode styles: "fuzz" draws every action's kind from FUZZ_KINDS (such episodes end in a fall within a few
#: steps); "walk" walks on near-nominal commands with a few bad ones (long episodes: goals, collisions, truncations).
EPISODE_STYLES = {"fuzz": 0.75, "walk": 0.25}
FUZZ_KINDS = {"inside": 0.3, "bounds": 0.2, "outside": 0.15, "walk": 0.1, "list": 0.1, "bad": 0.15}
WALK_KINDS = {"walk": 0.9, "bad": 0.1}
#: The near-nominal walk: each field uniform in its range (S, L, theta, T_SS, T_DS) [m, m, rad, s, s].
WALK_RANGES = ((0.0, 0.06), (0.075, 0.09), (-0.05, 0.05), (0.5, 0.6), (0.18, 0.22))
_WALK_LOW, _WALK_HIGH = (np.array(b) for b in zip(*WALK_RANGES))
P_STEP_AFTER_END = 0.1  # probability of stepping once more after an episode ended (must raise ResetNeeded)
P_UNSEEDED_RESET = 0.3
P_RANDOMIZE_KEY = 0.3  # each fuzzable key is randomized with this probability in a fresh env

#: randomize= ranges the soak draws from, per scene: [lo, hi] the user may pass. Keys with a
#: max_* bound (door_speed, ...) range from their low end here up to that bound, read from the config.
FUZZ_RANGES: dict[str, dict[str, tuple[float, float]]] = {
    "common": {"start_yaw": (-0.3, 0.3), "start_jitter": (0.0, 0.05), "goal_tolerance": (0.05, 0.3),
               "time_limit": (5.0, 60.0)},
    "door": {"door_speed": (0.0, math.inf), "door_radius": (0.3, 0.6), "door_start_angle": (0.0, 180.0),
             "door_angle_jitter": (0.0, 30.0)},
    "crossing": {"obstacle_speed": (0.01, math.inf), "arrival_speed": (0.02, math.inf), "crossing_x": (0.3, 2.0),
                 "timing_jitter": (0.0, 3.0), "obstacle_length": (0.3, 1.0), "obstacle_width": (0.1, 0.3)},
    "crowd": {"crowd_speed": (0.0, math.inf), "crowd_accel_time": (0.5, 8.0), "breathing_amplitude": (0.0, 0.1),
              "angle_jitter": (0.0, 20.0), "member_radius": (0.04, 0.12)},
}


def log(msg: str) -> None:
    print(f"[soak] {msg}", file=sys.stderr, flush=True)


# ------------------------------------------------------------------ the fuzz
def random_randomize(scene: str, rng: np.random.Generator) -> dict[str, list[float]]:
    """A random ``randomize=`` dict for ``scene``: each fuzzable key with probability P_RANDOMIZE_KEY."""
    from footstep_gym.scenarios import SCENARIOS

    cls = SCENARIOS[scene]
    cfg = cls.load_config()
    bounds = cls.Config.upper_bounds()
    out = {}
    for key, (lo, hi) in {**FUZZ_RANGES["common"], **FUZZ_RANGES[scene]}.items():
        if rng.random() >= P_RANDOMIZE_KEY:
            continue
        if key in bounds:
            hi = min(hi, getattr(cfg, bounds[key]))
        a, b = sorted(float(v) for v in rng.uniform(lo, hi, 2))
        out[key] = [a, b]
    return out


def make_fuzzed_env(env_id: str, rng: np.random.Generator) -> tuple[gym.Env, dict[str, Any]]:
    """``gym.make(env_id)`` with random ``randomize=`` settings; returns the env and its keyword arguments."""
    if env_id == footstep_gym.MIX_ENV_ID:
        kwargs: dict[str, Any] = {s: {"randomize": random_randomize(s, rng)} for s in footstep_gym.ENV_IDS}
    else:
        kwargs = {"randomize": random_randomize(SCENE_OF[env_id], rng)}
    return gym.make(env_id, **kwargs), kwargs


def fuzz_action(kind: str, low: np.ndarray, high: np.ndarray, rng: np.random.Generator) -> tuple[Any, bool | None]:
    """An action of ``kind`` and whether the env must report it clipped (``None``: unknown / bad)."""
    dtype = np.float32 if rng.random() < 0.5 else np.float64
    if kind == "inside":
        lo, hi = (low, high) if dtype == np.float64 else (low.astype(np.float32), high.astype(np.float32))
        return rng.uniform(lo, hi).astype(dtype), False
    if kind == "bounds":
        pick = rng.integers(0, 3, 5)  # 0: low end, 1: high end, 2: inside
        a = np.where(pick == 0, low, np.where(pick == 1, high, rng.uniform(low, high)))
        return a.astype(dtype), False
    if kind == "outside":
        span = high - low
        a = rng.uniform(low, high)
        out = rng.random(5) < 0.5
        out[rng.integers(5)] = True  # at least one field outside
        side = rng.choice([-1.0, 1.0], 5)
        beyond = np.where(side > 0, high, low) + side * span * 10.0 ** rng.uniform(-2, 3, 5)
        return np.where(out, beyond, a).astype(dtype), True
    if kind == "walk":
        a = rng.uniform(_WALK_LOW, _WALK_HIGH)
        return (a.astype(dtype) if rng.random() < 0.9 else [float(v) for v in a]), False
    if kind == "list":
        return [float(v) for v in rng.uniform(low, high)], False
    # bad
    choice = int(rng.integers(6))
    if choice == 0:
        a = rng.uniform(low, high).astype(dtype)
        a[rng.integers(5)] = rng.choice([np.nan, np.inf, -np.inf])
        return a, None
    if choice == 1:
        return rng.uniform(-1, 1, int(rng.choice([0, 1, 4, 6, 10]))).astype(dtype), None
    if choice == 2:
        return rng.uniform(low, high, (1, 5)).astype(dtype), None
    if choice == 3:
        return "fast", None
    if choice == 4:
        return None, None
    return [0.0, 0.08, "x", 0.6, 0.2], None


# ------------------------------------------------------------------ checks
def check_step(result: tuple, space: gym.spaces.Box, expect_clipped: bool | None) -> list[str]:
    """What is wrong with one step's ``(obs, reward, terminated, truncated, info)`` (empty: nothing)."""
    obs, reward, terminated, truncated, info = result
    bad = []
    if not isinstance(obs, np.ndarray) or obs.shape != space.shape or obs.dtype != space.dtype:
        bad.append("observation shape/dtype")
    elif not np.all(np.isfinite(obs)):
        bad.append("non-finite observation")
    if not isinstance(reward, float):
        bad.append("reward not a float")
    elif not math.isfinite(reward):
        bad.append("non-finite reward")
    if not isinstance(terminated, bool) or not isinstance(truncated, bool) or (terminated and truncated):
        bad.append("flags")
    values = [info.get("time"), *info.get("com", (math.nan,)), *info.get("com_vel", (math.nan,)),
              *info.get("zmp", (math.nan,)), *info.get("rewards", {}).values()]
    if not all(isinstance(v, float) and math.isfinite(v) for v in values):
        bad.append("non-finite info")
    if expect_clipped is not None and info.get("clipped") is not expect_clipped:
        bad.append(f"info['clipped'] is {info.get('clipped')} for a command {'outside' if expect_clipped else 'inside'} "
                   "the box")
    return bad


def _cumulative(weights: dict[str, float]) -> list[float]:
    """Cumulative weights, normalised to end at 1 (for :func:`_pick`)."""
    total, out = sum(weights.values()), []
    for w in weights.values():
        out.append((out[-1] if out else 0.0) + w / total)
    return out


def _pick(cumulative: list[float], rng: np.random.Generator) -> int:
    """An index drawn with the probabilities of ``cumulative`` (``rng.choice(n, p=...)`` costs ~20 us a call)."""
    return min(bisect.bisect_right(cumulative, rng.random()), len(cumulative) - 1)


class LeakyEnv(gym.Wrapper):
    """An env that keeps ``kib`` KiB more at every ``reset``: what ``--_inject-leak-kib`` soaks, to check that
    the RSS verdict catches a leak tied to the env instance."""

    def __init__(self, env: gym.Env, kib: float) -> None:
        super().__init__(env)
        self.kept: list[bytes] = []
        self.size = int(kib * 1024)

    def reset(self, **kwargs: Any) -> Any:
        self.kept.append(b"\x01" * self.size)  # written, so resident
        return self.env.reset(**kwargs)


class SoakAborted(RuntimeError):
    """The soak cannot go on (the env cannot be made); the run ends there and fails."""


def rss_slope(samples: list) -> float | None:
    """Least-squares slope [bytes per step] of ``[step, rss]`` samples (``None`` with fewer than 3)."""
    pts = [(n, r) for n, r in samples if r is not None]
    if len(pts) < 3 or len({n for n, _ in pts}) < 2:
        return None
    x, y = np.array(pts, dtype=float).T
    return float(np.polyfit(x, y, 1)[0])


# ------------------------------------------------------------------ one env
def soak_env(env_id: str, steps: int, seed: int, make: Callable[[np.random.Generator], tuple[gym.Env, dict]] | None = None,
             progress: bool = True, checkpoint: Callable[[dict[str, Any]], None] | None = None,
             remake_every: int = DEFAULT_REMAKE_EVERY, leak_kib: float = 0.0) -> dict[str, Any]:
    """Fuzz ``env_id`` for ``steps`` step calls; counts, failures and RSS figures as a dict.

    One env instance serves the whole run (a fresh one only after an unexpected exception), or a
    fresh one every ``remake_every`` episodes if that is > 0. ``checkpoint``, if given, receives
    the figures so far (``"partial": True``) at every RSS sample. ``leak_kib`` > 0 wraps the env
    in :class:`LeakyEnv` (a self-test of the RSS verdict).
    """
    rng = np.random.default_rng(seed)
    make = make or (lambda r: make_fuzzed_env(env_id, r))
    if leak_kib > 0:
        make_plain = make

        def make(r: np.random.Generator) -> tuple[gym.Env, dict]:
            env, kwargs = make_plain(r)
            return LeakyEnv(env, leak_kib), kwargs
    instances = 0
    styles = {name: (list(k), _cumulative(k)) for name, k in (("fuzz", FUZZ_KINDS), ("walk", WALK_KINDS))}
    style_names, style_cum = list(EPISODE_STYLES), _cumulative(EPISODE_STYLES)
    kinds, kinds_cum = styles["fuzz"]
    outcomes: Counter = Counter()
    expected: Counter = Counter()
    unexpected: Counter = Counter()
    failures: Counter = Counter()
    examples: dict[str, list[str]] = {}
    randomize_seen: list[dict] = []
    warning_counts: Counter = Counter()

    def record_unexpected(exc: BaseException, where: str) -> None:
        name = type(exc).__name__
        unexpected[name] += 1
        kept = examples.setdefault(name, [])
        if len(kept) < EXAMPLES_KEPT:
            kept.append(f"{where}: {traceback.format_exc(limit=8)}")

    def fresh(old: gym.Env | None = None) -> tuple[gym.Env, np.ndarray, np.ndarray, np.ndarray]:
        if old is not None:
            try:
                old.close()
            except Exception as exc:  # noqa: BLE001
                record_unexpected(exc, "close")
        nonlocal instances
        for attempt in range(MAX_MAKE_FAILURES):
            try:
                env, kwargs = make(rng)
                instances += 1
                break
            except Exception as exc:  # noqa: BLE001 - a rejected random config is a failure of the soak's ranges
                record_unexpected(exc, "make")
                if attempt == MAX_MAKE_FAILURES - 1:
                    raise SoakAborted(f"{MAX_MAKE_FAILURES} attempts in a row to make the env failed, the last with "
                                      f"{type(exc).__name__}: {str(exc)[:300]}") from exc
        if len(randomize_seen) < 20:
            randomize_seen.append(kwargs)
        robot = env.unwrapped.robot
        return env, robot.command_low, robot.command_high, robot.nominal_command

    def summarise(wall: float, rss: dict[str, Any], partial: bool) -> dict[str, Any]:
        return {
            "env_id": env_id, "steps": n, "seed": seed, "wall_s": wall, "steps_per_s": n / wall if wall > 0 else None,
            "episodes": episodes, "instances": instances, "remake_every": remake_every,
            "outcomes": dict(outcomes), "expected_errors": dict(expected),
            "unexpected_errors": dict(unexpected), "unexpected_examples": examples, "check_failures": dict(failures),
            "warnings": dict(warning_counts), "rss": rss, "randomize_examples": randomize_seen[:5], "partial": partial,
        }

    warmup = max(1, int(WARMUP_FRACTION * steps))
    sample_every = max(1, (steps - warmup) // RSS_SAMPLES)
    next_sample = warmup  # the step of the next RSS sample (a step after the end counts too: n may skip one)
    rss: dict[str, Any] = {"samples": []}
    peak: RssPeak | None = None
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=steps, desc=env_id, unit="step", mininterval=2.0, file=sys.stderr, smoothing=0.05)
    env: gym.Env | None = None
    aborted: str | None = None
    need_reset, episodes_in_env, episodes = True, 0, 0
    n = shown = 0
    t0 = time.perf_counter()

    def count_warning(message: Any, category: type, *_: Any, **__: Any) -> None:
        warning_counts[f"{category.__name__}: {str(message)[:160]}"] += 1  # counted, not kept: memory stays flat

    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = count_warning
        try:
            env, low, high, nominal = fresh()
            while n < steps:
                if need_reset:
                    if remake_every > 0 and episodes_in_env >= remake_every:
                        env, low, high, nominal = fresh(env)
                        outcomes["env_remade"] += 1
                        episodes_in_env = 0
                    seed_i = None if rng.random() < P_UNSEEDED_RESET else int(rng.integers(2**31 - 1))
                    try:
                        env.reset(seed=seed_i)
                        need_reset = False
                        episodes += 1
                        episodes_in_env += 1
                        style = style_names[_pick(style_cum, rng)]
                        kinds, kinds_cum = styles[style]
                        outcomes[f"style_{style}"] += 1
                    except Exception as exc:  # noqa: BLE001
                        record_unexpected(exc, f"reset(seed={seed_i})")
                        env, low, high, nominal = fresh(env)
                        continue
                kind = kinds[_pick(kinds_cum, rng)]
                action, expect_clipped = fuzz_action(kind, low, high, rng)
                n += 1
                before = env.unwrapped.steps if env_id != footstep_gym.MIX_ENV_ID else env.unwrapped.current.steps
                try:
                    result = env.step(action)
                except ActionError:
                    if kind == "bad":
                        expected["ActionError"] += 1
                        after = (env.unwrapped.steps if env_id != footstep_gym.MIX_ENV_ID
                                 else env.unwrapped.current.steps)
                        if after != before:
                            failures["bad action moved the episode on"] += 1
                    else:
                        record_unexpected(sys.exc_info()[1], f"step({kind} action {action!r})")
                        env, low, high, nominal = fresh(env)
                        need_reset = True
                except Exception as exc:  # noqa: BLE001
                    record_unexpected(exc, f"step({kind} action {action!r})")
                    env, low, high, nominal = fresh(env)
                    need_reset = True
                else:
                    if kind == "bad":
                        failures["bad action accepted"] += 1
                    for problem in check_step(result, env.observation_space, expect_clipped):
                        failures[problem] += 1
                    _, _, terminated, truncated, info = result
                    outcomes["clipped"] += bool(info.get("clipped"))
                    if terminated or truncated:
                        outcomes[info["termination"] if terminated else "truncated"] += 1
                        need_reset = True
                        if rng.random() < P_STEP_AFTER_END and n < steps:
                            n += 1
                            try:
                                env.step(nominal)
                                failures["step after the end accepted"] += 1
                            except gym.error.ResetNeeded:
                                expected["ResetNeeded"] += 1
                            except Exception as exc:  # noqa: BLE001
                                record_unexpected(exc, "step after the end")
                if n >= warmup and peak is None:
                    peak = RssPeak()
                    rss["start"] = rss_bytes()
                    rss["start_step"] = n
                if peak is not None:
                    if n >= warmup + (steps - warmup) // 2 and "middle" not in rss:
                        rss["middle"], rss["middle_step"] = rss_bytes(), n
                    if n >= next_sample:
                        next_sample += sample_every * ((n - next_sample) // sample_every + 1)
                        rss["samples"].append((n, peak.sample()))
                        if checkpoint is not None:
                            so_far = time.perf_counter() - t0
                            checkpoint(summarise(so_far, {**rss, "end": rss_bytes(), "peak": peak.peak,
                                                          "slope": rss_slope(rss["samples"])}, partial=True))
                if bar is not None and n - shown >= PROGRESS_EVERY:
                    bar.update(n - shown)
                    shown = n
        except SoakAborted as exc:
            aborted = str(exc)
            log(f"{env_id}: soak aborted at step {n:,}: {aborted}")
        wall = time.perf_counter() - t0
    if bar is not None:
        bar.update(n - bar.n)
        bar.close()
    rss["end"] = rss_bytes()
    if env is not None and aborted is None:
        env.close()
    rss.setdefault("middle", rss["end"])
    if peak is not None:  # the last sample is the end
        if rss["samples"] and rss["samples"][-1][0] == n:
            rss["samples"].pop()
        rss["samples"].append((n, rss["end"]))
    rss["slope"] = rss_slope(rss["samples"])
    if peak is not None:
        rss["peak"] = peak.peak
        rss["peak_method"] = peak.method
        peak.close()
    res = summarise(wall, rss, partial=False)
    res["aborted"] = aborted
    return res


def verdict(res: dict[str, Any], tolerance_mib: float) -> dict[str, Any]:
    """``res`` with ``rss_growth``, ``rss_flat``, ``passed`` and ``failures`` (why it failed, in words) added."""
    rss = res["rss"]
    start = rss.get("start")
    tol = tolerance_mib * 2**20
    growth = None if start is None or rss.get("end") is None else rss["end"] - start
    over_peak = None if start is None or rss.get("peak") is None else rss["peak"] - start
    flat = None if growth is None else growth <= tol and (over_peak is None or over_peak <= tol)
    res["rss_growth"], res["rss_peak_over_start"], res["rss_flat"] = growth, over_peak, flat
    reasons = []
    if flat is False:
        steps = res.get("steps", 0) - rss.get("start_step", 0)
        what = (f"RSS grew {fmt_bytes(growth)} after the warm-up: {fmt_bytes(start)} at step "
                f"{rss.get('start_step', 0):,}, {fmt_bytes(rss['end'])} at the end (step {res.get('steps', 0):,})")
        if over_peak is not None and over_peak > tol and growth <= tol:
            what = (f"peak RSS {fmt_bytes(rss['peak'])} is {fmt_bytes(over_peak)} above the {fmt_bytes(start)} after "
                    "the warm-up")
        per = f", {growth / steps:,.0f} B per step" if steps > 0 and growth > tol else ""
        reasons.append(f"{what}{per}; more than --rss-tolerance-mib={tolerance_mib:g} MiB: memory kept by the env "
                       f"instance ({res.get('instances', '?')} made)?")
    if res["unexpected_errors"]:
        reasons.append("unexpected exceptions: " + ", ".join(f"{k} x{v}" for k, v in res["unexpected_errors"].items()))
    if res["check_failures"]:
        reasons.append("failed checks: " + ", ".join(f"{k} x{v}" for k, v in res["check_failures"].items()))
    if res.get("aborted"):
        reasons.insert(0, f"aborted at step {res.get('steps', 0):,}: {res['aborted']}")
    res["failures"] = reasons
    res["passed"] = (not res["unexpected_errors"] and not res["check_failures"] and flat is not False
                     and not res.get("aborted"))
    return res


# ------------------------------------------------------------------ report
def report(summary: dict[str, Any]) -> str:
    rows = []
    for r in summary["envs"]:
        rss = r["rss"]
        rows.append([
            r["env_id"], f"{r['steps']:,}", fmt_num(r["steps_per_s"]), f"{r['episodes']:,}",
            ", ".join(f"{k} {v:,}" for k, v in sorted(r["outcomes"].items())) or "-",
            ", ".join(f"{k} {v:,}" for k, v in sorted(r["expected_errors"].items())) or "-",
            ", ".join(f"{k} {v:,}" for k, v in sorted(r["unexpected_errors"].items())) or "none",
            ", ".join(f"{k} {v:,}" for k, v in sorted(r["check_failures"].items())) or "none",
            f"{fmt_bytes(rss.get('start'))} / {fmt_bytes(rss.get('middle'))} / {fmt_bytes(rss.get('end'))}",
            fmt_bytes(rss.get("peak")), fmt_bytes(r["rss_growth"]),
            "n/a" if rss.get("slope") is None else f"{rss['slope']:.1f} B", r.get("instances", "n/a"),
            "PASS" if r["passed"] else "FAIL",
        ])
    meta = summary["meta"]
    lines = [
        "# Soak", "",
        f"{meta['steps_per_env']:,} fuzzed `step` calls per env, seed {meta['seed']}; "
        f"{meta['machine']['cpu']}, {meta['machine']['cores_usable']} cores, load average "
        f"{meta['load_average_start']} at the start, {meta['load_average_end']} at the end; "
        f"{meta['duration_s']:.0f} s in all.", "",
        markdown_table(["env", "steps", "steps/s", "episodes", "outcomes", "expected errors", "unexpected errors",
                        "check failures", "RSS start / middle / end", "peak RSS", "growth", "RSS slope per step",
                        "env instances", "verdict"], rows),
        "",
        f"RSS: the current resident set (`/proc/self/statm`) after {WARMUP_FRACTION:.0%} of the steps (start), at "
        f"the middle and at the end; peak since the start (VmHWM); slope: least-squares fit of the current RSS "
        f"sampled {RSS_SAMPLES} times after the start. Flat = end and peak within "
        f"{meta['rss_tolerance_mib']:g} MiB of the start (`--rss-tolerance-mib`). "
        + ("One env instance per env for the whole run (a fresh one only after an unexpected error)."
           if not meta.get("remake_every") else f"A fresh env every {meta['remake_every']:,} episodes."),
    ]
    for r in summary["envs"]:
        samples = r["rss"].get("samples") or []
        if samples:
            lines += ["", f"{r['env_id']} current RSS [MiB] at steps: " + ", ".join(
                f"{n:,}: {v / 2**20:.1f}" for n, v in samples if v is not None)]
        for reason in r.get("failures", []):
            lines += ["", f"**{r['env_id']} FAIL**: {reason}"]
        for name, kept in r["unexpected_examples"].items():
            lines += ["", f"## {r['env_id']}: {name}", "", "```", kept[0].rstrip(), "```"]
        if r["warnings"]:
            lines += ["", f"{r['env_id']} warnings: " + "; ".join(f"{k} (x{v})" for k, v in r["warnings"].items())]
    return "\n".join(lines) + "\n"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=DEFAULT_STEPS, help="step calls per env (default 10^6)")
    p.add_argument("--envs", default=",".join(ENV_IDS), help="comma-separated env ids (default: all four)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("runs/soak"), help="folder for soak.json and soak.md")
    p.add_argument("--rss-tolerance-mib", type=float, default=DEFAULT_RSS_TOLERANCE_MIB,
                   help="largest growth of the current RSS (and of the peak) over its value after the warm-up "
                        f"still called flat [MiB] (default {DEFAULT_RSS_TOLERANCE_MIB:g}); more fails the env")
    p.add_argument("--remake-every", type=int, default=DEFAULT_REMAKE_EVERY, metavar="EPISODES",
                   help="make a fresh env (new random randomize= settings) every this many episodes; 0 (default): "
                        "one env instance for the whole run, which is what shows a leak tied to the instance")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--_child", dest="child", default=None, help=argparse.SUPPRESS)
    p.add_argument("--_json", dest="json_path", type=Path, default=None, help=argparse.SUPPRESS)
    # Self-test of the RSS verdict: the env keeps this many KiB more at every reset (the run must FAIL).
    p.add_argument("--_inject-leak-kib", dest="leak_kib", type=float, default=0.0, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.steps < 1:
        p.error(f"--steps must be >= 1, got {args.steps}")
    if not (args.rss_tolerance_mib >= 0 and math.isfinite(args.rss_tolerance_mib)):
        p.error(f"--rss-tolerance-mib must be a finite number >= 0, got {args.rss_tolerance_mib}")
    if args.remake_every < 0:
        p.error(f"--remake-every must be >= 0 (0: one env instance), got {args.remake_every}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.child:
        def save(partial: dict[str, Any]) -> None:  # figures so far, in case the run is stopped early
            path = args.out / "partial" / f"{args.child}.json"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(finite_json(verdict(partial, args.rss_tolerance_mib)), indent=1), encoding="utf-8")

        res = soak_env(args.child, args.steps, args.seed, progress=not args.no_progress, checkpoint=save,
                       remake_every=args.remake_every, leak_kib=args.leak_kib)
        args.json_path.write_text(json.dumps(finite_json(res)), encoding="utf-8")
        return 0
    env_ids = [e.strip() for e in args.envs.split(",") if e.strip()]
    unknown = [e for e in env_ids if e not in ENV_IDS]
    if unknown:
        raise SystemExit(f"unknown env id(s) {unknown}; choose from {list(ENV_IDS)}")
    started = time.perf_counter()
    meta = {"steps_per_env": args.steps, "seed": args.seed, "rss_tolerance_mib": args.rss_tolerance_mib,
            "remake_every": args.remake_every, "machine": machine_info(), "load_average_start": loadavg(),
            "episode_styles": EPISODE_STYLES, "fuzz_kinds": FUZZ_KINDS, "walk_kinds": WALK_KINDS}
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, env_id in enumerate(env_ids):
            path = Path(tmp) / f"{i}.json"
            cmd = [sys.executable, str(Path(__file__).resolve()), "--_child", env_id, "--steps", str(args.steps),
                   "--seed", str(args.seed + i), "--_json", str(path), "--out", str(args.out),
                   "--rss-tolerance-mib", str(args.rss_tolerance_mib), "--remake-every", str(args.remake_every),
                   "--_inject-leak-kib", str(args.leak_kib)] + (["--no-progress"] if args.no_progress else [])
            proc = subprocess.run(cmd, check=False)
            if proc.returncode != 0 or not path.exists():
                res = {"env_id": env_id, "steps": 0, "steps_per_s": None, "episodes": 0, "outcomes": {},
                       "expected_errors": {}, "unexpected_errors": {"crash": 1},
                       "unexpected_examples": {"crash": [f"child exited with status {proc.returncode}"]},
                       "check_failures": {}, "warnings": {}, "rss": {}}
            else:
                res = json.loads(path.read_text(encoding="utf-8"))
            results.append(verdict(res, args.rss_tolerance_mib))
            log(f"{env_id}: {'PASS' if results[-1]['passed'] else 'FAIL'}")
            for reason in results[-1]["failures"]:
                log(f"{env_id}: FAIL: {reason}")
    meta["duration_s"] = time.perf_counter() - started
    meta["load_average_end"] = loadavg()
    summary = {"meta": meta, "envs": results, "passed": all(r["passed"] for r in results)}
    text = report(summary)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "soak.json").write_text(json.dumps(finite_json(summary), indent=2) + "\n", encoding="utf-8")
    (args.out / "soak.md").write_text(text, encoding="utf-8")
    log(f"wrote {args.out / 'soak.json'} and {args.out / 'soak.md'}")
    if not summary["passed"]:
        failed = [r for r in results if not r["passed"]]
        log(f"FAILED: {len(failed)} of {len(results)} env(s): " + "; ".join(
            f"{r['env_id']}: {' / '.join(r['failures'])}" for r in failed))
    return 0 if summary["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
