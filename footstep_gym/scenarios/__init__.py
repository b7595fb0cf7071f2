"""The three scenes of the paper, each a :class:`Scenario` with its config in ``configs/scenarios/``."""

from footstep_gym.scenarios.base import Scenario, ScenarioConfig
from footstep_gym.scenarios.crossing import Crossing, CrossingConfig
from footstep_gym.scenarios.crowd import Crowd, CrowdConfig
from footstep_gym.scenarios.door import Door, DoorConfig

SCENARIOS: dict[str, type[Scenario]] = {"door": Door, "crossing": Crossing, "crowd": Crowd}

__all__ = ["SCENARIOS", "Scenario", "ScenarioConfig", "Door", "DoorConfig", "Crossing", "CrossingConfig",
           "Crowd", "CrowdConfig"]
