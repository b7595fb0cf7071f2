"""The board as a static web site, built from committed files only (``baselines/make_site.py``).

Reads the leaderboard (``<board>/leaderboard.json``), each row's ``benchmark.json``, the shipped agents'
manifests (``baselines/agents/<name>/*/manifest.json``), the learning curves, the committed episode videos
(``baselines/results/site/videos.json``, :mod:`footstep_gym.evaluation.site_videos`), ``configs/benchmark.yaml``
and ``docs/benchmark.md``, and writes plain HTML with one stylesheet and one small script (column sorting),
every asset inside the output folder: nothing is fetched from the network when the site is built or opened.

Only the committed JSON files are read (not the leaderboard's code), so a board of a later protocol is shown
by building again: a tier's figure is the board's ``scores`` (scene-balanced success, protocol 3) where the
board has them, and its IQM otherwise.
"""

from __future__ import annotations

import html
import json
import re
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import yaml

from footstep_gym.evaluation.board import SHOWN_BOARD_DIR

__all__ = ["SiteError", "SiteData", "build_site", "load_site_data", "MARKER"]

#: The file that marks a folder as a site this module wrote (only such a folder is replaced).
MARKER = ".footstep_gym_site"
#: Where the committed episode videos live, relative to the repository.
VIDEOS_DIR = Path("baselines/results/site")
#: Figures wider than this [px] are scaled down for a screen.
SCREEN_WIDTH = 1200
ASSETS = Path(__file__).with_name("site_assets")
BUILD_COMMAND = "python baselines/make_site.py --out DIR"


class SiteError(ValueError):
    """The site cannot be built (a missing or malformed committed file, a bad ``--out``): one line."""


# ---------------------------------------------------------------- the data
@dataclass
class Method:
    name: str
    label: str
    kind: str  # planner / agent / baseline (a null walker, a reactive or classical baseline) / upper bound
    track: str
    trained_on_tier: str | None
    description: str
    complete: bool
    runs: int
    source: Path | None
    bench: dict[str, Any] = field(default_factory=dict)  # its benchmark.json ({} when absent)
    manifests: list[dict[str, Any]] = field(default_factory=list)
    #: The compute protocol's view of its shipped runs (:func:`footstep_gym.rl.compute.row_training`); None: none.
    training: dict[str, Any] | None = None
    #: Each shipped run's :func:`footstep_gym.rl.compute.run_status`, by its folder's name.
    run_status: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def page(self) -> str:
        return f"methods/{slug(self.name)}.html"

    @property
    def train_steps(self) -> int:
        return int(sum(m.get("timesteps") or 0 for m in self.manifests))

    @property
    def train_hours(self) -> float:
        return sum(float(m.get("wall_time_s") or 0.0) for m in self.manifests) / 3600.0


@dataclass
class SiteData:
    root: Path
    board: dict[str, Any]
    board_path: Path
    methods: list[Method]
    cells: list[tuple[str, str, str]]  # (tier, scene, cell), in the board's order
    tiers_config: dict[str, Any]
    videos: dict[str, Any]

    def method(self, name: str) -> Method:
        return next(m for m in self.methods if m.name == name)


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]", "-", text)


def cell_key(tier: str, scene: str, cell: str) -> str:
    return f"{tier}/{scene}/{cell}"


def cell_page(tier: str, scene: str, cell: str) -> str:
    return f"cells/{slug(tier)}-{slug(scene)}-{slug(cell)}.html"


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise SiteError(f"{path}: not a readable JSON file ({exc})") from None


def _kind(row: Mapping[str, Any], baselines: set[str]) -> str:
    if row.get("upper_bound"):
        return "upper bound"
    if str(row["policy"]).startswith("null-") or row["policy"] in baselines:
        return "baseline"
    return "agent" if row.get("learned") else "planner"


def _baselines(board: Mapping[str, Any]) -> set[str]:
    """The rows the board counts as baselines besides the null walkers: the registered reactive and classical
    baselines (:mod:`footstep_gym.planners.reactive`, :mod:`~footstep_gym.planners.classical`) and the board's
    reactive anchors (``scores.reactive_baselines``, protocol 3)."""
    from footstep_gym.planners.classical import CLASSICAL_POLICIES
    from footstep_gym.planners.reactive import REACTIVE_POLICIES

    names = {*REACTIVE_POLICIES, *CLASSICAL_POLICIES}
    scores = board.get("scores")
    if isinstance(scores, dict):
        names |= set(scores.get("reactive_baselines") or [])
    return names


def load_site_data(root: Path, board_dir: Path | None = None) -> SiteData:
    """Everything the site shows, from the committed files under ``root`` (the repository)."""
    board_dir = board_dir or root / SHOWN_BOARD_DIR
    board_path = board_dir / "leaderboard.json"
    if not board_path.is_file():
        raise SiteError(f"{board_path}: no leaderboard.json (python baselines/make_leaderboard.py writes it)")
    board = _read_json(board_path)
    if not isinstance(board, dict) or board.get("leaderboard") != "footstep_gym" or "policies" not in board:
        raise SiteError(f"{board_path}: not a footstep_gym leaderboard.json")
    methods = []
    baselines = _baselines(board)
    for row in list(board["policies"]) + list(board.get("in_distribution") or []):
        name = row["policy"]
        source = row.get("source")
        path = (root / source) if source and not Path(source).is_absolute() else board_dir / name / "benchmark.json"
        bench = _read_json(path) if path.is_file() else {}
        agents = root / "baselines/agents" / name
        found = sorted(agents.glob("*/manifest.json")) if agents.is_dir() else []
        manifests = [_read_json(p) for p in found]
        runs = row.get("runs") or [1]
        method = Method(name, row.get("label", name), _kind(row, baselines), row.get("track", "generalisation"),
                        row.get("trained_on_tier"), row.get("description", ""), bool(row.get("complete", True)),
                        int(max(runs)), path if path.is_file() else None, bench, manifests)
        if found:
            method.training, method.run_status = _training(root, row, [p.parent for p in found])
        methods.append(method)
    cells = [(t, *c.split("/", 1)) for t in board["tiers"] for c in board["tier_cells"][t]]
    tiers_path = root / "configs/benchmark.yaml"
    tiers_config = yaml.safe_load(tiers_path.read_text(encoding="utf-8")) if tiers_path.is_file() else {}
    videos_path = root / VIDEOS_DIR / "videos.json"
    videos = _read_json(videos_path) if videos_path.is_file() else {}
    return SiteData(root, board, board_path, methods, cells, tiers_config, videos)


def _training(root: Path, row: Mapping[str, Any], runs: Sequence[Path]) -> tuple[dict[str, Any], dict[str, Any]]:
    """A row's shipped runs under the compute protocol (``configs/compute.yaml``, read from ``root``): the row's
    summary (:func:`~footstep_gym.rl.compute.row_training`) and each run's status, from the manifests and curves."""
    from footstep_gym.rl import compute

    conf = (root / "configs" / "compute.yaml").resolve()
    proto = compute.load_protocol(conf if conf.is_file() else None)
    trained_on = row.get("trained_on_tier") if row.get("track") == "in-distribution" else None
    try:
        return (compute.row_training(runs, root / "baselines/agents", proto.budget(trained_on), proto.window),
                {r.name: compute.run_status(r, proto.window) for r in runs})
    except ValueError as exc:  # a curve that is not a success rate of whole episodes
        raise SiteError(f"{row.get('policy')}: {exc}") from None


# ---------------------------------------------------------------- figures of a row
def _num(x: Any) -> float | None:
    return None if x is None or (isinstance(x, float) and x != x) else float(x)


def tier_figure(data: SiteData, policy: str, tier: str) -> tuple[float | None, Sequence[float] | None]:
    """A row's figure on a tier and its 95 % interval: the board's scene-balanced success where it has ``scores``
    (protocol 3), its IQM otherwise; ``(None, None)`` where the row does not cover the tier."""
    if _scored(data, policy):
        for row in data.board["scores"]["tiers"]:
            if row.get("policy") == policy and row.get("tier") == tier:
                return _num(row.get("success")), row.get("success_ci95")
        return None, None
    for row in data.board.get("aggregates", []):
        if row["policy"] == policy and row["tier"] == tier:
            return _num(row.get("iqm")), row.get("iqm_ci95")
    return None, None


def _scored(data: SiteData, policy: str | None = None) -> bool:
    """Whether the board has ``scores`` (protocol 3) and, given ``policy``, tier scores of that row."""
    scores = data.board.get("scores")
    if not (isinstance(scores, dict) and scores.get("tiers")):
        return False
    return policy is None or any(row.get("policy") == policy for row in scores["tiers"])


def tier_label(data: SiteData, policy: str | None = None) -> str:
    """What :func:`tier_figure` gives: the board's (``policy`` None) or that row's."""
    return "scene-balanced success" if _scored(data, policy) else "IQM success"


def cell_summary(method: Method, tier: str, scene: str, cell: str) -> dict[str, Any] | None:
    """A row's record of one cell, pooled over its training runs (its ``benchmark.json`` summary)."""
    for rec in method.bench.get("summary", []):
        params = rec.get("params") or {}
        if ((rec.get("tier") or params.get("tier")) == tier and (rec.get("scene") or rec.get("scenario")) == scene
                and (rec.get("cell") or params.get("tier_cell")) == cell):
            return rec
    return None


# ---------------------------------------------------------------- HTML
def esc(x: Any) -> str:
    return html.escape(str(x), quote=True)


def fmt(x: float | None, digits: int = 2) -> str:
    return "–" if x is None else f"{x:.{digits}f}"


def interval_td(value: float | None, ci: Sequence[float] | None) -> str:
    """A table cell ``0.93 [0.88, 0.97]`` sorted by its value."""
    if value is None:
        return '<td data-v="-1" class="num">–</td>'
    text = fmt(value) + (f' <span class="ci">[{fmt(_num(ci[0]))}, {fmt(_num(ci[1]))}]</span>' if ci else "")
    return f'<td data-v="{value:.6f}" class="num">{text}</td>'


def num_td(value: float | None, digits: int = 2, scale: float = 1.0) -> str:
    if value is None:
        return '<td data-v="" class="num">–</td>'
    text = f"{value * scale:.{digits}f}"
    text = text.lstrip("-") if float(text) == 0 else text  # no "-0"
    return f'<td data-v="{value * scale:.6f}" class="num">{text}</td>'


def table(headers: Sequence[str], rows: Iterable[str], ident: str = "", caption: str = "") -> str:
    head = "".join(f'<th scope="col" title="click to sort">{h}</th>' for h in headers)
    cap = f"<caption>{caption}</caption>" if caption else ""
    idattr = f' id="{ident}"' if ident else ""
    return (f'<div class="scroll"><table class="sortable"{idattr}>{cap}<thead><tr>{head}</tr></thead>'
            f'<tbody>{"".join(rows)}</tbody></table></div>')


NAV = (("index.html", "Board"), ("cells.html", "Every cell"), ("methods/index.html", "Methods"),
       ("scenes/index.html", "Scenes and cells"), ("figures.html", "Figures"), ("protocol.html", "Protocol"),
       ("submit.html", "Submit your method"))


def page(title: str, body: str, depth: int = 0) -> str:
    up = "../" * depth
    nav = " ".join(f'<a href="{up}{href}">{esc(text)}</a>' for href, text in NAV)
    return (f'<!doctype html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f'<title>{esc(title)} · footstep_gym</title><link rel="icon" href="data:,">'
            f'<link rel="stylesheet" href="{up}assets/style.css"><script src="{up}assets/sortable.js" defer></script>'
            f'</head><body><header><span class="brand">footstep_gym</span><nav>{nav}</nav></header>'
            f'<main><h1>{esc(title)}</h1>\n{body}\n</main><footer>Built from the committed results by '
            f'<code>{esc(BUILD_COMMAND)}</code>; every file it shows is in the repository.</footer></body></html>\n')


def method_link(m: Method, depth: int = 0) -> str:
    badge = ' <span class="badge upper">upper bound</span>' if m.kind == "upper bound" else ""
    partial = "" if m.complete else ' <span class="badge partial">partial</span>'
    return f'<a href="{"../" * depth}{m.page}">{esc(m.name)}</a>{badge}{partial}'


def row_class(m: Method) -> str:
    return {"upper bound": "upper", "baseline": "baseline"}.get(m.kind, "")


def track_td(m: Method) -> str:
    """The track, short (the full name on hover)."""
    short = {"generalisation": "gen.", "in-distribution": "in-dist."}.get(m.track, m.track)
    return f'<td data-v="{esc(m.track)}" title="{esc(m.track)}">{esc(short)}</td>'


def budget(m: Method) -> tuple[str, float]:
    """The training budget as text (env steps per run against the track's declared budget, runs converged, the
    wall time of all runs) and as a sort key (the largest env steps per run)."""
    from footstep_gym.rl.compute import training_text

    if not m.manifests or not m.training:
        return ("no training", 0.0) if m.kind != "agent" else ("not shipped", 0.0)
    steps = m.training["env_steps_per_run"]
    return f"{training_text(m.training)}; {m.train_hours:.1f} h", float(steps[-1] if steps else 0)


def act_ms(m: Method) -> float | None:
    values = sorted(r["plan_ms_median"] for r in m.bench.get("summary", []) if r.get("plan_ms_median") is not None)
    return values[len(values) // 2] if values else None


# ---------------------------------------------------------------- pages
def board_page(data: SiteData) -> str:
    tiers = data.board["tiers"]
    label = tier_label(data)
    gen = [m for m in data.methods if m.track != "in-distribution"]
    ind = [m for m in data.methods if m.track == "in-distribution"]
    proto = data.board.get("protocol", {})
    intro = (f'<p>Protocol {esc(data.board.get("protocol_version"))}: {len(gen)} methods on the generalisation track '
             f'and {len(ind)} on the in-distribution track, {sum(len(v) for v in data.board["tier_cells"].values())} '
             f'cells in {len(tiers)} tiers, {esc(proto.get("episodes_per_cell"))} episodes per cell on the '
             f'<b>{esc(proto.get("split", "test"))}</b> split; configs <code>{esc(str(proto.get("env_configs_sha256", ""))[:12])}'
             f'</code>{_fingerprint(proto)}. Each tier: {esc(label)} with its 95 % interval. Upper bounds (italic) read the true '
             f'future and are not baselines; baselines are grey. Track: gen. = '
             f'generalisation (trained on <code>train</code>). Training budget: env steps per training run against '
             f'the track\'s declared budget and how many runs converged (the compute protocol of docs/benchmark.md, '
             f'read from the shipped agents\' manifests and learning curves), then the wall time of all runs. '
             f'Click a column to sort; '
             f'<a href="cells.html">every cell</a> is on its own page. Source: <code>{esc(_rel(data, data.board_path))}'
             f'</code>.</p>')
    ranking = {r["policy"]: r for r in (data.board.get("scores") or {}).get("ranking", [])} \
        if isinstance(data.board.get("scores"), dict) else {}
    extra = ["score", "safe score", "P(better than next)"] if ranking else []
    heads = ["method", "kind", "track", "runs"] + [esc(t) for t in tiers] + extra + ["training budget", "act ms"]
    rows = []
    for m in gen:
        text, key = budget(m)
        tds = [f'<td data-v="{esc(m.name)}" class="name">{method_link(m)}</td>', f'<td class="nowrap">{esc(m.kind)}</td>',
               track_td(m), num_td(m.runs, 0)]
        tds += [interval_td(*tier_figure(data, m.name, t)) for t in tiers]
        if ranking:
            r = ranking.get(m.name, {})
            tds += [num_td(_num(r.get(key))) for key in ("score", "safe_score", "p_improvement")]
        tds += [f'<td data-v="{key:.0f}" class="nowrap">{esc(text)}</td>', num_td(act_ms(m), 2)]
        rows.append(f'<tr class="{row_class(m)}">{"".join(tds)}</tr>')
    body = intro + _score_note(data) + "<h2>Generalisation track</h2>" + table(heads, rows, "board")
    rows = []
    for m in ind:
        text, key = budget(m)
        tds = [f'<td data-v="{esc(m.name)}" class="name">{method_link(m)}</td>', f"<td>{esc(m.trained_on_tier)}</td>",
               num_td(m.runs, 0)]
        tds += [interval_td(*tier_figure(data, m.name, t)) for t in tiers]
        tds += [f'<td data-v="{key:.0f}" class="nowrap">{esc(text)}</td>', num_td(act_ms(m), 2)]
        rows.append(f"<tr>{''.join(tds)}</tr>")
    if rows:
        body += ("<h2>In-distribution track</h2><p>Trained on a tier itself (its train seeds), tested on its cells; "
                 f"each tier: {esc(tier_label(data, ind[0].name))} with its 95 % interval.</p>"
                 + table(["method", "trained on", "runs"] + [esc(t) for t in tiers] + ["training budget", "act ms"],
                         rows, "board-in-distribution"))
    body += "<h2>Per tier</h2>" + "".join(_tier_table(data, t) for t in tiers)
    return page("Leaderboard", body)


def _score_note(data: SiteData) -> str:
    """What the score columns are (protocol 3's ranking), or nothing on a board without one."""
    scores = data.board.get("scores")
    if not (isinstance(scores, dict) and scores.get("ranking")):
        return ""
    ranked = ", ".join(scores.get("ranked_tiers") or [])
    t = scores.get("safety_thresholds") or {}
    safe = (f" (the goal reached with the episode's smallest clearance at least {1000 * t['min_clearance']:.0f} mm and "
            f"smallest ZMP margin at least {1000 * t['min_zmp_margin']:.0f} mm)"
            if {"min_clearance", "min_zmp_margin"} <= set(t) else "")
    return (f"<p>Score: the mean over the ranked tiers ({esc(ranked)}) of the scene-balanced success, which orders "
            f"the rows; safe score: the same of safe success{esc(safe)}; P(better than next): the probability that "
            "the row beats the next ranked row over the ranked cells (rliable). Privileged rows are not ranked.</p>")


def _fingerprint(proto: Mapping[str, Any]) -> str:
    fp = proto.get("fingerprint")
    return f', fingerprint <code>{esc(str(fp)[:12])}</code>' if fp else ""


def _rel(data: SiteData, path: Path) -> str:
    try:
        return str(path.resolve().relative_to(data.root.resolve()))
    except ValueError:
        return str(path)


def _tier_table(data: SiteData, tier: str) -> str:
    scenes = data.board["scenes"]
    per_scene = {(r["policy"], r["scene"]): r for r in data.board.get("per_scene", []) if r["tier"] == tier}
    aggs = {r["policy"]: r for r in data.board.get("aggregates", []) if r["tier"] == tier}
    fullbody = data.board.get("fullbody")  # the full-body column (docs/fullbody.md), on its tier's table
    fullbody = fullbody if isinstance(fullbody, dict) and fullbody.get("tier") == tier else None
    rows = []
    for m in data.methods:
        value, ci = tier_figure(data, m.name, tier)
        if value is None and m.name not in aggs:
            continue
        a = aggs.get(m.name, {})
        mine = tier_label(data, m.name)
        note = "" if mine == tier_label(data) else f' <span class="ci">({esc(mine)})</span>'  # a row the scores skip
        tds = [f'<td data-v="{esc(m.name)}">{method_link(m)}{note}</td>', f"<td>{esc(m.track)}</td>", num_td(m.runs, 0),
               interval_td(value, ci), interval_td(_num(a.get("optimality_gap")), a.get("optimality_gap_ci95")),
               num_td(_num(a.get("success_mean")))]
        for s in scenes:
            r = per_scene.get((m.name, s), {})
            tds.append(interval_td(_num(r.get("success_mean")), r.get("success_ci95")))
        if fullbody:
            e = fullbody["policies"].get(m.name)
            tds.append(num_td(None) if e is None or not e["episodes"] else
                       f'<td data-v="{float(e["op3_no_fall"]):.6f}" class="num" title="env success '
                       f'{float(e["env_success"]):.2f} on the same {int(e["episodes"])} episodes">'
                       f'{float(e["op3_no_fall"]):.2f} <span class="ci">({int(e["episodes"])})</span></td>')
        rows.append(f'<tr class="{row_class(m)}">{"".join(tds)}</tr>')
    cells = ", ".join(f'<a href="{cell_page(tier, *c.split("/", 1))}">{esc(c)}</a>'
                      for c in data.board["tier_cells"][tier])
    about = (data.tiers_config.get(tier) or {}).get("about", "")
    heads = ["method", "track", "runs", esc(tier_label(data)), "optimality gap", "mean success"] + \
        [f"{esc(s)} success" for s in scenes] + \
        ([f"full body ({esc(fullbody['robot'])}): no fall (episodes)"] if fullbody else [])
    return (f'<h3 id="tier-{slug(tier)}">{esc(tier)}</h3><p>{esc(about)}. Cells: {cells}.</p>'
            + table(heads, rows, f"tier-table-{slug(tier)}"))


CELL_HEADS = ["success", "collision", "fall", "timeout", "time to goal [s]", "clearance median [mm]", "act ms median"]


def _cell_tds(rec: Mapping[str, Any] | None) -> list[str]:
    if rec is None:
        return ['<td data-v="-1" class="num">–</td>'] + [num_td(None)] * 6
    return [interval_td(_num(rec.get("success_rate")), rec.get("success_ci95")), num_td(_num(rec.get("collision_rate"))),
            num_td(_num(rec.get("fall_rate"))), num_td(_num(rec.get("timeout_rate"))), num_td(_num(rec.get("mean_time")), 1),
            num_td(_num(rec.get("min_clearance_median")), 0, 1000.0), num_td(_num(rec.get("plan_ms_median")), 2)]


def cells_page(data: SiteData) -> str:
    rows = []
    for m in data.methods:
        for tier, scene, cell in data.cells:
            rec = cell_summary(m, tier, scene, cell)
            if rec is None:
                continue
            link = f'<a href="{cell_page(tier, scene, cell)}">{esc(cell)}</a>'
            rows.append(f'<tr class="{row_class(m)}"><td data-v="{esc(m.name)}">{method_link(m)}</td><td>{esc(m.track)}'
                        f'</td><td>{esc(tier)}</td><td>{esc(scene)}</td><td data-v="{esc(cell)}">{link}</td>'
                        f'{"".join(_cell_tds(rec))}</tr>')
    body = ("<p>Every method on every cell it ran, pooled over its training runs: success with its 95 % Wilson "
            "interval, the other outcomes' rates, time to goal over successes, the median over episodes of the "
            "smallest clearance, and the median act time per footstep. Click a column to sort.</p>"
            + table(["method", "track", "tier", "scene", "cell"] + CELL_HEADS, rows, "cells"))
    return page("Every cell", body)


def _kv_table(pairs: Iterable[tuple[str, str]]) -> str:
    return '<table class="kv">' + "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in pairs) + "</table>"


def _hyperparameters(data: SiteData, m: Method) -> str:
    """The training config of each of the agent's scenes: the rl_zoo3 entry its manifests' command read."""
    out = []
    for env_id in sorted({mf.get("env_id") for mf in m.manifests if mf.get("env_id")}):
        mf = next(x for x in m.manifests if x.get("env_id") == env_id)
        command = str(mf.get("command", ""))
        conf = re.search(r"--conf-file\s+(\S+)", command)
        entry: Any = None
        if conf and (data.root / conf.group(1)).is_file():
            loaded = yaml.safe_load((data.root / conf.group(1)).read_text(encoding="utf-8")) or {}
            entry = loaded.get(env_id)
        shown = {k: v for k, v in mf.items() if k not in ("versions", "command")} if entry is None else entry
        where = f" (<code>{esc(conf.group(1))}</code>)" if conf and entry is not None else " (its manifest)"
        out.append(f"<h3>{esc(env_id)}{where}</h3><pre>{esc(yaml.safe_dump(shown, sort_keys=False))}</pre>"
                   f"<p>Command: <code>{esc(command)}</code></p>")
    return "".join(out)


def method_page(data: SiteData, m: Method, figures: dict[str, str]) -> str:
    run = m.bench.get("run") or {}
    text, _ = budget(m)
    pairs = [("what it is", esc(m.description)), ("kind", esc(m.kind)), ("track", esc(m.track)),
             ("trained on tier", esc(m.trained_on_tier or "train" if m.kind == "agent" else "no training")),
             ("training runs", esc(m.runs)), ("complete", "yes" if m.complete else "no (a partial run)"),
             ("training budget", esc(text)),
             ("evaluation", f'<code>{esc(run.get("command", "–"))}</code>, {esc(run.get("wall_time_s", "–"))} s wall on '
                            f'{esc(run.get("cpu_count", "?"))} cores ({esc(run.get("workers", "?"))} workers)'),
             ("median act time", f"{fmt(act_ms(m))} ms per footstep (median over cells)"),
             ("results file", f'<code>{esc(_rel(data, m.source)) if m.source else "–"}</code>')]
    body = _kv_table(pairs)
    tiers = data.board["tiers"]
    body += "<h2>Tiers</h2>" + table(["tier", esc(tier_label(data, m.name))],
                                     (f"<tr><td>{esc(t)}</td>{interval_td(*tier_figure(data, m.name, t))}</tr>"
                                      for t in tiers), "method-tiers")
    rows = []
    for tier, scene, cell in data.cells:
        rec = cell_summary(m, tier, scene, cell)
        if rec is not None:
            rows.append(f'<tr><td>{esc(tier)}</td><td>{esc(scene)}</td><td data-v="{esc(cell)}"><a href="../'
                        f'{cell_page(tier, scene, cell)}">{esc(cell)}</a></td>{"".join(_cell_tds(rec))}</tr>')
    body += "<h2>Cells</h2>" + table(["tier", "scene", "cell"] + CELL_HEADS, rows, "method-cells")
    if m.manifests:
        def converged(mf: Mapping[str, Any]) -> str:
            st = m.run_status.get(f"{mf.get('env_id')}_{mf.get('seed')}") or {}
            c = st.get("converged")
            return "no curve" if c is None else ("yes" if c else "no") + f" ({st['points']} points of {st['episodes']})"

        runs = [f"<tr><td>{esc(mf.get('env_id'))}</td><td class='num'>{esc(mf.get('seed'))}</td><td class='num'>"
                f"{esc(mf.get('timesteps'))}</td><td class='num'>{esc(mf.get('wall_time_s'))}</td><td class='num'>"
                f"{esc(mf.get('cpu_time_s', '–'))}</td><td class='num'>"
                f"{esc(mf.get('n_envs'))}</td><td class='num'>{esc(mf.get('final_eval_success'))}</td>"
                f"<td>{esc(converged(mf))}</td></tr>" for mf in m.manifests]
        body += ("<h2>Training runs and cost</h2>" + table(["env", "seed", "env steps", "wall time [s]", "CPU time [s]",
                                                            "envs", "final validation success",
                                                            "converged (compute protocol)"], runs, "method-runs")
                 + "<h2>Hyperparameters</h2>" + _hyperparameters(data, m))
    planner_yaml = data.root / "configs/planner.yaml"
    if m.kind in ("planner", "upper bound") and planner_yaml.is_file():
        body += ("<h2>Settings</h2><p>The planners read <code>configs/planner.yaml</code> (a variant's switches are in "
                 "its name, e.g. <code>-no-tracking</code>):</p><details><summary>configs/planner.yaml</summary><pre>"
                 f"{esc(planner_yaml.read_text(encoding='utf-8'))}</pre></details>")
    curves = [(k, v) for k, v in figures.items() if k.startswith(f"learning_curves/{m.name}_")]
    if curves:
        body += "<h2>Learning curves</h2>" + "".join(
            f'<figure><img src="../{esc(v)}" alt="learning curve {esc(k)}"><figcaption>{esc(k)}</figcaption></figure>'
            for k, v in curves)
    return page(f"{m.name}", body, 1)


def methods_index(data: SiteData) -> str:
    rows = (f'<tr class="{row_class(m)}"><td data-v="{esc(m.name)}">{method_link(m, 1)}</td><td>{esc(m.kind)}</td>'
            f'<td>{esc(m.track)}</td><td>{esc(m.description)}</td></tr>' for m in data.methods)
    return page("Methods", table(["method", "kind", "track", "what it is"], rows, "methods"), 1)


def _scene_of(data: SiteData, scene: str) -> list[tuple[str, str]]:
    return [(t, c) for t, s, c in data.cells if s == scene]


def scene_page_name(scene: str) -> str:
    return f"scenes/{slug(scene)}.html"


def scenes_index(data: SiteData, frames: dict[str, str]) -> str:
    body = []
    for scene in data.board["scenes"]:
        img = frames.get(scene)
        pic = f'<img class="frame" src="../{esc(img)}" alt="the {esc(scene)} scene">' if img else ""
        links = "".join(f'<li><a href="../{cell_page(t, scene, c)}">{esc(t)}/{esc(c)}</a></li>'
                        for t, c in _scene_of(data, scene))
        body.append(f'<h2 id="{slug(scene)}"><a href="../{scene_page_name(scene)}">{esc(scene)}</a></h2>{pic}'
                    f'<ul>{links}</ul>')
    return page("Scenes and cells", "".join(body), 1)


def scene_page(data: SiteData, scene: str, frames: dict[str, str]) -> str:
    """One scene: its picture, its cells, and every method's success on each of them (a column per cell)."""
    cells = _scene_of(data, scene)
    img = frames.get(scene)
    body = f'<img class="frame" src="../{esc(img)}" alt="the {esc(scene)} scene">' if img else ""
    heads = ["method", "kind"] + [f'<a href="../{cell_page(t, scene, c)}">{esc(t)}/{esc(c)}</a>' for t, c in cells]
    rows = []
    for m in data.methods:
        recs = [cell_summary(m, t, scene, c) for t, c in cells]
        if any(r is not None for r in recs):
            tds = [f'<td data-v="{esc(m.name)}" class="name">{method_link(m, 1)}</td>', f"<td>{esc(m.kind)}</td>"]
            tds += [interval_td(_num(r.get("success_rate")), r.get("success_ci95")) if r else interval_td(None, None)
                    for r in recs]
            rows.append(f'<tr class="{row_class(m)}">{"".join(tds)}</tr>')
    body += ("<p>Success on each of the scene's cells, pooled over training runs, with its 95 % Wilson interval; a "
             "cell's name opens its page (its rule, keywords and videos).</p>" + table(heads, rows, "scene-cells"))
    return page(f"Scene: {scene}", body, 1)


def _cell_keywords(data: SiteData, tier: str, scene: str, cell: str) -> Any:
    for m in data.methods:
        for c in (m.bench.get("protocol") or {}).get("cells", []):
            if (c.get("tier"), c.get("scene"), c.get("cell")) == (tier, scene, cell):
                return {"env_id": c.get("env_id"), "env_kwargs": c.get("env_kwargs")}
    return None


def cell_html(data: SiteData, tier: str, scene: str, cell: str, video: Mapping[str, Any] | None) -> str:
    conf = data.tiers_config.get(tier) or {}
    entry = (conf.get(scene) or {}).get(cell)
    pairs = [("scene", f'<a href="../{scene_page_name(scene)}">{esc(scene)}</a>'),
             ("tier", f'<a href="../index.html#tier-{slug(tier)}">{esc(tier)}</a>: {esc(conf.get("about", ""))}'),
             ("the tier's rule", f"<code>{esc(json.dumps(conf.get('rule')))}</code>"),
             ("the cell's entry (configs/benchmark.yaml)", f"<code>{esc(json.dumps(entry))}</code>"),
             ("runs as", f"<code>gymnasium.make(ENV_ID, tier={esc(repr(tier))}, tier_cell={esc(repr(cell))})</code>")]
    kw = _cell_keywords(data, tier, scene, cell)
    body = _kv_table(pairs)
    if kw is not None:
        body += f"<h2>Its env keywords</h2><pre>{esc(yaml.safe_dump(kw, sort_keys=False))}</pre>"
    if not video:
        body += ('<p class="note">No episode video of this cell is committed; '
                 f'<code>{esc(data.videos.get("command", "python baselines/make_site.py --videos"))}</code> makes them.</p>')
    else:
        outcomes = "; ".join(f"{esc(k)}: {esc(v)}" for k, v in (video.get("outcomes") or {}).items())
        body += (f'<h2>One episode, side by side</h2><video src="../{esc(video["href"])}" controls muted loop playsinline '
                 f'preload="auto" width="{esc(video.get("width", 1200))}"></video><p class="note">Validation seed '
                 f'{esc(data.videos.get("seed"))}, the same for every method (left to right: '
                 f'{esc(", ".join(data.videos.get("methods", [])))}); outcomes: {outcomes}. Made by '
                 f'<code>{esc(data.videos.get("command", ""))}</code> (2D renders, '
                 f'<code>render_mode="rgb_array_list"</code>).</p>')
    rows = []
    for m in data.methods:
        rec = cell_summary(m, tier, scene, cell)
        if rec is not None:
            rows.append(f'<tr class="{row_class(m)}"><td data-v="{esc(m.name)}">{method_link(m, 1)}</td>'
                        f'<td>{esc(m.track)}</td>{"".join(_cell_tds(rec))}</tr>')
    body += "<h2>Every method on this cell</h2>" + table(["method", "track"] + CELL_HEADS, rows, "cell-methods")
    return page(f"{tier} / {scene} / {cell}", body, 1)


def figures_page(figures: dict[str, str]) -> str:
    body = "".join(f'<figure><img src="{esc(v)}" alt="{esc(k)}"><figcaption><code>{esc(k)}</code></figcaption></figure>'
                   for k, v in figures.items() if not k.startswith("learning_curves/"))
    return page("Figures", "<p>The board's figures (rliable: per tier, stratified bootstrap over runs), scaled to "
                f"at most {SCREEN_WIDTH} px wide.</p>" + body)


# ---------------------------------------------------------------- assets and the build
def _copy_figure(src: Path, dst: Path) -> None:
    """A PNG copied, scaled down to :data:`SCREEN_WIDTH` where wider."""
    from PIL import Image

    dst.parent.mkdir(parents=True, exist_ok=True)
    with Image.open(src) as im:
        if im.width <= SCREEN_WIDTH:
            shutil.copyfile(src, dst)
            return
        h = round(im.height * SCREEN_WIDTH / im.width)
        im.resize((SCREEN_WIDTH, h), Image.LANCZOS).save(dst, optimize=True)


def _figures(data: SiteData, out: Path) -> dict[str, str]:
    """The board's figures and the learning curves, copied in: ``{name: href}``."""
    found: dict[str, str] = {}
    board_dir = data.board_path.parent
    for src in sorted(board_dir.glob("*.png")):
        href = f"assets/figures/{src.name}"
        _copy_figure(src, out / href)
        found[src.name] = href
    curves = data.root / "baselines/results/learning_curves"
    names = {m.name for m in data.methods}
    for src in sorted(curves.glob("*.png")) if curves.is_dir() else []:
        if src.name.rsplit("_", 1)[0] in names:
            href = f"assets/curves/{src.name}"
            _copy_figure(src, out / href)
            found[f"learning_curves/{src.name}"] = href
    return found


def _frames(data: SiteData, out: Path) -> dict[str, str]:
    found = {}
    for scene in data.board["scenes"]:
        src = data.root / "baselines/results/frames" / f"{scene}.png"
        if src.is_file():
            _copy_figure(src, out / "assets/frames" / src.name)
            found[scene] = f"assets/frames/{src.name}"
    return found


def _videos(data: SiteData, out: Path) -> dict[str, dict[str, Any]]:
    """The committed videos of the board's cells, copied in: ``{tier/scene/cell: entry with its href}``."""
    got = {}
    for key, entry in (data.videos.get("videos") or {}).items():
        src = data.root / VIDEOS_DIR / entry["file"]
        if src.is_file():
            dst = out / "assets/videos" / Path(entry["file"]).name
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, dst)
            got[key] = {**entry, "href": f"assets/videos/{dst.name}"}
    return got


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")


def check_out(out: Path) -> None:
    """Refuse an ``out`` that is a file, or a non-empty folder that is not a site this module wrote."""
    if out.exists() and not out.is_dir():
        raise SiteError(f"--out {out}: a file, not a folder")
    if out.is_dir() and any(out.iterdir()) and not (out / MARKER).is_file():
        raise SiteError(f"--out {out}: a non-empty folder that is not a site make_site.py wrote (no {MARKER}); "
                        "give an empty or new folder")


def build_site(root: Path, out: Path, board_dir: Path | None = None) -> list[Path]:
    """Build the site from the committed files under ``root`` into ``out`` (written into a temporary folder beside
    it, then moved in, so a failed build leaves ``out`` as it was). Returns the pages written."""
    from footstep_gym.evaluation import site_docs

    out = Path(out)
    check_out(out)
    data = load_site_data(Path(root), board_dir)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        shutil.copytree(ASSETS, tmp / "assets")
        figures = _figures(data, tmp)
        frames = _frames(data, tmp)
        videos = _videos(data, tmp)
        pages = {"index.html": board_page(data), "cells.html": cells_page(data), "figures.html": figures_page(figures),
                 "methods/index.html": methods_index(data), "scenes/index.html": scenes_index(data, frames)}
        for m in data.methods:
            pages[m.page] = method_page(data, m, figures)
        for scene in data.board["scenes"]:
            pages[scene_page_name(scene)] = scene_page(data, scene, frames)
        for tier, scene, cell in data.cells:
            pages[cell_page(tier, scene, cell)] = cell_html(data, tier, scene, cell,
                                                            videos.get(cell_key(tier, scene, cell)))
        protocol, submit = site_docs.render_protocol(data.root / "docs/benchmark.md", tmp)
        pages["protocol.html"] = page("The protocol", protocol)
        pages["submit.html"] = page("Submit your method", submit)
        for name, text in pages.items():
            _write(tmp / name, text)
        (tmp / MARKER).write_text("written by footstep_gym.evaluation.site\n", encoding="utf-8")
        if out.exists():
            shutil.rmtree(out)
        tmp.replace(out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return [out / name for name in pages]
