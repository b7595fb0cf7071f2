"""footstep_gym: Gymnasium environments for humanoid footstep planning with the walking period.

``import footstep_gym`` registers one env per scenario of ``footstep_gym.scenarios.SCENARIOS``
(``FootstepDoor-v0``, ``FootstepCrossing-v0``, ``FootstepCrowd-v0``; :data:`ENV_IDS` maps
scene names to them) and ``FootstepMix-v0`` (each episode one of the scenes);
``gymnasium.make("footstep_gym:FootstepDoor-v0")`` does it without a prior import.

The ids are registered without ``max_episode_steps``: each env truncates by itself at its
scenario's ``max_steps`` (which ``env.spec.max_episode_steps`` reports), and a registered
limit would make ``gymnasium.make`` add a second one, a ``TimeLimit`` wrapper
(``FootstepEnv``'s docstring, "Episode End").
"""

from gymnasium.envs.registration import register, registry

from footstep_gym.errors import ActionError, ConfigError, FootstepGymError

__version__ = "0.1.0"

#: The env whose every episode draws one of the scenes (``footstep_gym.mix``).
MIX_ENV_ID = "FootstepMix-v0"

# Registers each scenario's env id; ENV_IDS is a live view of the registry (scene name -> env id).
from footstep_gym.scenarios import ENV_IDS, resolve_env_id  # noqa: E402

if MIX_ENV_ID not in registry:
    register(id=MIX_ENV_ID, entry_point="footstep_gym.mix:FootstepMixEnv")

__all__ = ["ENV_IDS", "MIX_ENV_ID", "ActionError", "ConfigError", "FootstepGymError", "resolve_env_id",
           "__version__"]

# The one factory of policies, planners, trained agents and imported ones alike (footstep_gym/registry.py; the
# interface is footstep_gym.policy.Policy). Light: the planners, footstep_gym.rl and torch load only when needed.
from footstep_gym.registry import make_policy  # noqa: E402

__all__ += ["make_policy"]
