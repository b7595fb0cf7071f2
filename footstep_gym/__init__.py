"""footstep_gym: Gymnasium environments for humanoid footstep planning with the walking period.

``import footstep_gym`` registers ``FootstepDoor-v0``, ``FootstepCrossing-v0``,
``FootstepCrowd-v0`` and ``FootstepMix-v0`` (each episode one of the three scenes);
``gymnasium.make("footstep_gym:FootstepDoor-v0")`` does it without a prior import.

The ids are registered without ``max_episode_steps``: each env truncates by itself at its
scenario's ``max_steps`` (which ``env.spec.max_episode_steps`` reports), and a registered
limit would make ``gymnasium.make`` add a second one, a ``TimeLimit`` wrapper
(``FootstepEnv``'s docstring, "Episode End").
"""

from gymnasium.envs.registration import register, registry

from footstep_gym.errors import ActionError, ConfigError, FootstepGymError

__version__ = "0.1.0"

ENV_IDS = {"door": "FootstepDoor-v0", "crossing": "FootstepCrossing-v0", "crowd": "FootstepCrowd-v0"}

for _scenario, _env_id in ENV_IDS.items():
    if _env_id not in registry:
        register(id=_env_id, entry_point="footstep_gym.env:FootstepEnv", kwargs={"scenario": _scenario})

#: The env whose every episode draws one of the three scenes (``footstep_gym.mix``).
MIX_ENV_ID = "FootstepMix-v0"
if MIX_ENV_ID not in registry:
    register(id=MIX_ENV_ID, entry_point="footstep_gym.mix:FootstepMixEnv")

__all__ = ["ENV_IDS", "MIX_ENV_ID", "ActionError", "ConfigError", "FootstepGymError", "__version__"]
