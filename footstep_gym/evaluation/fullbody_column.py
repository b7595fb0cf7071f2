"""The board's full-body column: how many of a method's episodes walk on the OP3 without a fall (docs/fullbody.md).

``baselines/fullbody.py replay`` writes one Markdown table per (scene, tier, policy, robot) into
``baselines/results/fullbody/`` (:func:`footstep_gym.fullbody.replay.markdown_table`: a summary table, then a row per
episode). :func:`summarise` reads the episode rows of one tier and robot and pools them per policy over the scenes;
:func:`write_summary` writes that as ``fullbody_<tier>_<robot>.json`` (and ``.csv``), the file the leaderboard reads
(:func:`load_summary`). Nothing here needs MuJoCo.
"""

from __future__ import annotations

import csv
import io
import json
import re
from pathlib import Path
from typing import Any, Mapping

#: The columns an episode row must have (``footstep_gym.fullbody.replay.table_rows``).
ROW_KEYS = ("env", "tier", "policy", "seed", "env_end", "op3_fell")
#: What a table says instead of its episode rows when none was walked (none admitted by the robot's box).
NO_EPISODE = "No episode walked."
#: What a table recorded with another robot says of the episodes it walked (:data:`NO_EPISODE` when none).
ADMITTED = re.compile(r"walked: the (\d+) of (\d+) episodes")
#: The columns of the summary's CSV, one row per policy.
SUMMARY_KEYS = ("policy", "episodes", "scenes", "op3_no_fall", "env_success", "env_success_and_op3_no_fall",
                "not_admitted")


class FullBodyError(ValueError):
    """A replay table or summary that cannot be read."""


def summary_name(tier: str = "paper", robot: str = "op3") -> str:
    """The summary's file name (without suffix) for ``tier`` and ``robot``."""
    return f"fullbody_{tier}_{robot}"


def episode_rows(path: Path) -> list[dict[str, str]]:
    """The per-episode rows of one replay table (its Markdown table whose header holds :data:`ROW_KEYS`)."""
    tables: list[list[list[str]]] = [[]]
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("|"):
            tables[-1].append([c.strip() for c in line.strip().strip("|").split("|")])
        elif tables[-1]:
            tables.append([])
    for table in tables:
        if table and all(k in table[0] for k in ROW_KEYS):
            head = table[0]
            rows = [dict(zip(head, r)) for r in table[2:]]
            if any(len(r) != len(head) for r in table[2:]):
                raise FullBodyError(f"{path}: a row of its episode table has not {len(head)} cells")
            return rows
    if NO_EPISODE in path.read_text(encoding="utf-8"):
        return []
    raise FullBodyError(f"{path}: no episode table (a header with {', '.join(ROW_KEYS)})")


def _flag(text: str, path: Path) -> bool:
    if text not in ("True", "False"):
        raise FullBodyError(f"{path}: op3_fell must be True or False, got {text!r}")
    return text == "True"


def summarise(folder: Path, tier: str = "paper", robot: str = "op3") -> dict[str, dict[str, Any]]:
    """``policy -> {episodes, scenes, op3_no_fall, env_success, env_success_and_op3_no_fall}`` pooled over the
    replay tables ``<env>_<tier>_<cell>_<policy>_<robot>.md`` in ``folder`` (every scene and cell); an episode
    (scene, policy, seed) replayed in two tables counts once, from the later file name. A policy whose episodes were
    recorded with another robot (an agent's, ``--recorded-with``) also gets ``not_admitted``: those its tables left
    out because the robot's box or swing floor does not hold their commands; if it left out every one, its
    ``episodes`` is 0 and its shares are None."""
    episodes: dict[tuple[str, str, str], tuple[bool, bool]] = {}
    left_out: dict[str, int] = {}  # per policy: episodes recorded with another robot that this one does not admit
    left_scenes: dict[str, set[str]] = {}
    for path in sorted(folder.glob(f"*_{tier}_*_{robot}.md")):
        text = path.read_text(encoding="utf-8")
        note = ADMITTED.search(text)
        if note:  # the title: "# <policy> on <env> (...)"
            title = text.splitlines()[0].removeprefix("# ").split(" (")[0].split(" on ")
            if len(title) != 2:
                raise FullBodyError(f"{path}: its first line is not '# <policy> on <env> ...'")
            policy, env = title
            left_out[policy] = left_out.get(policy, 0) + int(note.group(2)) - int(note.group(1))
            left_scenes.setdefault(policy, set()).add(env)
        for r in episode_rows(path):
            if r["tier"] != tier:
                raise FullBodyError(f"{path}: an episode of tier {r['tier']!r} in a table named for {tier!r}")
            episodes[(r["policy"], r["env"], r["seed"])] = (r["env_end"] == "goal", not _flag(r["op3_fell"], path))
    out: dict[str, dict[str, Any]] = {}
    for (policy, env, _), (success, walked) in sorted(episodes.items()):
        e = out.setdefault(policy, {"episodes": 0, "scenes": [], "_s": 0, "_w": 0, "_b": 0})
        e["episodes"] += 1
        e["scenes"] = sorted(set(e["scenes"]) | {env})
        e["_s"] += success
        e["_w"] += walked
        e["_b"] += success and walked
    for policy, n in left_out.items():
        if policy in out:
            out[policy]["not_admitted"] = n
        elif n:  # none of its episodes admitted: nothing walked
            out[policy] = {"episodes": 0, "scenes": sorted(left_scenes[policy]), "not_admitted": n}
    for e in out.values():
        n = e["episodes"]
        for key, part in (("op3_no_fall", "_w"), ("env_success", "_s"), ("env_success_and_op3_no_fall", "_b")):
            e[key] = round(e.pop(part) / n, 3) if n else None
    return dict(sorted(out.items()))


def write_summary(folder: Path, tier: str = "paper", robot: str = "op3") -> list[Path]:
    """:func:`summarise` written as ``<folder>/fullbody_<tier>_<robot>.json`` and ``.csv``; returns the paths."""
    policies = summarise(folder, tier, robot)
    if not policies:
        raise FullBodyError(f"{folder}: no replay table of tier {tier!r} and robot {robot!r}")
    stem = folder / summary_name(tier, robot)
    doc = {"fullbody": "footstep_gym", "tier": tier, "robot": robot,
           "what": "per policy, the share of its replayed episodes (validation seeds, pooled over the tier's scenes) "
                   "that walk on the OP3 without a fall, beside the share that succeed in the env with the same robot",
           "policies": policies}
    json_path, csv_path = stem.with_suffix(".json"), stem.with_suffix(".csv")
    json_path.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(SUMMARY_KEYS)
    for name, e in policies.items():
        writer.writerow([name, e["episodes"], " ".join(e["scenes"])]
                        + ["" if e[k] is None else e[k] for k in SUMMARY_KEYS[3:6]] + [e.get("not_admitted", "")])
    csv_path.write_text(buf.getvalue(), encoding="utf-8")
    return [json_path, csv_path]


def load_summary(path: Path) -> dict[str, Any]:
    """A summary written by :func:`write_summary`, checked: ``{tier, robot, policies, source}``."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise FullBodyError(f"{path}: cannot read the full-body summary ({exc})") from exc
    if not isinstance(doc, Mapping) or doc.get("fullbody") != "footstep_gym" or not isinstance(doc.get("policies"),
                                                                                                Mapping):
        raise FullBodyError(f"{path}: not a full-body summary (footstep_gym.evaluation.fullbody_column)")
    for name, e in doc["policies"].items():
        walked = isinstance(e, Mapping) and isinstance(e.get("episodes"), int) and e["episodes"] > 0 \
            and all(0.0 <= float(e.get(k, -1)) <= 1.0 for k in SUMMARY_KEYS[3:6])
        none_admitted = isinstance(e, Mapping) and e.get("episodes") == 0 and isinstance(e.get("not_admitted"), int) \
            and e["not_admitted"] > 0 and all(e.get(k, -1) is None for k in SUMMARY_KEYS[3:6])
        if not (walked or none_admitted):
            raise FullBodyError(f"{path}: policy {name!r} has no episodes walked or admitted, or a share outside "
                                f"[0, 1]")
    return {"tier": doc["tier"], "robot": doc["robot"], "policies": dict(doc["policies"]), "source": path.name}


def cell(summary: Mapping[str, Any] | None, policy: str) -> str | None:
    """The column's text for ``policy``: ``"<no fall> (<env success>, n)"`` (``n + k not admitted``: episodes
    recorded with another robot whose commands this one's box or swing floor refuses; ``"– (0 + k not admitted)"``
    when that is every one), or None if it was not replayed."""
    if not summary or policy not in summary["policies"]:
        return None
    e = summary["policies"][policy]
    left = f" + {e['not_admitted']} not admitted" if e.get("not_admitted") else ""
    if not e["episodes"]:
        return f"– (0{left})"
    return f"{e['op3_no_fall']:.2f} ({e['env_success']:.2f}, {e['episodes']}{left})"
