"""Markdown of the results: the speed run's tables (:func:`speed_report`) and the soak's
(:func:`soak_report`), as ``speed.md`` / ``soak.md`` and the commands' stdout."""

from __future__ import annotations

from typing import Any

from .env_rates import VEC_MODES
from .fmt import fmt_bytes, fmt_num, fmt_stat, markdown_table
from .ppo_rates import PPO_CELLS, PPO_ENVS


# ------------------------------------------------------------------ the speed run
def _cell_str(cell: dict | None) -> str:
    if not cell:
        return "n/a"
    if "skipped" in cell:
        return "skipped"
    return fmt_stat(cell["steps_per_s"])


def busy(meta: dict[str, Any]) -> bool:
    """Whether the 1-minute load average suggests other work shared the CPUs during the run."""
    loads = [x[0] for x in (meta.get("load_average_start"), meta.get("load_average_end")) if x]
    return bool(loads) and max(loads) > 0.5 * (meta["machine"].get("cores_usable") or 1) + 1.0


def _env_section(res: dict[str, Any], envs: dict[str, Any]) -> list[str]:
    out = ["## Env steps per second (resets timed; vector rates count sub-env transitions, 2 sub-envs)", ""]
    rows = []
    for env_id, by_cmd in envs.items():
        for commands, cell in by_cmd.items():
            single = cell.get("single", {})
            eplen = single.get("mean_episode_steps")
            rows.append([env_id, commands, _cell_str(single), _cell_str(cell.get("sync")),
                         _cell_str(cell.get("async")),
                         f"{eplen:.1f}" if isinstance(eplen, (int, float)) else "n/a"])
    out += [markdown_table(["env", "commands", "1 process", "sync ×2", "async ×2", "steps/episode"], rows), ""]
    vec_info = {mode: {(c.get(mode) or {}).get("vector", {}).get("class") for bc in envs.values()
                       for c in bc.values()} - {None} for mode in VEC_MODES}
    procs = {(c.get("async") or {}).get("vector", {}).get("worker_processes") for bc in envs.values()
             for c in bc.values()} - {None}
    out.append(f"- `gym.make_vec(id, num_envs=2, vectorization_mode=...)`: sync = {sorted(vec_info['sync'])} "
               f"(both sub-envs in this process), async = {sorted(vec_info['async'])} with "
               f"{sorted(procs)} worker process(es); default autoreset (NEXT_STEP): the reset-only vector "
               "steps are timed, not counted.")
    skipped: dict[str, str] = {}
    for e, bc in envs.items():
        for commands, c in bc.items():
            for mode, cell in c.items():
                if isinstance(cell, dict) and "skipped" in cell:
                    key = e if "skipped" in c.get("single", {}) else f"{e} {commands} {mode}"
                    skipped.setdefault(key, cell["skipped"])
    for e, why in skipped.items():
        out.append(f"- {e}: skipped ({why[:200]})")
    for env_id, by_cmd in envs.items():
        if by_cmd.get("planner", {}).get("single", {}).get("replay_matches_recording") is False:
            out.append(f"- {env_id}: replaying the planner's commands did NOT end the episodes as recorded "
                       "(the env is not deterministic given the seed?)")
    ratio_rows = [[k, f"{v['median']:.2f} ({v['q1']:.2f}–{v['q3']:.2f})" if v else "n/a"]
                  for k, v in res["ratios"].items() if k.startswith("FootstepDoor")]
    return out + ["", markdown_table(["single-process steps/s ratio (paired per round)", "median (IQR)"], ratio_rows),
                  ""]


def _lipm_section(lp: dict[str, Any]) -> list[str]:
    rows = [["check_step (scalar)", 1, fmt_stat(lp["check_step"]["commands_per_s"]),
             f"{1e6 / lp['check_step']['commands_per_s']['median']:.1f}"]]
    for b, cell in lp["check_steps"].items():
        s = cell["commands_per_s"]
        rows.append(["check_steps", b, fmt_stat(s), f"{1e6 * int(b) / s['median']:.1f}"])
    out = ["## LIPM feasibility checks", "", markdown_table(["function", "batch", "commands/s", "µs per call"], rows),
           ""]
    c = lp.get("commands")
    if c:
        out += [f"{c['pool']} commands {c['sampling']}: {100 * c['feasible_fraction']:.1f}% feasible; "
                f"check_step and check_steps agree on {100 * c['scalar_batched_agreement']:.2f}%.", ""]
    return out


def _planner_section(res: dict[str, Any], pl: dict[str, Any]) -> list[str]:
    out = ["## Planning time per footstep (policy.act; sensing and env.step timed apart)", ""]
    if "skipped" in pl:
        return out + [f"skipped: {pl['skipped']}", ""]
    rows = []
    for env_id, by_planner in pl.items():
        for planner, r in by_planner.items():
            if "skipped" in r:
                rows.append([env_id, planner, "skipped", "", "", "", "", "", r["skipped"][:60]])
                continue
            p = r["plan_time_s"]
            rows.append([env_id, planner, f"{p['median'] * 1e3:.2f}", f"{p['p95'] * 1e3:.2f}",
                         f"{p['p99'] * 1e3:.2f}", f"{r['sensing_time_s']['median'] * 1e3:.3f}",
                         f"{100 * r['pso_ran_fraction']:.0f}%", f"{r['successes']}/{r['episodes']}",
                         r["footsteps"]])
    out += [markdown_table(["env", "planner", "median ms", "p95 ms", "p99 ms", "sensing ms", "PSO ran",
                            "success", "footsteps"], rows), ""]
    for env_id, by_planner in pl.items():
        r = next((r for r in by_planner.values() if "seeds" in r), None)
        if r and r.get("budget_exhausted"):
            out.append(f"- {env_id}: the time budget ({res['meta']['settings']['planner_budget_s']:.0f} s "
                       f"per env) was used up after {len(r['seeds'])} of {len(r['seeds_planned'])} seeds "
                       "(the same seeds for every planner).")
    if any(r.get("footsteps", 1e9) < 100 for bp in pl.values() for r in bp.values()):
        out.append("- With fewer than 100 footsteps, p99 is close to the maximum; `--full` runs more seeds.")
    return out + [""]


def _memory_section(mem: dict[str, Any]) -> list[str]:
    rows = []

    def mem_row(label: str, r: dict[str, Any], per_act: bool = False) -> list[str]:
        rss, tm = r.get("rss", {}), r.get("tracemalloc", {})
        tm_s = tm.get("skipped", "")[:60] or fmt_bytes(tm.get("tracemalloc_peak_bytes"))
        if per_act and "skipped" not in tm:
            tm_s += f" (one act: {fmt_bytes(tm.get('tracemalloc_peak_per_act_bytes'))})"
        if "skipped" in rss:
            return [label, tm_s, rss["skipped"][:60], "", ""]
        return [label, tm_s, fmt_bytes(rss.get("peak_rss_delta_bytes")), fmt_bytes(rss.get("rss_delta_bytes")),
                fmt_bytes(rss.get("max_rss_bytes"))]

    for env_id, r in mem["env"].items():
        rows.append(mem_row(f"env {env_id} (make+reset+{r.get('rss', {}).get('steps', '?')} steps)", r))
    for name, by_env in mem["planner"].items():
        for env_id, r in by_env.items():
            rows.append(mem_row(f"planner {name} on {env_id} ({r.get('rss', {}).get('steps', '?')} acts)",
                                r, per_act=True))
    return ["## Peak memory (a process of its own per figure; modules imported before the baseline)", "",
            markdown_table(["what", "tracemalloc peak", "peak RSS above baseline", "RSS growth at end",
                            "process peak RSS"], rows), "",
            "tracemalloc: peak of Python-level allocations (numpy buffers included), in a child forked "
            "from a fresh interpreter after its imports. RSS figures: a fresh interpreter each; peak RSS "
            "above baseline is the kernel's VmHWM reset at the baseline (C allocations of pymunk and "
            "numpy included); process peak RSS (getrusage) is the whole process, interpreter and imports "
            "included.", ""]


def _ppo_section(ppo: dict[str, Any]) -> list[str]:
    out = ["## PPO training throughput (env steps/s inside model.learn; configs/rl/ppo.yml, one torch thread)", ""]
    if "skipped" in ppo:
        return out + [f"skipped: {ppo['skipped']}", ""]
    rows = []
    for env_id, by_n in ppo["cells"].items():
        hyper = ppo["hyperparameters"].get(env_id, env_id)
        name = env_id if hyper == env_id else f"{env_id} ({hyper}'s network and hyperparameters: the ceiling)"
        rows.append([name] + [fmt_stat(by_n[str(n)]["steps_per_s"]) if str(n) in by_n else "n/a" for n in PPO_ENVS])
    r = ppo["ratios"]
    rows.append([f"{PPO_CELLS[0][0]} / {PPO_CELLS[1][0]} (paired per round)"]
                + [f"{r[str(n)]['median']:.2f}" if str(n) in r else "n/a" for n in PPO_ENVS])
    return out + [markdown_table(["env", *(f"{n} env{'s' if n > 1 else ''} (DummyVecEnv)" for n in PPO_ENVS)], rows),
                  "", f"{ppo['timesteps']} timed env steps per cell after a one-rollout warm-up, {ppo['rounds']} "
                  "interleaved round(s); median (IQR) over rounds.", ""]


def _ms(s: dict[str, Any] | None, key: str) -> str:
    return f"{s[key] * 1e3:.2f}" if s and s.get("n") else "n/a"


def _tiers_section(res: dict[str, Any], tiers: dict[str, Any]) -> list[str]:
    from .targets import tier_ratio_key

    out = ["## Tiers: env steps per second and planning time per tier (configs/benchmark.yaml)", ""]
    if "skipped" in tiers:
        return out + [f"skipped: {tiers['skipped']}", ""]
    ratios = res.get("ratios", {})
    base = tiers.get("base_tier", "paper")

    def ratio(key: str) -> str:
        r = ratios.get(key)
        return f"{r['median']:.2f} ({r['q1']:.2f}–{r['q3']:.2f})" if r else "—"

    def success(r: dict[str, Any]) -> str:
        return f"{r['successes']}/{r['episodes']}" if r.get("episodes") else "n/a"

    rows = []
    for scene, by_tier in tiers["scenes"].items():
        for tier, agg in by_tier.items():
            eplen = agg.get("mean_episode_steps")
            rows.append([scene, tier, len(agg["cells"]), fmt_stat(agg["steps_per_s"]),
                         ratio(tier_ratio_key(scene, tier)) if tier != base else "1",
                         f"{eplen:.1f}" if isinstance(eplen, (int, float)) else "n/a",
                         _ms(agg["plan_time_s"], "median"), _ms(agg["plan_time_s"], "p99"), agg["footsteps"],
                         success(agg)])
    out += [markdown_table(["scene", "tier", "cells", "env steps/s (median over cells)", f"× {base} (paired)",
                            "steps/episode", "plan median ms", "plan p99 ms", "footsteps", "success"], rows), ""]
    rows = []
    for c in (tiers["cells"][f"{scene}/{tier}/{name}"] for scene, by_tier in tiers["scenes"].items()
              for tier, agg in by_tier.items() for name in agg["cells"]):
        env, pl = c.get("env", {}), c.get("planner", {})
        eplen = env.get("mean_episode_steps")
        rows.append([c["scene"], c["tier"], c["cell"] + (" (ORCA)" if c.get("orca") else ""),
                     "skipped" if "skipped" in env else fmt_stat(env.get("steps_per_s")),
                     ratio(tier_ratio_key(c["scene"], c["tier"], c["cell"])) if c["tier"] != base else "1",
                     f"{eplen:.1f}" if isinstance(eplen, (int, float)) else "n/a",
                     _ms(pl.get("plan_time_s"), "median"), _ms(pl.get("plan_time_s"), "p99"),
                     pl.get("footsteps", "n/a"), success(pl) if "skipped" not in pl else "skipped"])
    out += [markdown_table(["scene", "tier", "cell", "env steps/s", f"× {base} (paired)", "steps/episode",
                            "plan median ms", "plan p99 ms", "footsteps", "success"], rows), ""]
    seeds = tiers.get("seeds", [])
    span = f"seed {seeds[0]}" if len(seeds) == 1 else f"seeds {seeds[0]}–{seeds[-1]}" if seeds else "no seeds"
    out.append(f"- One process; each cell is `gym.make(id, tier=TIER, tier_cell=CELL)` with the {tiers['planner']} "
               f"planner's commands recorded once ({span} per cell) and replayed from the same seeds, resets inside "
               "the timed loop; the cells' "
               "repetitions are interleaved round by round. A tier's rate is, per round, the median over its "
               f"cells; × {base}: over the scene's {base} tier, paired per round, median (IQR) over rounds.")
    out.append("- Planning time: `policy.act` per footstep through the evaluation runner after its warm-up of "
               "each cell, pooled over a tier's cells.")
    for label, c in tiers["cells"].items():
        for part in ("env", "planner"):
            if "skipped" in c.get(part, {}):
                out.append(f"- {label} {part}: skipped ({c[part]['skipped'][:200]})")
        if c.get("env", {}).get("replay_matches_recording") is False:
            out.append(f"- {label}: replaying the planner's commands did NOT end the episodes as recorded")
        if c.get("planner", {}).get("budget_exhausted"):
            out.append(f"- {label}: the planner's time budget per cell ran out after "
                       f"{len(c['planner']['seeds'])} of {len(c['planner']['seeds_planned'])} seeds")
    return out + [""]


def speed_report(res: dict[str, Any]) -> str:
    """The speed run's markdown: the machine, then a table per section measured, then the targets."""
    m = res["meta"]
    mc = m["machine"]
    out = [f"# footstep_gym speed ({m['mode']} mode)", "",
           f"Machine: {mc['cpu']}, {mc['cores_usable']} usable / {mc['cores_logical']} logical cores, "
           f"{mc['os']}; Python {mc['python']}, numpy {mc['numpy']}, pymunk {mc['pymunk']}, "
           f"gymnasium {mc['gymnasium']}, box2d {mc['box2d']}.", "",
           f"Load average (1/5/15 min) at start {m.get('load_average_start')}, at end {m.get('load_average_end')}"
           + (" — other processes were running: rates are lower and noisier than on an idle machine."
              if busy(m) else "."), "",
           "All rates: median (IQR) over repetitions in this run; min/max are in speed.json.", ""]
    if res.get("env_steps"):
        out += _env_section(res, res["env_steps"])
    if res.get("lipm"):
        out += _lipm_section(res["lipm"])
    if res.get("planners"):
        out += _planner_section(res, res["planners"])
    if res.get("memory"):
        out += _memory_section(res["memory"])
    if res.get("ppo"):
        out += _ppo_section(res["ppo"])
    if res.get("tiers"):
        out += _tiers_section(res, res["tiers"])
    if res.get("targets"):
        out += ["## Targets", "", markdown_table(["target", "threshold", "measured", "status"],
                                                 [[t["target"], t["threshold"], t["measured"], t["status"]]
                                                  for t in res["targets"]]), ""]
    out.append(f"Total time: {m['duration_s']:.0f} s.")
    return "\n".join(out)


# ------------------------------------------------------------------ the soak
def soak_report(summary: dict[str, Any]) -> str:
    """The soak's markdown: a row per env, the RSS samples, and each failure with why."""
    from .soak import RSS_SAMPLES, WARMUP_FRACTION

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
