"""Tables and files of an evaluation: the markdown tables, results.csv, episodes.csv, the paper's numbers.

Reads records (:class:`~footstep_gym.evaluation.records.CellRecord`) and episode results; runs nothing. Every table
is a pandas DataFrame of text cells (:mod:`footstep_gym.evaluation.tables`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import pandas as pd

from footstep_gym.evaluation.records import CellRecord, frame
from footstep_gym.evaluation.runner import WARMUP_ACTS, Cell, safe_name
from footstep_gym.evaluation.stats import EpisodeResult
from footstep_gym.evaluation.tables import DASH, grid, interval, markdown, mm, num, percent, runs


def upper_bound(policy: str) -> bool:
    """Whether ``policy`` reads the true future (``oracle``): an upper bound, never a baseline."""
    from footstep_gym import registry

    try:
        return registry.resolve(policy).reads_truth
    except ValueError:  # a name no registry knows (a callable's): not the oracle
        return False


def policy_label(policy: str) -> str:
    """The policy's name in a table: ``oracle (upper bound)`` for a policy that reads the truth, else the name."""
    return f"{policy} (upper bound)" if upper_bound(policy) else policy


def setting_text(params: dict[str, Any]) -> str:
    """``door_speed=17`` (every key), or :data:`DASH` for none."""
    return ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}" for k, v in params.items()) or DASH


def iqm_text(r: CellRecord) -> str:
    """The IQM over training runs with its interval and the runs, ``– (1 run)`` for one, ``–`` for a planner."""
    if r.success_iqm is not None and len(r.runs or ()) > 1:
        return f"{interval(r.success_iqm, r.success_iqm_ci95)} ({runs(len(r.runs))})"
    return f"{DASH} (1 run)" if r.runs else DASH


def markdown_table(records: Sequence[CellRecord]) -> str:
    """One row per record (planners, and agents summarised over their training runs by ``over_runs``)."""
    rows = [{
        "env": r.scenario, "setting": setting_text(r.params), "policy": policy_label(r.policy), "n": r.episodes,
        "success [95% CI]": interval(r.success_rate, r.success_ci95), "IQM over training seeds [95% CI]": iqm_text(r),
        "collision": num(r.collision_rate), "fall": num(r.fall_rate), "timeout": num(r.timeout_rate),
        "steps*": num(r.mean_steps, 1), "path (m)*": num(r.mean_path_length), "time (s)*": num(r.mean_time, 1),
        "mean T (s)": num(r.mean_period),
        "clearance mm": f"{mm(r.min_clearance_median)} / {mm(r.min_clearance_min)}",
        "ZMP margin mm": f"{mm(r.min_zmp_margin_median)} / {mm(r.min_zmp_margin_min)}",
        "PSO steps": percent(r.pso_step_rate),
        "act ms median / p95 / p99": f"{num(r.plan_ms_median)} / {num(r.plan_ms_p95, 1)} / {num(r.plan_ms_p99, 1)}",
    } for r in records]
    return markdown(pd.DataFrame(rows), left=3)


def ablation_table(records: Sequence[CellRecord], base: str) -> str:
    """What each addition buys: one row per policy (``base``, then its variants), one column per setting.

    A cell gives the success rate with its Wilson 95 % interval, then steps / time [s] / path [m]
    (means over the successes) and the median planning time [ms]; a variant's success is followed
    by its difference to ``base`` in the same setting where they differ.
    """
    df = frame(records)
    df["column"] = [f"{r.scenario} {', '.join(f'{v:g}' for v in r.params.values())}".strip() for r in records]
    base_rate = {c: r.success_rate for c, r in zip(df["column"], records) if r.policy == base}

    def text(r: CellRecord, column: str) -> str:
        out = interval(r.success_rate, r.success_ci95)
        ref = base_rate.get(column)
        if r.policy != base and ref is not None and ref != r.success_rate:
            out += f" ({r.success_rate - ref:+.2f})"
        return (f"{out}; {num(r.mean_steps, 1)} / {num(r.mean_time, 1)} / {num(r.mean_path_length)}"
                f"; {num(r.plan_ms_median, 1)} ms")

    df["text"] = [text(r, c) for r, c in zip(records, df["column"])]
    table = grid(df, index="policy", columns="column", values="text")
    return markdown(table)


def csv_table(records: Sequence[CellRecord]) -> pd.DataFrame:
    """``results.csv``: a row per record, params flattened to ``param_<key>``, ``success_ci95`` to ``_lo`` / ``_hi``,
    lists joined by spaces, None empty; the columns of the records' fields in their order."""
    keys = sorted({k for r in records for k in r.params})
    rows = []
    for r in records:
        row: dict[str, Any] = {}
        for key, value in r.to_dict().items():
            if key == "params":
                row.update({f"param_{k}": value.get(k, "") for k in keys})
            elif key == "success_ci95":
                row["success_ci95_lo"], row["success_ci95_hi"] = value
            elif isinstance(value, list):
                row[key] = " ".join(str(v) for v in value)
            elif isinstance(value, dict):
                row[key] = setting_text(value)
            else:
                row[key] = "" if value is None else value
        rows.append(row)
    columns = list(dict.fromkeys(k for row in rows for k in row))  # a pooled agent's row adds the over-runs fields
    return pd.DataFrame([[row.get(k, "") for k in columns] for row in rows], columns=columns, dtype=object)


def write_csv(path: Path, table: pd.DataFrame) -> None:
    table.to_csv(path, index=False, lineterminator="\r\n")


def episode_table(cells: Sequence[Cell], results: Sequence[EpisodeResult]) -> pd.DataFrame:
    """``episodes.csv``: a row per episode."""
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
    return pd.DataFrame(rows, dtype=object)


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


def _rate(r: CellRecord | None) -> str:
    return "not run" if r is None else interval(r.success_rate, r.success_ci95)


#: Door outcomes in the paper (§3.1): door speed [deg/s] -> (fixed-period, period-aware).
PAPER_DOOR = {8.0: ("goal", "goal"), 14.0: ("collides", "goal"), 17.0: ("collides", "goal")}


def paper_comparison(records: Sequence[CellRecord]) -> str:
    """The paper's results (docs/model.md §6) beside the numbers of this run, for the cells that were run."""
    def find(scenario: str, policy: str, **params: float) -> CellRecord | None:
        return next((r for r in records if r.scenario == scenario and r.policy == policy and r.params == params),
                    None)

    def settings_of(scenario: str) -> list[dict[str, float]]:
        return [dict(p) for p in sorted({tuple(sorted(r.params.items())) for r in records if r.scenario == scenario})]

    def steps_path(r: CellRecord | None) -> str:
        if r is None or r.mean_steps is None:
            return "no success" if r is not None else "not run"
        return f"{r.mean_steps:.1f} steps, {100 * r.mean_path_length:.0f} cm"

    rows = []
    for v in sorted({r.params["door_speed"] for r in records if r.scenario == "door" and "door_speed" in r.params}):
        fixed, aware = find("door", "fixed-period", door_speed=v), find("door", "period-aware", door_speed=v)
        paper = PAPER_DOOR.get(v)
        rows.append((f"door {v:g} deg/s: success",
                     f"fixed-period {paper[0]}, period-aware {paper[1]}" if paper else "(speed not in the paper)",
                     f"fixed-period {_rate(fixed)}, period-aware {_rate(aware)}"))
    for params in settings_of("crossing"):
        fixed, aware = find("crossing", "fixed-period", **params), find("crossing", "period-aware", **params)
        rows.append(("crossing: success", "both reach the goal",
                     f"fixed-period {_rate(fixed)}, period-aware {_rate(aware)}"))
        rows.append(("crossing: steps, path (successes)",
                     "fixed-period 26 steps, 260 cm; period-aware 20 steps, 190 cm",
                     f"fixed-period {steps_path(fixed)}; period-aware {steps_path(aware)}"))
    for params in settings_of("crowd"):
        fixed, aware = find("crowd", "fixed-period", **params), find("crowd", "period-aware", **params)
        where = f" at {params['crowd_speed']:g} m/s" if "crowd_speed" in params else ""
        rows.append((f"crowd{where}: success", "fixed-period collides, period-aware survives",
                     f"fixed-period {_rate(fixed)}, period-aware {_rate(aware)}"))
        period = "not run" if aware is None else f"mean T {aware.mean_period:.2f} s, min {aware.min_period:.2f} s"
        rows.append((f"crowd{where}: period-aware period",
                     "T_SS 0.60 -> 0.54 s (T 0.80 -> 0.74 s), S 7.0 -> 5.6 cm (Table 4)", period))
    if not rows:
        return ""
    table = pd.DataFrame(rows, columns=["result", "paper (one run each)", "this run (success rate [95% CI])"])
    return "## Against the paper\n\n" + markdown(table, left=3)


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


