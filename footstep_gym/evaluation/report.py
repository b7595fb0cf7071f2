"""Tables and files of an evaluation: the markdown table, results.json/.csv, episodes.csv, the paper's numbers.

Reads records (:func:`~footstep_gym.evaluation.stats.cell_record`,
:func:`~footstep_gym.evaluation.stats.over_runs`) and episode results; runs nothing.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

from footstep_gym.evaluation.runner import WARMUP_ACTS, Cell, safe_name
from footstep_gym.evaluation.stats import EpisodeResult


def _fmt(v: Any, digits: int = 2) -> str:
    return "–" if v is None else f"{v:.{digits}f}"


def _mm(v: float | None) -> str:
    return "–" if v is None else f"{1000 * v:.0f}"


def upper_bound(policy: str) -> bool:
    """Whether ``policy`` reads the true future (``oracle``): an upper bound, never a baseline."""
    from footstep_gym import policies

    return policies.is_policy(policy) and policies.reads_truth(policy)


def policy_label(policy: str) -> str:
    """The policy's name in a table: ``oracle (upper bound)`` for a policy that reads the truth, else the name."""
    return f"{policy} (upper bound)" if upper_bound(policy) else policy


def markdown_table(records: list[dict[str, Any]]) -> str:
    """One row per record (planners, and agents summarised over their training runs by ``over_runs``)."""
    head = ["env", "setting", "policy", "n", "success [95% CI]", "IQM over training seeds [95% CI]",
            "collision", "fall", "timeout", "steps*", "path (m)*", "time (s)*", "mean T (s)",
            "clearance mm", "ZMP margin mm", "PSO steps", "act ms median / p95 / p99"]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(["---"] * 3 + ["---:"] * (len(head) - 3)) + "|"]
    for r in records:
        lo, hi = r["success_ci95"]
        setting = ", ".join(f"{k}={v:g}" for k, v in r["params"].items()) or "–"
        pso = "–" if r["pso_step_rate"] is None else f"{100 * r['pso_step_rate']:.0f} %"
        if r.get("success_iqm") is not None and len(r["runs"]) > 1:
            ilo, ihi = r["success_iqm_ci95"]
            iqm = f"{r['success_iqm']:.2f} [{ilo:.2f}, {ihi:.2f}] ({len(r['runs'])} runs)"
        else:
            iqm = "– (1 run)" if r.get("runs") else "–"
        lines.append("| " + " | ".join([
            r["scenario"], setting, policy_label(r["policy"]), str(r["episodes"]),
            f"{r['success_rate']:.2f} [{lo:.2f}, {hi:.2f}]", iqm, f"{r['collision_rate']:.2f}",
            f"{r['fall_rate']:.2f}", f"{r['timeout_rate']:.2f}", _fmt(r["mean_steps"], 1),
            _fmt(r["mean_path_length"]), _fmt(r["mean_time"], 1), _fmt(r["mean_period"]),
            f"{_mm(r['min_clearance_median'])} / {_mm(r['min_clearance_min'])}",
            f"{_mm(r['min_zmp_margin_median'])} / {_mm(r['min_zmp_margin_min'])}", pso,
            f"{_fmt(r['plan_ms_median'], 2)} / {_fmt(r['plan_ms_p95'], 1)} / {_fmt(r['plan_ms_p99'], 1)}",
        ]) + " |")
    return "\n".join(lines) + "\n"


def ablation_table(records: list[dict[str, Any]], base: str) -> str:
    """What each addition buys: one row per policy (``base``, then its variants), one column per setting.

    A cell gives the success rate with its Wilson 95 % interval, then steps / time [s] / path [m]
    (means over the successes) and the median planning time [ms]; a variant's success is followed
    by its difference to ``base`` in the same setting where they differ.
    """
    settings = list(dict.fromkeys((r["scenario"], tuple(r["params"].items())) for r in records))
    policies = list(dict.fromkeys(r["policy"] for r in records))
    by_key = {(r["scenario"], tuple(r["params"].items()), r["policy"]): r for r in records}
    names = [f"{scenario} {', '.join(f'{v:g}' for _, v in params)}".strip() for scenario, params in settings]
    lines = ["| policy | " + " | ".join(names) + " |", "|---|" + "---:|" * len(names)]
    for policy in policies:
        cells = []
        for scenario, params in settings:
            r = by_key.get((scenario, params, policy))
            if r is None:
                cells.append("–")
                continue
            lo, hi = r["success_ci95"]
            text = f"{r['success_rate']:.2f} [{lo:.2f}, {hi:.2f}]"
            ref = by_key.get((scenario, params, base))
            if policy != base and ref is not None and ref["success_rate"] != r["success_rate"]:
                text += f" ({r['success_rate'] - ref['success_rate']:+.2f})"
            text += (f"; {_fmt(r['mean_steps'], 1)} / {_fmt(r['mean_time'], 1)} / {_fmt(r['mean_path_length'])}"
                     f"; {_fmt(r['plan_ms_median'], 1)} ms")
            cells.append(text)
        lines.append(f"| {policy} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def csv_rows(records: list[dict[str, Any]]) -> tuple[list[str], list[dict[str, Any]]]:
    """``results.csv`` columns and rows: params flattened to ``param_<key>``, lists joined by spaces."""
    param_keys = sorted({k for r in records for k in r["params"]})
    rows = []
    for r in records:
        row: dict[str, Any] = {}
        for key, value in r.items():
            if key == "params":
                row.update({f"param_{k}": r["params"].get(k, "") for k in param_keys})
            elif key == "success_ci95":
                row["success_ci95_lo"], row["success_ci95_hi"] = value
            elif isinstance(value, list):
                row[key] = " ".join(str(v) for v in value)
            else:
                row[key] = "" if value is None else value
        rows.append(row)
    columns = list(dict.fromkeys(k for row in rows for k in row))  # agents' rows add the over-runs fields
    return columns, [{k: row.get(k, "") for k in columns} for row in rows]


def write_csv(path: Path, columns: list[str], rows: list[dict[str, Any]]) -> None:
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)


def episode_rows(cells: list[Cell], results: list[EpisodeResult]) -> list[dict[str, Any]]:
    rows = []
    for r in results:
        c = cells[r.cell_index]
        rows.append({
            "env": c.env_id, "setting": c.setting, "policy": c.policy, "run": c.run_name or "",
            "seed": r.seed, "outcome": r.outcome,
            "obstacle": r.obstacle or "", "steps": r.steps, "time": round(r.time, 4),
            "path_length": round(r.path_length, 4), "com_path_length": round(r.com_path_length, 4),
            "mean_period": round(sum(r.periods) / len(r.periods), 4) if r.periods else "",
            "min_period": round(min(r.periods), 4) if r.periods else "",
            "pso_steps": sum(bool(x) for x in r.pso_ran if x is not None),
            "min_clearance": "" if r.min_clearance is None else round(r.min_clearance, 5),
            "min_zmp_margin": "" if r.min_zmp_margin is None else round(r.min_zmp_margin, 5),
            "plan_ms_mean": round(sum(r.plan_ms) / len(r.plan_ms), 3) if r.plan_ms else "",
            "plan_ms_max": round(max(r.plan_ms), 3) if r.plan_ms else "",
        })
    return rows


def showcase_seed(cells: list[Cell], results: list[EpisodeResult], indices: list[int], policy: str) -> int:
    """The lowest seed that ``policy`` solved among the cells ``indices`` (else the lowest seed)."""
    seeds = sorted({r.seed for r in results if r.cell_index in indices})
    wins = sorted(r.seed for r in results if r.cell_index in indices
                  and cells[r.cell_index].policy == policy and r.outcome == "goal")
    return wins[0] if wins else seeds[0]


def write_pictures(out: Path, cells: list[Cell], results: list[EpisodeResult], showcase: str,
                   figure_scenarios: tuple[str, ...] | None = None,
                   table_scenarios: tuple[str, ...] | None = None) -> list[Path]:
    """One figure per env setting (policies side by side on the showcase seed) and its command tables.

    Figures for the scenes ``figure_scenarios`` (default: all), command tables for ``table_scenarios``
    (default: the scenarios whose class sets ``command_tables``, door and crowd as the paper's Tables 2
    and 4). An agent with several training runs is shown by its first run.
    """
    from footstep_gym.evaluation.figures import episode_figure, params_text, write_command_table
    from footstep_gym.scenarios import SCENARIOS

    if table_scenarios is None:
        table_scenarios = tuple(name for name, cls in SCENARIOS.items() if cls.command_tables)

    written = []
    groups: dict[tuple[str, tuple], list[int]] = {}
    shown: set[tuple[str, tuple, str]] = set()
    for i, c in enumerate(cells):
        if (c.env_id, c.params, c.policy) in shown:
            continue  # later training runs of an agent already shown
        shown.add((c.env_id, c.params, c.policy))
        groups.setdefault((c.env_id, c.params), []).append(i)
    for (env_id, _), indices in groups.items():
        scenario = cells[indices[0]].scenario
        if figure_scenarios is not None and scenario not in figure_scenarios:
            continue
        seed = showcase_seed(cells, results, indices, showcase)
        traces = [r.trace for i in indices for r in results if r.cell_index == i and r.seed == seed]
        traces = [t for t in traces if t is not None]
        if not traces:
            continue
        setting = cells[indices[0]].setting
        shown_params = f" ({params_text(traces[0].params, scenario)})" if traces[0].params else ""
        title = f"{env_id}{shown_params}, seed {seed}"
        written.append(episode_figure(traces, out / "figures" / f"{safe_name(setting)}.png", title))
        if scenario in table_scenarios:
            for tr in traces:
                path = out / "tables" / f"{safe_name(setting, tr.policy, f'seed{seed}')}.md"
                written.append(write_command_table(tr, path))
    return written


def _rate(r: dict[str, Any] | None) -> str:
    if r is None:
        return "not run"
    lo, hi = r["success_ci95"]
    return f"{r['success_rate']:.2f} [{lo:.2f}, {hi:.2f}]"


#: Door outcomes in the paper (§3.1): door speed [deg/s] -> (fixed-period, period-aware).
PAPER_DOOR = {8.0: ("goal", "goal"), 14.0: ("collides", "goal"), 17.0: ("collides", "goal")}


def paper_comparison(records: list[dict[str, Any]]) -> str:
    """The paper's results (docs/model.md §6) beside the numbers of this run, for the cells that were run."""
    def find(scenario: str, policy: str, **params: float) -> dict[str, Any] | None:
        return next((r for r in records if r["scenario"] == scenario and r["policy"] == policy
                     and r["params"] == params), None)

    def settings_of(scenario: str) -> list[dict[str, float]]:
        found = {tuple(sorted(r["params"].items())) for r in records if r["scenario"] == scenario}
        return [dict(p) for p in sorted(found)]

    def steps_path(r: dict[str, Any] | None) -> str:
        if r is None or r["mean_steps"] is None:
            return "no success" if r is not None else "not run"
        return f"{r['mean_steps']:.1f} steps, {100 * r['mean_path_length']:.0f} cm"

    rows = []
    speeds = sorted({r["params"]["door_speed"] for r in records if r["scenario"] == "door"})
    for v in speeds:
        fixed, aware = find("door", "fixed-period", door_speed=v), find("door", "period-aware", door_speed=v)
        paper = PAPER_DOOR.get(v)
        paper_text = f"fixed-period {paper[0]}, period-aware {paper[1]}" if paper else "(speed not in the paper)"
        rows.append(f"| door {v:g} deg/s: success | {paper_text} "
                    f"| fixed-period {_rate(fixed)}, period-aware {_rate(aware)} |")
    for params in settings_of("crossing"):
        fixed, aware = find("crossing", "fixed-period", **params), find("crossing", "period-aware", **params)
        rows.append(f"| crossing: success | both reach the goal | fixed-period {_rate(fixed)}, "
                    f"period-aware {_rate(aware)} |")
        rows.append(f"| crossing: steps, path (successes) | fixed-period 26 steps, 260 cm; period-aware 20 steps, "
                    f"190 cm | fixed-period {steps_path(fixed)}; period-aware {steps_path(aware)} |")
    for params in settings_of("crowd"):
        fixed, aware = find("crowd", "fixed-period", **params), find("crowd", "period-aware", **params)
        where = f" at {params['crowd_speed']:g} m/s" if "crowd_speed" in params else ""
        rows.append(f"| crowd{where}: success | fixed-period collides, period-aware survives | "
                    f"fixed-period {_rate(fixed)}, period-aware {_rate(aware)} |")
        period = "not run" if aware is None else f"mean T {aware['mean_period']:.2f} s, min {aware['min_period']:.2f} s"
        rows.append(f"| crowd{where}: period-aware period | T_SS 0.60 -> 0.54 s (T 0.80 -> 0.74 s), S 7.0 -> 5.6 cm "
                    f"(Table 4) | {period} |")
    if not rows:
        return ""
    return ("## Against the paper\n\n| result | paper (one run each) | this run (success rate [95% CI]) |\n"
            "|---|---|---|\n" + "\n".join(rows) + "\n")


DEFINITIONS = """\
Agents trained with several seeds are summarised over their training runs: success is
pooled over every run's episodes (Wilson interval), and the IQM column is the
interquartile mean of the per-run success rates with a stratified-bootstrap 95 % interval
over runs (rliable); `results.json` keeps one record per run as well (`runs/`).
Columns marked * are means over the successful episodes only (– when there is none);
`results.json` also has them over all episodes (`*_all`). The rates sum to 1: success
(goal), collision, fall (an infeasible step: the ZMP leaves the stable region or a
kinematic limit is broken) and timeout (step or time limit). The 95 % interval is
Wilson's. The path is the walked path of the robot centre (midpoint of the feet), as the
paper's "length of path". Mean T is the walking period T_SS + T_DS averaged over all
footsteps; PSO steps is the share of footsteps on which the policy ran PSO. Clearance is
the smallest gap between the robot's body circle and any obstacle over an episode (at the
env's collision checks), ZMP margin the smallest distance of the ZMP from the stable
region's edge over an episode; both in mm as median / min over the episodes. Act time is
the wall clock of `policy.act` per footstep (planning, or an agent's inference), pooled
over the cell's footsteps (it depends on the machine and the load, the other fields do not),
timed after each worker process's untimed warm-up of {warmup} acts per cell (a fresh
process's first acts load the compiled kernels or the agent's network: start-up, not planning).
""".format(warmup=WARMUP_ACTS)


