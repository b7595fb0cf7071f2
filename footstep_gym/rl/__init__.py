"""The RL baselines in one place: training through rl_zoo3, shipping, and trained agents as policies.

* :mod:`.registry`: the registry of shipped agents (:data:`AGENTS`, :func:`agent_runs`, where the
  agents folder is: :func:`default_agents_dir`), below the modules that load and train them;
* :mod:`.training`: the zoo's command line (:func:`~.training.zoo_command`), a run in a
  subprocess (:func:`~.training.train`), shipping a run with its manifest
  (:func:`~.training.ship`), learning curves, PPO's throughput;
* :mod:`.jobs`: a grid of training runs, one after the other or as Ray tasks, and their learning curves;
* :mod:`.agents`: :class:`ZooAgent`, a zoo run (or a plain stable-baselines3 / sbx ``.zip``) as a
  :class:`footstep_gym.policy.Policy` (made by name with :func:`footstep_gym.make_policy`).

``import footstep_gym`` does not import this package; nothing here imports torch or
stable-baselines3 until an agent is loaded or trained.
"""

from footstep_gym.rl.agents import ZooAgent, check_run, resolve_run, training_env
from footstep_gym.rl.registry import AGENTS, AGENTS_DIR_ENV_VAR, AgentEntry, agent_runs, default_agents_dir

__all__ = ["AGENTS", "AGENTS_DIR_ENV_VAR", "AgentEntry", "ZooAgent", "agent_runs", "check_run",
           "default_agents_dir", "resolve_run", "training_env"]
