"""The privileged planners' decisions replayed: ``oracle-lookahead`` (and the ``oracle`` that seeds it) on a few short
validation episodes against the commands recorded from an earlier commit (``tests/data/oracle_lookahead_replay.json``,
its ``recorded_with``), so that a change made for speed is seen to change no decision: every footstep command within
a few ulps, the outcome and the footstep count exactly.

The episodes exercise the truth's three kinds of motion: the scripted crowd's schedule (circles), the crossing's
steady stream (segments that do not turn) and the doors' turning rods, with the cross-entropy search run on some of
their footsteps (``cem_acts``: where the oracle's plan did not hold for the horizon).

The fixture was recorded as :func:`episode` does here, run on the commit it names.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from footstep_gym.evaluation.benchmark import benchmark_cells
from footstep_gym.evaluation.runner import ActTiming, Cell, Task, run_episode
from footstep_gym.registry import resolve

FIXTURE = Path(__file__).parent / "data" / "oracle_lookahead_replay.json"
EPISODES = json.loads(FIXTURE.read_text())["episodes"]


def episode(policy: str, cell: str, seed: int) -> dict[str, Any]:
    """``policy`` on benchmark ``cell`` (``TIER/SCENE/CELL``) from ``seed``: its outcome, its footsteps, each
    footstep's command as the policy returned it, and how many footsteps ran the cross-entropy search."""
    tier, scene, name = cell.split("/")
    (bc,) = [b for b in benchmark_cells([scene], [tier]) if dict(b.selector)["tier_cell"] == name]
    commands: list[list[float]] = []
    cem = []

    def hook(t: ActTiming) -> bool:
        commands.append(np.asarray(t.action, dtype=float).reshape(5).tolist())
        cem.append(t.last_info.get("lookahead_kept_greedy") is False)
        return False

    result = run_episode(Task(0, Cell(bc.env_id, bc.scene, policy, bc.selector, entry=resolve(policy)), seed),
                         warm=False, on_step=hook)
    return {"policy": policy, "cell": cell, "seed": seed, "outcome": result.outcome, "steps": result.steps,
            "cem_acts": int(sum(cem)), "commands": commands}


@pytest.mark.parametrize("recorded", EPISODES, ids=lambda e: f"{e['policy']}-{e['cell']}-{e['seed']}")
def test_the_privileged_planner_decides_as_recorded(recorded):
    assert 10000 <= recorded["seed"] < 20000  # validation seeds only
    now = episode(recorded["policy"], recorded["cell"], recorded["seed"])
    assert (now["outcome"], now["steps"], now["cem_acts"]) == (recorded["outcome"], recorded["steps"],
                                                               recorded["cem_acts"])
    np.testing.assert_array_max_ulp(np.array(now["commands"]), np.array(recorded["commands"]), maxulp=4)
    assert recorded["cem_acts"] > 0  # the search itself ran, not only the oracle's plan
