"""The soak engine: millions of fuzzed steps per env, checking that nothing unexpected ever happens
(``baselines/soak.py`` is its command line; ``speedlib.reports.soak_report`` its markdown).

:func:`run` soaks each env in a fresh interpreter of its own (so its memory figures are its own)
with :func:`soak_env`, with a tqdm progress bar on stderr, and keeps **one env instance** for its
whole run (made with random ``randomize=`` settings drawn from the scenario's fuzz ranges,
:meth:`footstep_gym.scenarios.Scenario.fuzz_ranges`, reset at every episode's end), as a training
run does: a leak tied to the env instance (pymunk keeping the shapes removed at reset, say) shows
only there. ``remake_every=N`` makes a fresh env every N episodes instead, which hides such a leak.
Every ``env.step`` call counts as a step. The fuzz, drawn from one seeded generator:

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
(default :data:`DEFAULT_RSS_TOLERANCE_MIB`: over 10^6 steps a leak of 10 B per step exceeds it, while a
leak-free env's RSS grows only in the allocators' one-off steps after the warm-up); an env whose RSS is
not flat FAILs. If the env cannot be made ``MAX_MAKE_FAILURES`` times in a row, the run ends there and fails.

:func:`run` returns the summary (steps/s, outcomes, exceptions by type, RSS figures, and each
env's verdict with why it failed); the command writes it as ``<out>/soak.json`` and
``<out>/soak.md`` and exits with status 1 if any env failed. While it runs, each env's figures
so far are in ``<out>/partial/<env id>.json`` (updated 20 times per env), so a run stopped
early still says how far it got and what it saw.
"""

from __future__ import annotations

import bisect
import json
import math
import sys
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np

import footstep_gym
from footstep_gym.errors import ActionError
from footstep_gym.scenarios import SCENARIOS, scene_of

from .fmt import finite_json, fmt_bytes
from .fresh import ChildFailed, call_fresh
from .machine import loadavg, machine_info
from .memory_use import RssPeak, rss_bytes

ENV_IDS = (*footstep_gym.ENV_IDS.values(), footstep_gym.MIX_ENV_ID)
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



def log(msg: str) -> None:
    print(f"[soak] {msg}", file=sys.stderr, flush=True)


# ------------------------------------------------------------------ the fuzz
def random_randomize(scene: str, rng: np.random.Generator) -> dict[str, list[float]]:
    """A random ``randomize=`` dict for ``scene``: each key of the scenario's fuzz ranges
    (:meth:`~footstep_gym.scenarios.Scenario.fuzz_ranges`: the YAML's ``fuzz:`` section, in its order,
    ``.inf`` already resolved to the key's ``max_*`` bound) with probability :data:`P_RANDOMIZE_KEY`,
    as ``[a, b]`` drawn uniformly in its range."""
    cls = SCENARIOS[scene]
    out = {}
    for key, (lo, hi) in cls.fuzz_ranges().items():
        if rng.random() >= P_RANDOMIZE_KEY:
            continue
        a, b = sorted(float(v) for v in rng.uniform(lo, hi, 2))
        out[key] = [a, b]
    return out


def make_fuzzed_env(env_id: str, rng: np.random.Generator) -> tuple[gym.Env, dict[str, Any]]:
    """``gym.make(env_id)`` with random ``randomize=`` settings; returns the env and its keyword arguments."""
    if env_id == footstep_gym.MIX_ENV_ID:
        kwargs: dict[str, Any] = {s: {"randomize": random_randomize(s, rng)} for s in footstep_gym.ENV_IDS}
    else:
        kwargs = {"randomize": random_randomize(scene_of(env_id), rng)}
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
    """An index drawn with the probabilities of ``cumulative`` (cheaper than ``rng.choice(n, p=...)`` per call)."""
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


# ------------------------------------------------------------------ every env, each in a process of its own
def soak_child(env_id: str, steps: int, seed: int, out: Path, rss_tolerance_mib: float, remake_every: int,
               progress: bool, leak_kib: float) -> dict[str, Any]:
    """Runs in a fresh interpreter (:func:`run`): :func:`soak_env` of ``env_id``, its figures so far written to
    ``<out>/partial/<env id>.json`` at every RSS sample. Returns the result as strict JSON would have it."""
    def save(partial: dict[str, Any]) -> None:  # figures so far, in case the run is stopped early
        path = Path(out) / "partial" / f"{env_id}.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(finite_json(verdict(partial, rss_tolerance_mib)), indent=1), encoding="utf-8")

    res = soak_env(env_id, steps, seed, progress=progress, checkpoint=save, remake_every=remake_every,
                   leak_kib=leak_kib)
    return json.loads(json.dumps(finite_json(res)))


def run(env_ids: list[str], steps: int, seed: int, out: Path, rss_tolerance_mib: float = DEFAULT_RSS_TOLERANCE_MIB,
        remake_every: int = DEFAULT_REMAKE_EVERY, progress: bool = True, leak_kib: float = 0.0) -> dict[str, Any]:
    """Soak each of ``env_ids`` in turn, each in a fresh interpreter (:func:`soak_child`; env ``i`` with seed
    ``seed + i``), and judge it (:func:`verdict`). Returns ``{"meta", "envs", "passed"}``; says each env's
    verdict (and why it failed) on stderr. ``leak_kib`` > 0: the self-test of the RSS verdict (:class:`LeakyEnv`)."""
    started = time.perf_counter()
    meta = {"steps_per_env": steps, "seed": seed, "rss_tolerance_mib": rss_tolerance_mib,
            "remake_every": remake_every, "machine": machine_info(), "load_average_start": loadavg(),
            "episode_styles": EPISODE_STYLES, "fuzz_kinds": FUZZ_KINDS, "walk_kinds": WALK_KINDS}
    results = []
    for i, env_id in enumerate(env_ids):
        try:
            res = call_fresh(soak_child, env_id, steps, seed + i, Path(out), rss_tolerance_mib, remake_every,
                             progress, leak_kib)
        except ChildFailed as exc:
            res = {"env_id": env_id, "steps": 0, "steps_per_s": None, "episodes": 0, "outcomes": {},
                   "expected_errors": {}, "unexpected_errors": {"crash": 1},
                   "unexpected_examples": {"crash": [f"child exited with status {exc.status}: {exc}"]},
                   "check_failures": {}, "warnings": {}, "rss": {}}
        results.append(verdict(res, rss_tolerance_mib))
        log(f"{env_id}: {'PASS' if results[-1]['passed'] else 'FAIL'}")
        for reason in results[-1]["failures"]:
            log(f"{env_id}: FAIL: {reason}")
    meta["duration_s"] = time.perf_counter() - started
    meta["load_average_end"] = loadavg()
    return {"meta": meta, "envs": results, "passed": all(r["passed"] for r in results)}
