"""The results pages, written from the committed result files: ``docs/results.md``, the generated blocks of
``README.md``, ``docs/benchmark.md`` and ``docs/speed.md``, and each committed evaluation's ``summary.md``.

Nothing here runs an episode: every number comes from a file under ``baselines/results/`` (each evaluation's
``run.json`` and ``results.json``, the speed run's ``speed/speed.md`` and its tiers run's ``speed_tiers/speed.md``,
the soak's ``soak.md``, the leaderboard's ``benchmark/leaderboard.{md,json}``), from a shipped agent's
``manifest.json`` under ``baselines/agents/``, or from ``configs/eval.yaml`` (the seed splits). :func:`render_docs`
gives the text each page must have; ``baselines/make_results_doc.py`` writes it (``--check``: only says which page
is stale) and ``tests/test_docs.py`` fails when a committed page differs from it, so a re-run whose results are
committed without the pages shows up.

``docs/results.md`` is generated whole: the leaderboard, one section per evaluation folder (those of
:data:`EVALUATIONS` first, then any other folder holding a ``run.json`` and a ``results.json``), then the shipped
agents' training runs.
``README.md``, ``docs/benchmark.md`` and ``docs/speed.md`` (:data:`COG_PAGES`) are written by hand around blocks
that `cog <https://cog.readthedocs.io>`_ fills (``cog -r README.md`` does what the script does for that page), each
block naming what fills it (:data:`BLOCKS`)::

    <!-- [[[cog import footstep_gym.evaluation.results_doc as r; r.cog_block(cog, "splits") ]]] -->
    ...
    <!-- [[[end]]] -->
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import pandas as pd

from footstep_gym.evaluation.board import SHOWN_BOARD_DIR
from footstep_gym.evaluation.records import CellRecord, frame, load_records
from footstep_gym.evaluation.report import ablation_table, paper_comparison
from footstep_gym.evaluation.tables import grid, interval, markdown, num

#: The page :func:`results_markdown` writes, and the hand-written pages with generated blocks, relative to the repo.
RESULTS_DOC = Path("docs") / "results.md"
SPEED_DOC = Path("docs") / "speed.md"
README = Path("README.md")
BENCHMARK_DOC = Path("docs") / "benchmark.md"
#: The hand-written pages with cog blocks.
COG_PAGES = (README, BENCHMARK_DOC, SPEED_DOC)
#: The command that regenerates the pages (shown in them).
COMMAND = "python baselines/make_results_doc.py"


@dataclass(frozen=True)
class Evaluation:
    """A committed evaluation: its folder under ``baselines/results/``, its title and what it is."""

    folder: str
    title: str
    about: str
    #: ``"wide"``: success and outcome tables, a column per policy; ``"ablation"``: the ablation's table.
    layout: str = "wide"


#: The evaluations of ``baselines/results/``, in the order the page shows them.
EVALUATIONS = (
    Evaluation("paper", "Reproduction of the paper",
               "The paper's protocol (`--paper`): the door at 8, 14 and 17 deg/s, the crossing and the crowd at "
               "its default speed, our three planners and the paper's planner as written "
               "(`paper-period-aware`, `paper-fixed-period`)."),
    Evaluation("robustness", "The planners on unseen seeds",
               "The period-aware and the fixed-period planner on test seeds that nobody looked at while the "
               "planner was built, over a sweep of door and crowd speeds."),
    Evaluation("agents", "Agents against the planners",
               "`--profile agents`: the shipped agents (`ppo`: three training seeds, summarised over them; "
               "`ppo-fixed-period`: the period held at nominal; `ppo-wide`: trained on wider ranges; `ppo-all`: one agent "
               "for the three scenes; `sac`, `td3`: sbx's SAC and TD3, three seeds per scene) against both planners, at settings "
               "each agent met only as part of its randomised training distribution, on test seeds disjoint "
               "from training."),
    Evaluation("ablation", "Ablation: what each addition buys",
               "`--ablation`: `period-aware`, the same with each of our additions switched off in turn "
               "(`period-aware-no-<switch>`), and the paper's planner (every addition off).",
               layout="ablation"),
)

#: The leaderboard rows the README's headline table shows (the whole board is in docs/results.md): the best of
#: each kind of method, the paper's comparison, the best null baseline and the upper bound.
HEADLINE_POLICIES = ("lookahead", "period-aware", "ppo-wide", "td3", "sac", "ppo", "ppo-jax", "lattice",
                     "fixed-period", "ppo-fixed-period", "null-walk-10cm-0.4s", "oracle")
#: The same on a protocol-3 board (ranked by its scene-balanced score): the planners, the classical and reactive
#: baselines, the learned rows at and below the budget, the paper's comparison, both privileged rows; the best of
#: the null baselines (by the board's score) is added to them.
HEADLINE_POLICIES_P3 = ("lookahead", "period-aware", "lattice", "ppo-jax-2e7", "ppo-wide", "td3", "orca-robot", "dwa",
                        "wait-until-clear", "straight-stop", "fixed-period", "oracle", "oracle-lookahead")


def headline_policies(board: dict[str, Any]) -> tuple[str, ...]:
    """The README's rows of ``board`` (a ``leaderboard.json``): :data:`HEADLINE_POLICIES`, or on a protocol-3 board
    :data:`HEADLINE_POLICIES_P3` and its best null baseline (of ``NULL_POLICIES``, the first in its ranking)."""
    from footstep_gym.planners.null import NULL_POLICIES

    if board.get("protocol_version", 2) < 3:
        return HEADLINE_POLICIES
    nulls = [r["policy"] for r in board["scores"]["ranking"] if r["policy"] in NULL_POLICIES]
    return HEADLINE_POLICIES_P3 + tuple(nulls[:1])


# ---------------------------------------------------------------- reading the files
def load_json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def evaluation_folders(results_dir: Path) -> list[Evaluation]:
    """The evaluations committed under ``results_dir``: those of :data:`EVALUATIONS` that exist, then any other
    folder with a ``run.json`` and a ``results.json`` (titled by its name), alphabetically."""
    known = [e for e in EVALUATIONS if (results_dir / e.folder / "results.json").is_file()]
    names = {e.folder for e in EVALUATIONS}
    extra = sorted(p.name for p in results_dir.iterdir() if p.is_dir() and p.name not in names
                   and (p / "results.json").is_file() and (p / "run.json").is_file())
    return known + [Evaluation(name, f"Evaluation `{name}`", "") for name in extra]


# ---------------------------------------------------------------- formatting
def setting_label(record: CellRecord) -> str:
    """``door 8 deg/s``, ``crowd 0.16 m/s``, ``crossing``; ``crowd (default)`` for a scene with a sweep axis run
    at its YAML's value; several keys as ``key=value``."""
    from footstep_gym.scenarios import SCENARIOS, units

    scene, params = record.scenario, record.params
    if len(params) == 1:
        (key, value), = params.items()
        unit = units(scene).get(key, "") if scene in SCENARIOS else ""
        return f"{scene} {value:g} {unit}".strip()
    if params:
        return f"{scene} " + ", ".join(f"{k}={v:g}" for k, v in params.items())
    swept = scene in SCENARIOS and SCENARIOS[scene].sweep_axes
    return f"{scene} (default)" if swept else scene


def success_text(r: CellRecord, failures: bool = True) -> str:
    """``0.95 [0.76, 0.99]``, then the IQM over training runs where there are several, then the non-zero failure
    rates: ``(c 0.05, f 0.00)`` with c / f / t = collision / fall / timeout."""
    text = interval(r.success_rate, r.success_ci95)
    if r.success_iqm is not None and len(r.runs or ()) > 1:
        text += f"; IQM {interval(r.success_iqm, r.success_iqm_ci95)}"
    if failures:
        rates = [f"{tag} {rate:.2f}" for tag, rate in (("c", r.collision_rate), ("f", r.fall_rate),
                                                       ("t", r.timeout_rate)) if rate > 0]
        if rates:
            text += f" ({', '.join(rates)})"
    return text


def outcome_text(r: CellRecord) -> str:
    """``26.9 / 12.5 / 2.60 / 0.46``: steps / time [s] / path [m] over the successes, mean period [s] over all."""
    return f"{num(r.mean_steps, 1)} / {num(r.mean_time, 1)} / {num(r.mean_path_length)} / {num(r.mean_period)}"


def policy_grid(records: list[CellRecord], policies: list[str], cell: Callable[[CellRecord], str]) -> str:
    """A markdown table with a row per setting (in the records' order) and a column per policy, each entry
    ``cell(record)``."""
    df = frame(records)
    df["setting"] = [setting_label(r) for r in records]
    df["text"] = [cell(r) for r in records]
    return markdown(grid(df, index="setting", columns="policy", values="text", order=policies))


def _policies(records: list[CellRecord]) -> list[str]:
    """The policies in a readable order: the staged planners first, then the other planners, then the agents."""
    present = list(dict.fromkeys(r.policy for r in records))
    first = [p for p in ("period-aware", "fixed-period", "pso-only", "paper-period-aware", "paper-fixed-period")
             if p in present]
    return first + [p for p in present if p not in first]


def _seeds(run: dict[str, Any]) -> str:
    seeds = run.get("seeds") or []
    if not seeds:
        return "no seeds recorded"
    contiguous = seeds == list(range(seeds[0], seeds[0] + len(seeds)))
    span = f"{seeds[0]}–{seeds[-1]}" if contiguous else ", ".join(map(str, seeds))
    return f"{len(seeds)} seeds of the {run.get('split', '?')} split per cell ({span})"


def _agent_runs(run: dict[str, Any]) -> str:
    names = [Path(p).parent.name + "/" + Path(p).name for p in run.get("agent_runs") or []]
    return ", ".join(f"`{n}`" for n in names)


def _provenance(folder: str, run: dict[str, Any], records: list[CellRecord]) -> str:
    episodes = sum(r.episodes for r in records)
    lines = [f"`{run['command']}`", "",
             f"- {len(records)} cells, {episodes:,} episodes: {_seeds(run)}; {run.get('workers', '?')} worker(s) "
             f"({run.get('backend', 'local')}), {run.get('wall_time_s', 0):.0f} s wall time; Python "
             f"{run.get('python', '?')} on {run.get('machine', '?')} with {run.get('cpu_count', '?')} cores, "
             f"footstep_gym {run.get('footstep_gym', '?')}."]
    if run.get("agent_runs"):
        lines.append(f"- Agents' training runs: {_agent_runs(run)}.")
    lines.append(f"- Every column (clearance, ZMP margin, act time, PSO share, ...): "
                 f"[`baselines/results/{folder}/summary.md`](../baselines/results/{folder}/summary.md); "
                 f"per episode: `episodes.csv`; per cell: `results.json`, `results.csv`.")
    return "\n".join(lines) + "\n"


def _figures(results_dir: Path, folder: str) -> str:
    figures = sorted((results_dir / folder / "figures").glob("*.png"))
    if not figures:
        return ""
    links = ", ".join(f"[{p.stem}](../baselines/results/{folder}/figures/{p.name})" for p in figures)
    return f"Figures (the policies side by side on one seed, in the spirit of the paper's Fig. 8–10): {links}.\n"


def evaluation_section(results_dir: Path, evaluation: Evaluation) -> str:
    """The section of one evaluation folder: what it is, how it was run, its tables, its figures."""
    folder = evaluation.folder
    run = load_json(results_dir / folder / "run.json")
    records = load_records(load_json(results_dir / folder / "results.json"))
    out = [f"## {evaluation.title}", ""]
    if evaluation.about:
        out += [evaluation.about, ""]
    out += [_provenance(folder, run, records)]
    if evaluation.layout == "ablation":
        base = "period-aware"
        present = list(dict.fromkeys(r.policy for r in records))
        order = [base] + sorted(p for p in present if p != base and not p.startswith("paper-")) \
            + sorted(p for p in present if p.startswith("paper-"))
        ordered = sorted(records, key=lambda r: order.index(r.policy))
        out += ["Each cell: success [Wilson 95 % CI] (difference to `period-aware` where it differs); steps / "
                "time (s) / path (m), means over the successes; median planning time per footstep.", "",
                ablation_table(ordered, base)]
    else:
        policies = _policies(records)
        out += ["**Success** [Wilson 95 % CI]; for an agent trained with several seeds the episodes are pooled "
                "over its runs, followed by the interquartile mean of the runs' success rates with its "
                "stratified-bootstrap interval (rliable); then the non-zero failure rates (c collision, "
                "f fall, t timeout).", "", policy_grid(records, policies, success_text)]
        out += ["**How**: steps / time (s) / path of the robot centre (m), means over the successful episodes "
                "(– without one); mean walking period T (s) over all footsteps.", "",
                policy_grid(records, policies, outcome_text)]
    if folder == "paper":
        comparison = paper_comparison(records).strip("\n")
        if comparison:
            out += [comparison.replace("## Against the paper", "**Against the paper's own runs** (one run each, "
                                       "[model.md §6](model.md#6-what-a-reproduction-must-show)):"), ""]
    figures = _figures(results_dir, folder)
    if figures:
        out += [figures]
    return "\n".join(out).rstrip("\n") + "\n"


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.0f} min" if seconds >= 600 else f"{seconds / 60:.1f} min"


def agent_name(folder: str, manifest: dict[str, Any]) -> str:
    """The registered agent (``footstep_gym.rl.AGENTS``) a shipped run under ``<agents>/<folder>/`` is: the entry of
    that folder trained on the run's env (``ppo-all`` for ``ppo/FootstepMix-v0_1``), else the one trained on the env
    evaluated; the manifest's own name if none fits."""
    from footstep_gym.rl.registry import AGENTS

    fits = [(entry.trained_on is None, name) for name, entry in AGENTS.items()
            if (entry.folder or entry.algo) == folder and entry.trained_on in (None, manifest["env_id"])]
    return min(fits)[1] if fits else manifest.get("agent") or manifest["algorithm"]


def training_section(agents_dir: Path) -> str:
    """The shipped agents' training runs, from their ``manifest.json``: budget, cost and final evaluation."""
    paths = sorted(agents_dir.glob("*/*/manifest.json"))
    if not paths:
        return ""
    manifests = [(agent_name(p.parent.parent.name, m), m) for p in paths for m in [load_json(p)]]
    manifests.sort(key=lambda nm: (nm[0], nm[1]["env_id"], nm[1]["seed"]))
    rows, notes = [], {}
    for name, m in manifests:
        eval_kwargs = re.search(r"--eval-env-kwargs (\S+)", m.get("command", ""))
        mark = ""
        if eval_kwargs:
            note = (f"periodic evaluation on the scene's default setting with `{eval_kwargs.group(1)}` "
                    "(`--eval-env-kwargs`), not on the randomised training distribution")
            mark = notes.setdefault(note, "¹²³⁴⁵"[len(notes)])
        rows.append([name, m["env_id"], str(m["seed"]), f"{m['timesteps']:,}",
                     str(m.get("n_envs", "?")), _minutes(m["wall_time_s"]), f"{m['env_steps_per_s']:,.0f}",
                     f"{m['final_eval_success']:.2f}{mark}", m.get("versions", {}).get("torch", "?")])
    out = ["## The shipped agents' training runs", "",
           "From each agent's `manifest.json` under [`baselines/agents/`](../baselines/agents/) "
           "(`python baselines/train_rl.py ... --ship`). Wall time includes start-up and the zoo's periodic "
           "evaluations; the final evaluation success is the zoo's last deterministic evaluation "
           "(on the randomised training distribution unless marked). The runs shared two cores with other "
           "work at different times, so their wall times are not comparable with each other.", "",
           markdown(pd.DataFrame(rows, columns=["agent", "env trained on", "seed", "timesteps", "envs", "wall time",
                                                "env steps/s (wall)", "final eval success", "torch"]), left=2)]
    for note, mark in notes.items():
        out += [f"{mark} {note[0].upper()}{note[1:]}.", ""]
    return "\n".join(out).rstrip("\n") + "\n"


def results_markdown(repo: Path) -> str:
    """The whole of ``docs/results.md`` for the result files under ``repo``."""
    results_dir = repo / "baselines" / "results"
    evaluations = evaluation_folders(results_dir)
    board = leaderboard_section(repo) if (repo / LEADERBOARD).is_file() else ""
    sections = ([board] if board else []) + [evaluation_section(results_dir, e) for e in evaluations]
    training = training_section(repo / "baselines" / "agents")
    titles = ([LEADERBOARD_TITLE] if board else []) + [e.title for e in evaluations] \
        + (["The shipped agents' training runs"] if training else [])
    toc = "\n".join(f"- [{t}](#{anchor(t)})" for t in titles)
    head = (f"# Results\n\n"
            f"<!-- Generated by `{COMMAND}` from baselines/results/ and baselines/agents/*/*/manifest.json: "
            f"do not edit by hand (tests/test_docs.py checks it). -->\n\n"
            "Every table below is generated from the committed result files by "
            f"`{COMMAND}`, and `tests/test_docs.py` fails when this page differs from what the script writes: "
            "re-run an evaluation into its folder under `baselines/results/`, then re-run the script. What the "
            "numbers mean for the paper's claims is in [reproduction.md](reproduction.md); the speed of the "
            "envs and planners is in [speed.md](speed.md).\n\n"
            f"Seeds come from disjoint splits, {splits_text()}; every evaluation here uses the test split of "
            "the protocol it was run under (protocol 1's test seeds, 20000–29999, joined validation when "
            "protocol 2 was cut). Each episode seeds the env and the "
            "policy with its seed, so a result does not depend on the worker that ran it. Scenes without a "
            "swept setting run at their YAML's values (`configs/scenarios/`); \"(default)\" marks them.\n\n"
            f"{toc}\n")
    return "\n".join([head, *sections, *([training] if training else [])]).rstrip("\n") + "\n"


def anchor(title: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", title.lower()).replace(" ", "-")


# ---------------------------------------------------------------- the leaderboard and the splits
#: The benchmark's leaderboard across policies (baselines/make_leaderboard.py): docs/results.md shows its tables,
#: the README some of its rows.
LEADERBOARD = SHOWN_BOARD_DIR / "leaderboard.md"
LEADERBOARD_TITLE = "The benchmark leaderboard"


def leaderboard_block(repo: Path, section: str | None = None) -> str:
    """A section of the committed ``leaderboard.md`` (its table and notes, as ``baselines/make_leaderboard.py`` wrote
    them; the bootstrap is not redone here): the generalisation track's headline (None: ``Scene-balanced success
    per tier`` on a protocol-3 board, ``IQM success per tier`` on an earlier one), or ``In-distribution track``."""
    path = repo / LEADERBOARD
    lines = path.read_text(encoding="utf-8").split("\n")
    if section is None:
        section = ("Scene-balanced success per tier" if "## Scene-balanced success per tier" in lines
                   else "IQM success per tier")
    try:
        start = lines.index(f"## {section}") + 1
    except ValueError:
        raise ValueError(f"{LEADERBOARD}: no '## {section}' section; regenerate it with "
                         "python baselines/make_leaderboard.py") from None
    end = next((i for i in range(start, len(lines)) if lines[i].startswith("## ")), len(lines))
    return "\n".join(lines[start:end]).strip("\n") + "\n"


def leaderboard_section(repo: Path) -> str:
    """docs/results.md's first section: the leaderboard's two tables (both tracks), its figures, where it lives."""
    folder = LEADERBOARD.parent.as_posix()
    return "\n".join([
        f"## {LEADERBOARD_TITLE}", "",
        "`python baselines/eval_planner.py --benchmark --policy NAME` runs one method on every cell of the five "
        "tiers ([benchmark.md](benchmark.md): `paper` = the paper's scenes, `train` = the training distribution, "
        "`shifted` = each training range moved one band beyond it, `structure` = a named structural change, "
        "`noise` = known scenes through the sensing-noise profile); `python baselines/make_leaderboard.py FOLDER` "
        f"gathers a board's rows (`FOLDER/<method>/`) into its `leaderboard.md`. The board shown here is "
        f"`{folder}/`'s: [`leaderboard.md`](../{LEADERBOARD.as_posix()}) (with the per-scene table). What the "
        "numbers show: [reproduction.md](reproduction.md#what-the-leaderboard-shows).",
        "", "**Generalisation track** (trained on `train`, tested on every tier):", "",
        leaderboard_block(repo).rstrip("\n"), "",
        "**In-distribution track** (trained on every cell of a tier, tested on that tier's test seeds):", "",
        leaderboard_block(repo, "In-distribution track").rstrip("\n"), "",
        *_board_figures(repo, folder),
    ]) + "\n"


def _board_figures(repo: Path, folder: str) -> list[str]:
    """The shown board's figures: protocol 3's scores figure first where the board has one, then the IQM grid, the
    per-tier optimality-gap figures and the performance profiles."""
    from footstep_gym.evaluation.leaderboard import FIGURE_IQM, FIGURE_PROFILES, FIGURE_SCORES, FIGURE_SCORES_CAPTION

    lines = []
    if (repo / folder / FIGURE_SCORES).is_file():
        lines += [f"![Scene-balanced success per tier](../{folder}/{FIGURE_SCORES})", "",
                  f"{FIGURE_SCORES_CAPTION[0].upper()}{FIGURE_SCORES_CAPTION[1:]} Protocol 2's figure, the IQM over "
                  "the tier's cells:", ""]
    return lines + [
        f"![IQM success per tier](../{folder}/{FIGURE_IQM})", "",
        f"Per tier with the optimality gap: `{folder}/iqm_optimality_gap_<tier>.png`; performance profiles: "
        f"[`{FIGURE_PROFILES}`](../{folder}/{FIGURE_PROFILES})."]


def leaderboard_headline(repo: Path) -> str:
    """The README's headline table: the leaderboard's table (``leaderboard.json``, as ``leaderboard.md`` shows it)
    restricted to the rows of :func:`headline_policies`: protocol 3's scored table (without the probability of
    improvement, which is over the next row of the whole board), an earlier board's IQM table."""
    from footstep_gym.evaluation.leaderboard import headline_markdown, scores_markdown

    board = load_json(repo / LEADERBOARD.with_suffix(".json"))
    rows = headline_policies(board)
    missing = [p for p in rows if p not in {q["policy"] for q in board["policies"]}]
    if missing:
        raise ValueError(f"{LEADERBOARD.with_suffix('.json')}: no row for {', '.join(missing)} (results_doc."
                         "HEADLINE_POLICIES names the README's rows)")
    shown = {**board, "policies": [p for p in board["policies"] if p["policy"] in rows]}
    if board.get("protocol_version", 2) >= 3:
        return scores_markdown(shown, p_next=False) + "\n"
    return headline_markdown(shown) + "\n"


def splits_text() -> str:
    """The seed splits as ``configs/eval.yaml`` has them: ``train 0–9999, validation 10000–29999, test 30000–39999
    (`configs/eval.yaml`, protocol 2)``."""
    from footstep_gym.evaluation.splits import PROTOCOL_VERSION, SPLITS

    ranges = ", ".join(f"{name} {first}–{end - 1}" for name, (first, end) in sorted(SPLITS.items(),
                                                                                     key=lambda kv: kv[1]))
    return f"{ranges} (`configs/eval.yaml`, protocol {PROTOCOL_VERSION})"


def splits_block(repo: Path) -> str:
    """The pages' sentence on the seed splits, from ``configs/eval.yaml``."""
    return f"**Seed splits**: {splits_text()}."


def _include(path: Path, skip: Callable[[str], bool] = lambda line: False) -> str:
    """A generated markdown file's body (its title dropped, its headings one level down)."""
    lines = path.read_text(encoding="utf-8").rstrip("\n").split("\n")
    if lines and lines[0].startswith("# "):
        lines = lines[1:]
    body = [("#" + line if line.startswith("#") else line) for line in lines if not skip(line)]
    return "\n".join(body).strip("\n") + "\n"


def speed_blocks(repo: Path) -> dict[str, str]:
    """The blocks of ``docs/speed.md``: the speed run's tables (``speed/speed.md``, which ``baselines/speed.py``
    writes beside ``speed.json``), its tiers section's own run (``speed_tiers/speed.md``, ``--sections
    tiers``) and the soak's (``soak.md``, without its RSS series)."""
    results = repo / "baselines" / "results"
    return {"speed": _include(results / "speed" / "speed.md"),
            "speed_tiers": _include(results / "speed_tiers" / "speed.md"),
            "soak": _include(results / "soak" / "soak.md", skip=lambda line: "current RSS [MiB] at steps" in line)}


#: The blocks of the hand-written pages: name -> what fills it from the repository (under ``baselines/``).
BLOCKS: dict[str, Callable[[Path], str]] = {
    "leaderboard_headline": leaderboard_headline,
    "splits": splits_block,
    "speed": lambda repo: speed_blocks(repo)["speed"],
    "speed_tiers": lambda repo: speed_blocks(repo)["speed_tiers"],
    "soak": lambda repo: speed_blocks(repo)["soak"],
}


def repo_of(page: Path) -> Path:
    """The repository a page is in: the nearest folder above it holding ``baselines/``."""
    for folder in Path(page).absolute().parents:
        if (folder / "baselines").is_dir():
            return folder
    raise ValueError(f"{page}: no baselines/ in any folder above it")


def block(name: str, page: Path) -> str:
    """The text of generated block ``name`` for ``page`` (a blank line before and after it)."""
    if name not in BLOCKS:
        raise ValueError(f"{page}: unknown generated block {name!r}; known: {', '.join(BLOCKS)}")
    return "\n" + BLOCKS[name](repo_of(page)).strip("\n") + "\n\n"


def cog_block(cog: Any, name: str) -> None:
    """Write block ``name`` into the page cog is processing: the call a page's ``[[[cog ...]]]`` makes, with the
    ``cog`` module cog gives it."""
    cog.out(block(name, Path(cog.inFile)))


def cog_page(path: Path, text: str | None = None) -> str:
    """``path``'s text (or ``text``, as if it were at ``path``) with every cog block regenerated; a bad block raises
    ``ValueError`` with cog's (or the block's own) one line."""
    from cogapp import Cog
    from cogapp.cogapp import CogError

    source = path.read_text(encoding="utf-8") if text is None else text
    try:
        return Cog().process_string(source, fname=str(path))
    except CogError as exc:
        last = str(exc).strip().splitlines()[-1]
        raise ValueError(last.removeprefix("ValueError: ")) from None


def summary_page(folder: Path) -> str:
    """An evaluation folder's ``summary.md`` written again from its ``run.json`` and ``results.json`` (its list of
    files, which no JSON holds, as the committed page has it)."""
    from footstep_gym.evaluation.outputs import summary_markdown

    text = (folder / "summary.md").read_text(encoding="utf-8")
    listing = re.findall(r"^- `([^`]+)`$", text.split("\n## Files\n", 1)[-1], re.M)
    return summary_markdown(load_json(folder / "run.json"), load_records(load_json(folder / "results.json")), listing)


def render_docs(repo: Path) -> dict[Path, str]:
    """``{path relative to repo: the text it must have}`` for every page this module writes or fills: the results
    page, the blocks of the hand-written pages, and each committed evaluation's ``summary.md``."""
    pages = {RESULTS_DOC: results_markdown(repo)}
    results_dir = repo / "baselines" / "results"
    for evaluation in evaluation_folders(results_dir):
        if (results_dir / evaluation.folder / "summary.md").is_file():
            pages[Path("baselines") / "results" / evaluation.folder / "summary.md"] = \
                summary_page(results_dir / evaluation.folder)
    for rel in COG_PAGES:
        if (repo / rel).is_file():
            pages[rel] = cog_page(repo / rel)
    return pages


def stale_docs(repo: Path) -> list[Path]:
    """The pages whose committed text differs from :func:`render_docs` (missing ones included)."""
    stale = []
    for rel, text in render_docs(repo).items():
        path = repo / rel
        if not path.is_file() or path.read_text(encoding="utf-8") != text:
            stale.append(rel)
    return stale
