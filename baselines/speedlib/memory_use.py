"""Memory: the RSS of this process (:func:`rss_bytes`, :class:`RssPeak`, :func:`max_rss_bytes`; no psutil:
``/proc/self/statm``, ``/proc/self/status``'s ``VmHWM`` reset through ``/proc/self/clear_refs``, and
``resource.getrusage``), and the speed run's memory section (:func:`bench_memory`): the peak memory of
one env and of the period-aware planner, each figure in a process of its own (:func:`memory_child`).
"""

from __future__ import annotations

import gc
import json
import os
import resource
import sys
import time
import tracemalloc
from typing import Any

import numpy as np

from .fmt import finite_json
from .fresh import ChildFailed, call_fresh
from .machine import machine_info
from .settings import Settings, error, log

MEMORY_TIMEOUT_S = 900  # for the whole memory section (each probe also has a stepping budget)


# ------------------------------------------------------------------ this process's RSS
def rss_bytes() -> int | None:
    """Current resident set size of this process [bytes] (``/proc/self/statm``; ``None`` elsewhere)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            pages = int(f.read().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def _vm_hwm_bytes() -> int | None:
    """``VmHWM`` (peak RSS) from ``/proc/self/status`` [bytes], ``None`` where unavailable."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


class RssPeak:
    """Peak RSS of this process from now on, C allocations (pymunk/chipmunk, numpy) included.

    ``getrusage``'s ``ru_maxrss`` is the peak over the whole process life, usually set while
    importing. Here, on Linux, writing ``5`` to ``/proc/self/clear_refs`` resets the kernel's
    peak (``VmHWM``) to the current RSS, so :attr:`peak` is the exact peak since then, even
    inside a call. Where that is not allowed, it falls back to the largest current RSS
    seen by :meth:`sample` (call it after every step; it misses peaks inside a call).
    ``peak`` is ``None`` without ``/proc``.
    """

    def __init__(self) -> None:
        self._page = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096
        try:
            self._f = open("/proc/self/statm", "rb", buffering=0)  # noqa: SIM115 - closed in close()
        except OSError:
            self._f = None
        self.sampled_peak: int | None = None
        self.samples = 0
        try:
            with open("/proc/self/clear_refs", "w", encoding="ascii") as f:
                f.write("5")
            self.hwm_reset = _vm_hwm_bytes() is not None
        except OSError:
            self.hwm_reset = False
        self.sample()

    @property
    def method(self) -> str:
        if self.hwm_reset:
            return "VmHWM reset at the baseline (/proc/self/clear_refs)"
        return "current RSS sampled after every step" if self._f is not None or self.samples else "unavailable"

    def sample(self) -> int | None:
        if self._f is None:
            return None
        self._f.seek(0)
        rss = int(self._f.read().split()[1]) * self._page
        self.samples += 1
        if self.sampled_peak is None or rss > self.sampled_peak:
            self.sampled_peak = rss
        return rss

    @property
    def peak(self) -> int | None:
        hwm = _vm_hwm_bytes() if self.hwm_reset else None
        vals = [v for v in (hwm, self.sampled_peak) if v is not None]
        return max(vals) if vals else None

    def close(self) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None


def max_rss_bytes() -> int:
    """Peak resident set size of this process so far [bytes] (``getrusage``; KiB on Linux, bytes on macOS)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(peak) if sys.platform == "darwin" else int(peak) * 1024


# ------------------------------------------------------------------ the probes (each in a process of its own)
def memory_child(spec: dict[str, Any]) -> dict[str, Any]:
    """Runs in a fresh interpreter: memory of make + reset + N steps (env) or of the period-aware planner.

    Modules are imported before the baseline (code is not the env's memory); for the
    planner, the env is made and stepped first so that only the planner's memory remains
    (its env keeps stepping, so the env's growth over those steps is included). The planner
    acts in one env across episodes (reset on each end), not through the evaluation runner,
    which makes an env per episode: that env's memory would count as the planner's.
    Without tracemalloc, ``peak_rss_delta_bytes`` is the peak RSS above the baseline
    (``RssPeak``: the kernel's ``VmHWM`` reset at the baseline, else the current RSS sampled
    after every step and act). With tracemalloc (a separate child: tracing slows everything
    and allocates), the peak of Python-level allocations (numpy's buffers included).
    """
    import gymnasium as gym

    import footstep_gym.env  # noqa: F401 - pymunk, scenarios, world
    from footstep_gym.robot import load_robot

    from .env_rates import near_nominal_commands
    from .planner_times import make_policy_fn

    env_id, n, what, use_tm = spec["env_id"], spec["steps"], spec["what"], spec["tracemalloc"]
    budget = spec.get("budget_s")
    done = 0
    rng = np.random.default_rng(0)
    make_policy = None
    env = None
    obs = None
    if what == "planner":
        make_policy, reason = make_policy_fn()
        if make_policy is None:
            return {"skipped": reason}
        env = gym.make(env_id)
        env.reset(seed=0)
        for _ in range(3):  # the env's own lazy allocations before the planner is measured
            env.step(env.unwrapped.robot.nominal_command)
        obs, _ = env.reset(seed=0)
    actions = list(near_nominal_commands(load_robot(), n, rng)) if what == "env" else []
    gc.collect()
    rss0, max0 = rss_bytes(), max_rss_bytes()
    sampler = RssPeak()
    if use_tm:
        tracemalloc.start()
    t0 = time.perf_counter()
    peak_all, peak_act, episodes = 0, None, 0
    if what == "env":
        env = gym.make(env_id)
        env.reset(seed=0)
        sampler.sample()
        for a in actions:
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                env.reset()
                episodes += 1
            sampler.sample()
            done += 1
            if budget is not None and time.perf_counter() - t0 > budget:
                break
    else:
        policy = make_policy("period-aware", env.unwrapped.robot, seed=0)
        policy.reset(seed=0)
        sampler.sample()
        peak_act = 0
        for _ in range(n):
            snap = env.unwrapped.sensing()
            if use_tm:
                cur, peak = tracemalloc.get_traced_memory()
                peak_all = max(peak_all, peak)
                tracemalloc.reset_peak()
            action = policy.act(obs, snap)
            if use_tm:
                peak_act = max(peak_act, tracemalloc.get_traced_memory()[1] - cur)
            sampler.sample()
            obs, _, term, trunc, _ = env.step(action)
            if term or trunc:
                episodes += 1
                obs, _ = env.reset(seed=episodes)
                policy.reset(seed=episodes)
            sampler.sample()
            done += 1
            if budget is not None and time.perf_counter() - t0 > budget:
                break
    elapsed = time.perf_counter() - t0
    out: dict[str, Any] = {"steps": done, "steps_planned": n, "episodes_ended": episodes, "seconds": elapsed,
                           "torch_imported": "torch" in sys.modules}
    if use_tm:
        current, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        out.update(tracemalloc_peak_bytes=max(peak_all, peak), tracemalloc_current_bytes=current)
        if peak_act is not None:
            out["tracemalloc_peak_per_act_bytes"] = peak_act
    else:
        sampler.sample()
        rss1, max1 = rss_bytes(), max_rss_bytes()
        out.update(rss_before_bytes=rss0, rss_after_bytes=rss1,
                   rss_delta_bytes=None if rss0 is None or rss1 is None else rss1 - rss0,
                   peak_rss_bytes=sampler.peak, peak_rss_method=sampler.method,
                   rss_samples=sampler.samples, sampled_peak_rss_bytes=sampler.sampled_peak,
                   peak_rss_delta_bytes=None if rss0 is None or sampler.peak is None else sampler.peak - rss0,
                   max_rss_bytes=max1, max_rss_delta_bytes=max1 - max0)
    sampler.close()
    return finite_json(out)


def _spawn_memory(spec: dict[str, Any]) -> dict[str, Any]:
    """One memory probe in a fresh interpreter; the fallback without a fork server."""
    try:
        return call_fresh(memory_child, spec, timeout=MEMORY_TIMEOUT_S, quiet=True)
    except ChildFailed as exc:
        if exc.status is None:
            return {"skipped": f"child timed out after {MEMORY_TIMEOUT_S} s"}
        return {"skipped": f"child failed: {str(exc)[:250]}"}


def memory_server(specs: list[dict[str, Any]], workers: int) -> list[dict[str, Any]]:
    """Runs in a fresh interpreter: every (tracemalloc) probe in a child forked from it.

    This interpreter has imported numpy, gymnasium, pymunk, footstep_gym and the planners
    and allocated nothing else, so a forked child starts from the state of a fresh
    interpreter after its imports (what :func:`memory_child` measures from in a fresh
    interpreter), without paying for the imports again per probe. ``workers`` children run at a
    time; each writes its result to a file of its own and leaves with ``os._exit``.
    """
    import tempfile

    import footstep_gym.env  # noqa: F401

    from .planner_times import make_policy_fn

    make_policy_fn()  # import the planners once, here
    workers = max(1, int(workers))
    results: list[dict[str, Any] | None] = [None] * len(specs)
    with tempfile.TemporaryDirectory(prefix="footstep-speed-mem-") as tmp:
        running: dict[int, int] = {}
        nxt = 0
        while nxt < len(specs) or running:
            while nxt < len(specs) and len(running) < workers:
                path = os.path.join(tmp, f"{nxt}.json")
                pid = os.fork()
                if pid == 0:  # child: measure, write, leave without cleanup handlers
                    code = 0
                    try:
                        out = finite_json(memory_child(specs[nxt]))
                    except BaseException as exc:  # noqa: BLE001
                        out, code = {"skipped": error(exc)}, 1
                    try:
                        with open(path, "w", encoding="utf-8") as f:
                            json.dump(out, f)
                    finally:
                        os._exit(code)
                running[pid] = nxt
                nxt += 1
            pid, status = os.wait()
            i = running.pop(pid)
            try:
                with open(os.path.join(tmp, f"{i}.json"), encoding="utf-8") as f:
                    results[i] = json.load(f)
            except (OSError, ValueError):
                results[i] = {"skipped": f"probe process ended with status {status} and no result"}
    return [r if r is not None else {"skipped": "no result"} for r in results]


def _serve_memory(specs: list[dict[str, Any]], workers: int) -> list[dict[str, Any]] | None:
    """The results of ``specs`` from one :func:`memory_server` interpreter, or ``None`` if it failed."""
    try:
        results = call_fresh(memory_server, specs, workers, timeout=MEMORY_TIMEOUT_S, quiet=True)
        if isinstance(results, list) and len(results) == len(specs):
            return results
        why = f"{len(results) if isinstance(results, list) else results!r} results for {len(specs)} probes"
    except ChildFailed as exc:
        why = str(exc)
    log(f"  memory server failed ({why[:200]}); a fresh interpreter per probe instead")
    return None


def run_memory_jobs(specs: list[dict[str, Any]], workers: int) -> list[dict[str, Any]]:
    """Run the probes ``workers`` at a time, each in a process of its own.

    RSS probes: a fresh interpreter each. A child forked from an interpreter would start
    with its shared-library pages unmapped and fault them back in as it runs, which shows
    up as RSS growth that is no allocation. tracemalloc probes count allocations only, so
    (where ``os.fork`` exists) they run in children forked from one :func:`memory_server`
    interpreter, one at a time beside the RSS probes, which saves the imports per
    probe. Each result says which (``process``).
    """
    from concurrent.futures import ThreadPoolExecutor

    forked = [i for i, sp in enumerate(specs) if sp["tracemalloc"]] if hasattr(os, "fork") and workers > 1 else []
    fresh = [i for i in range(len(specs)) if i not in forked]
    results: list[dict[str, Any] | None] = [None] * len(specs)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        served = pool.submit(_serve_memory, [specs[i] for i in forked], 1) if forked else None
        futures = {i: pool.submit(_spawn_memory, specs[i]) for i in fresh}
        for i, fut in futures.items():
            results[i] = {**fut.result(), "process": "fresh interpreter"}
        got = served.result() if served is not None else None
        if got is None:
            futures = {i: pool.submit(_spawn_memory, specs[i]) for i in forked}
            for i, fut in futures.items():
                results[i] = {**fut.result(), "process": "fresh interpreter"}
        else:
            for i, r in zip(forked, got):
                results[i] = {**r, "process": "forked from a fresh interpreter after its imports"}
    return [r or {"skipped": "no result"} for r in results]


def bench_memory(settings: Settings, workers: int | None = None) -> dict[str, Any]:
    """Memory of one env (each scenario) and of the period-aware planner (on each scenario).

    Every figure comes from a process of its own (see :func:`run_memory_jobs`); they run
    ``workers`` at a time (default: the usable cores). Nothing is timed here, so running
    them side by side does not change what they measure (RSS and tracemalloc are per process).
    """
    from .env_rates import FOOTSTEP_ENVS

    n = settings.memory_steps
    planner_steps = settings.memory_acts
    jobs: list[tuple[str, str, str, dict[str, Any]]] = []
    for what, steps in (("env", n), ("planner", planner_steps)):
        for env_id in FOOTSTEP_ENVS:
            for kind in ("rss", "tracemalloc"):
                jobs.append((what, env_id, kind, {"env_id": env_id, "steps": steps, "what": what,
                                                  "tracemalloc": kind == "tracemalloc",
                                                  "budget_s": settings.memory_budget_s}))
    workers = workers or machine_info()["cores_usable"] or 1
    log(f"  {len(jobs)} memory probes ({workers} at a time): env x{n} steps and period-aware planner "
        f"x{planner_steps} acts, on {len(FOOTSTEP_ENVS)} envs")
    results = run_memory_jobs([spec for *_, spec in jobs], workers)
    out: dict[str, Any] = {"env": {}, "planner": {"period-aware": {}}}
    for (what, env_id, kind, _), r in zip(jobs, results):
        if what == "env":
            out["env"].setdefault(env_id, {})[kind] = r
        else:
            out["planner"]["period-aware"].setdefault(env_id, {"env_id": env_id})[kind] = r
    return out
