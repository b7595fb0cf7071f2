"""Planning time per footstep (median, p95, p99 of ``policy.act``) and success of :data:`PLANNERS` on every
footstep env, on the same seeds (:func:`bench_planners`).

The planners are timed through the evaluation runner's episode loop
(:func:`footstep_gym.evaluation.runner.run_episode` with its ``on_step`` hook): the act times
are the ones an evaluation records (``EpisodeResult.plan_ms``), with the sensing call and the
env step timed beside them and the planners' per-stage times read from ``policy.last_info``.
Each planner is warmed up first as the runner warms up a cell (``runner.warm_up``: once per
process, :attr:`Settings.planner_warmup_steps` untimed acts on a throwaway env).
"""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from .settings import Settings, error, log
from .timing import tail_summary

PLANNERS = ("period-aware", "fixed-period", "pso-only")
STAGE_KEYS = ("time_period_search_ms", "time_rrt_ms", "time_pso_ms")  # policy.last_info, when present
WARMUP_SEED_OFFSET = 10_000  # the warm-up's seed: the first timed seed + this (never a timed one)


def make_policy_fn() -> tuple[Callable | None, str | None]:
    """``(footstep_gym.make_policy, None)``, or ``(None, why)`` where the planners cannot be imported."""
    try:
        import footstep_gym.planners  # noqa: F401  (the planners' modules, imported here once)
        from footstep_gym import make_policy
    except Exception as exc:  # noqa: BLE001
        return None, f"footstep_gym.planners unavailable: {type(exc).__name__}: {exc}"
    return make_policy, None


class PlannerRun:
    """One planner on one env: its footsteps' times and its episodes, through the evaluation runner.

    :meth:`episode` runs one seed's episode with :func:`~footstep_gym.evaluation.runner.run_episode`
    (a fresh env and policy, both seeded with the seed, as an evaluation runs it) and collects,
    through its ``on_step`` hook, the times of ``sensing()``, ``policy.act`` and ``env.step``
    of every footstep, the stage times of ``policy.last_info`` and the commands (replayed by the
    env section). :func:`bench_planners` alternates the planners seed by seed (the same seeds
    for every planner), so that background load hits them alike and their time ratio is fair.
    """

    def __init__(self, planner: str, env_id: str, max_steps: int | None) -> None:
        from footstep_gym.evaluation.runner import Cell
        from footstep_gym.scenarios import scene_of

        self.planner, self.env_id, self.max_steps = planner, env_id, max_steps
        self.cell = Cell(env_id, scene_of(env_id), planner)
        self.plan_s: list[float] = []
        self.plan_by_episode: list[list[float]] = []  # the same times, one list per recorded episode
        self.sense_s: list[float] = []
        self.step_s: list[float] = []
        self.stages: dict[str, list[float]] = {}
        self.pso_ran = 0
        self.episodes: list[dict[str, Any]] = []
        self.recorded: list[tuple[int, np.ndarray, Any]] = []

    def warm_up(self, seed: int, acts: int) -> bool:
        """The runner's warm-up of this cell (once per process): ``acts`` untimed acts from ``seed``."""
        from footstep_gym.evaluation.runner import warm_up

        return warm_up(self.cell, seed, acts=acts)

    def episode(self, seed: int) -> int:
        """Run and record one episode from ``seed`` (cut after ``max_steps`` footsteps if set). Returns its footsteps."""
        from footstep_gym.evaluation.runner import ActTiming, Task, run_episode

        plan_times: list[float] = []
        actions: list[np.ndarray] = []
        last: list[ActTiming] = []

        def on_step(t: ActTiming) -> bool:
            self.sense_s.append(t.sense_s)
            self.plan_s.append(t.act_s)
            plan_times.append(t.act_s)
            self.step_s.append(t.step_s)
            for key in STAGE_KEYS:
                if isinstance(t.last_info.get(key), (int, float)):
                    self.stages.setdefault(key, []).append(1e-3 * t.last_info[key])
            self.pso_ran += bool(t.last_info.get("pso_ran", False))
            actions.append(np.array(t.action, copy=True))
            last[:] = [t]
            return self.max_steps is not None and t.footstep >= self.max_steps

        run_episode(Task(0, self.cell, seed), warm=False, on_step=on_step)
        end = last[0]
        info = end.info
        self.plan_by_episode.append(plan_times)
        self.episodes.append({"seed": seed, "steps": len(actions), "termination": info.get("termination"),
                              "success": bool(info.get("is_success", False)), "time": info.get("time"),
                              "capped": not (end.terminated or end.truncated)})
        self.recorded.append((seed, np.array(actions), info.get("termination")))
        return len(actions)

    def result(self) -> dict[str, Any]:
        successes = sum(e["success"] for e in self.episodes)
        return {
            "plan_time_s": tail_summary(self.plan_s),
            "plan_time_by_episode_s": [[round(t, 7) for t in ep] for ep in self.plan_by_episode],
            "sensing_time_s": tail_summary(self.sense_s),
            "env_step_time_s": tail_summary(self.step_s),
            "stage_time_s": {k.removeprefix("time_").removesuffix("_ms"): tail_summary(v)
                             for k, v in self.stages.items()},
            "pso_ran_fraction": self.pso_ran / max(len(self.plan_s), 1),
            "footsteps": len(self.plan_s),
            "episodes": len(self.episodes),
            "successes": successes,
            "success_rate": successes / max(len(self.episodes), 1),
            "seeds": [e["seed"] for e in self.episodes],
            "per_episode": self.episodes,
        }


def bench_planners(settings: Settings, seed: int) -> tuple[dict[str, Any], dict[str, list]]:
    """Planning time per footstep and success of every planner on every env, on the same seeds.

    Also returns the period-aware planner's recorded commands per env (replayed by the
    env-steps section, so that the env is timed without the planner).
    """
    from .env_rates import FOOTSTEP_ENVS

    make_policy, reason = make_policy_fn()
    if make_policy is None:
        return {"skipped": reason}, {}
    seeds = [seed + i for i in range(max(settings.planner_episodes, 2))]  # >= 2: the vector replay pairs seeds
    results: dict[str, Any] = {}
    replays: dict[str, list] = {}
    for env_id in FOOTSTEP_ENVS:
        runs: dict[str, PlannerRun] = {}
        failed: dict[str, str] = {}
        for planner in PLANNERS:
            try:
                runs[planner] = PlannerRun(planner, env_id, settings.planner_max_steps)
                runs[planner].warm_up(seed + WARMUP_SEED_OFFSET, settings.planner_warmup_steps)
            except Exception as exc:  # noqa: BLE001 - one broken planner must not lose the rest
                failed[planner] = error(exc)
                runs.pop(planner, None)
        t_env = time.perf_counter()
        budget_hit = False
        for i, s in enumerate(seeds):
            if settings.planner_budget_s is not None and i >= 2 and \
                    time.perf_counter() - t_env > settings.planner_budget_s:
                budget_hit = True
                log(f"  planners on {env_id}: time budget of {settings.planner_budget_s:.0f} s used up; "
                    f"{i} of {len(seeds)} seeds run (the same for every planner)")
                break
            done = []
            for planner, run in list(runs.items()):
                t0 = time.perf_counter()
                try:
                    n = run.episode(s)
                except Exception as exc:  # noqa: BLE001
                    failed[planner] = error(exc)
                    del runs[planner]
                    continue
                done.append(f"{planner} {n} steps {time.perf_counter() - t0:.1f} s")
            log(f"  planners on {env_id:20s} seed {s} ({i + 1}/{len(seeds)}): " + ", ".join(done))
        results[env_id] = {}
        for planner in PLANNERS:
            if planner in failed:
                results[env_id][planner] = {"skipped": failed[planner]}
            else:
                results[env_id][planner] = {**runs[planner].result(), "seeds_planned": list(seeds),
                                            "budget_exhausted": budget_hit}
        if "period-aware" in runs:
            replays[env_id] = runs["period-aware"].recorded
    return results, replays
