"""What the evaluation says in words: counts that match the table, plurals, and the one-line errors' grammar."""

from __future__ import annotations

import gymnasium as gym
import pytest

from footstep_gym.errors import ConfigError
from footstep_gym.evaluation import profiles
from footstep_gym.evaluation.runner import Cell
from footstep_gym.evaluation.tables import plural


def test_the_announced_cells_are_the_tables_rows():
    door = (("door_speed", 17.0),)
    cells = [Cell("FootstepDoor-v0", "door", "fixed-period", door)]
    assert profiles.describe_cells(cells) == "1 cell"
    cells += [Cell("FootstepDoor-v0", "door", "ppo", door, run=f"runs/FootstepDoor-v0_{k}") for k in (1, 2, 3)]
    cells += [Cell("FootstepCrowd-v0", "crowd", "ppo", (), run=f"runs/FootstepCrowd-v0_{k}") for k in (1, 2, 3)]
    assert profiles.describe_cells(cells) == "3 cells (7 with the agents' training runs)"


def test_plurals():
    assert [plural(n, "policy") for n in (0, 1, 2)] == ["0 policies", "1 policy", "2 policies"]
    assert [plural(n, "cell") for n in (1, 3)] == ["1 cell", "3 cells"]
    assert plural(2, "day") == "2 days"


def test_a_randomize_range_above_its_bound_reads_as_a_sentence():
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepDoor-v0", randomize={"door_speed": [5.0, 1000.0]})
    assert "randomize.door_speed reaches 1000 deg/s, above max_door_speed=" in str(exc.value)
    with pytest.raises(ConfigError) as exc:
        gym.make("FootstepDoor-v0", door_speed=1000.0)
    assert "door_speed=1000 deg/s is above max_door_speed=" in str(exc.value)
