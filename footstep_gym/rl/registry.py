"""The registry of shipped agents: :data:`AGENTS` (name -> :class:`AgentEntry`) and where their runs are.

An entry says what the agent is (its rl_zoo3 algorithm, a one-line description, the env it was
trained on), where its runs ship (``<agents>/<folder>/<EnvId>_<seed>/``, :func:`agent_runs`) and
how it was trained (its hyperparameter file in ``configs/rl/``, the zoo's evaluation options), so
that ``baselines/train_rl.py --agent NAME`` trains it again as it was shipped.

Which agents folder: the ``agents_dir`` argument, else the environment variable
``FOOTSTEP_GYM_AGENTS_DIR``, else ``./baselines/agents`` relative to the current working directory,
else the ``baselines/agents`` of the checkout the package is imported from (:func:`default_agents_dir`).
The agents are not part of the installed package.

This module sits below what it lists: the loader (:mod:`.agents`) and the training
(:mod:`.training`) import it, it imports neither (nor torch).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class AgentEntry:
    """A shipped agent.

    ``algo``: its rl_zoo3 / stable-baselines3 algorithm (``ppo``, ``sac_sbx``); ``description``: one
    line (``eval_planner.py --help``); ``trained_on``: the env id it was trained on (None: the env
    being evaluated, one agent per env); ``folder``: its folder under the agents folder (default
    ``algo``); ``default_folder``: a run of ``algo`` shipped without naming an agent goes here (False
    for a second agent of an algorithm, which takes a run only when named).

    How it was trained (``train_rl.py --agent NAME``): ``config``, the stem of its hyperparameter file
    ``configs/rl/<config>.yml`` (default ``algo``; ``None``: its hyperparameters are in no file of
    ``configs/rl/`` and ``why_not_trainable`` says where they are); ``eval_freq``, the zoo's
    evaluation period in env steps (``-1``: none, the config's ``ValidationCallback`` draws the
    curve); ``eval_like_training``: the zoo's evaluation env gets the config's ``env_kwargs``.

    Its track (docs/benchmark.md): ``tier`` None, the generalisation track (trained on ``train``, tested on
    every tier); a tier's name, the in-distribution track (trained on that tier's cells, tested on that tier
    only).
    """

    algo: str
    description: str
    trained_on: str | None = None
    folder: str = ""
    default_folder: bool = True
    config: str | None = ""
    eval_freq: int = 25_000
    eval_like_training: bool = False
    why_not_trainable: str = ""
    tier: str | None = None

    def __post_init__(self) -> None:
        if not self.folder:
            object.__setattr__(self, "folder", self.algo)
        if self.config == "":
            object.__setattr__(self, "config", self.algo)
        if self.config is None and not self.why_not_trainable:
            raise ValueError("an agent with no config in configs/rl/ says why (why_not_trainable)")


AGENTS: dict[str, AgentEntry] = {
    "ppo": AgentEntry("ppo", "PPO (stable-baselines3, rl_zoo3) trained on the env evaluated; one row per "
                             "training seed, summarised over seeds"),
    "ppo-all": AgentEntry("ppo", "one PPO trained across the three scenes (FootstepMix-v0)",
                          trained_on="FootstepMix-v0"),
    "sac": AgentEntry("sac_sbx", "SAC (sbx, the JAX implementation of stable-baselines3's; rl_zoo3-tuned, "
                                 "configs/rl/sac_sbx.yml) trained on the env evaluated", folder="sac",
                      eval_freq=10_000, eval_like_training=True),
    "ppo-fixed-period": AgentEntry("ppo", "PPO trained with the period held at nominal (action [S, L, theta], "
                                          "configs/rl/ppo-fixed-period.yml): the period ablation for agents",
                                   folder="ppo-fixed-period", config="ppo-fixed-period", eval_like_training=True),
    "td3": AgentEntry("td3_sbx", "TD3 (sbx, the JAX implementation of stable-baselines3's; rl_zoo3-tuned, "
                                 "configs/rl/td3_sbx.yml) trained on the env evaluated", folder="td3",
                      eval_freq=10_000, eval_like_training=True),
    "ppo-wide": AgentEntry("ppo", "PPO trained on a wider distribution, the train tier's ranges stretched over the "
                                  "shifted tier's (configs/rl/ppo-wide.yml)", folder="ppo-wide", config="ppo-wide",
                           eval_freq=-1),
    "ppo-noisy": AgentEntry("ppo", "PPO trained on each scene sensed with the noise tier's profile "
                                   "(configs/rl/ppo-noisy.yml): ppo-lstm's memoryless twin", folder="ppo-noisy",
                            config="ppo-noisy", eval_freq=-1),
    "ppo-lstm": AgentEntry("ppo_lstm", "RecurrentPPO (sb3-contrib, an LSTM policy) trained on each scene sensed with "
                                       "the noise tier's profile (configs/rl/ppo-lstm.yml)", folder="ppo-lstm",
                           config="ppo-lstm", eval_freq=-1),
    "sac-sb3": AgentEntry("sac", "the first SAC (stable-baselines3, configs/rl/sac.yml, hand-set, 60k steps on the "
                                 "door): a straw man kept for reference", folder="sac-sb3"),
    "td3-b2048": AgentEntry("td3_sbx", "TD3 (sbx) with the tuner's top trial (batch 2048; ~20x td3's wall time), one "
                                       "seed on the door: kept for reference", folder="td3-b2048",
                            default_folder=False, config=None,
                            why_not_trainable="its hyperparameters are the tuner's top trial, kept in its shipped "
                                              "run's config.yml (configs/rl/td3_sbx.yml holds td3's)"),
    "ppo-jax": AgentEntry("ppo_jax", "PPO in JAX (Brax's trainer) on the batched JAX scenes (footstep_gym/jax/), "
                                     "configs/rl/ppo-jax.yml; plays through the reference env", folder="ppo-jax",
                          config=None, eval_freq=-1,
                          why_not_trainable="it trains in JAX, not through rl_zoo3: python baselines/train_jax.py "
                                            "(hyperparameters in configs/rl/ppo-jax.yml)"),
    "ppo-jax-2e7": AgentEntry("ppo_jax", "ppo-jax at the declared budget, 2e7 env steps per run "
                                         "(configs/rl/ppo-jax-2e7.yml), trained on the train tier: the generalisation "
                                         "track at budget", folder="ppo-jax-2e7", default_folder=False, config=None,
                              eval_freq=-1,
                              why_not_trainable="it trains in JAX, not through rl_zoo3: python baselines/train_jax.py "
                                                "--config configs/rl/ppo-jax-2e7.yml --agent ppo-jax-2e7"),
    # The in-distribution track: trained on a tier's cells (train split seeds), tested on that tier only.
    "ppo-jax-2e7-structure": AgentEntry(
        "ppo_jax", "ppo-jax at the declared budget (2e7 env steps per run) trained on each scene's structure tier, "
                   "tested there only", folder="ppo-jax-2e7-structure", default_folder=False, config=None,
        eval_freq=-1, tier="structure",
        why_not_trainable="it trains in JAX: python baselines/train_jax.py --config configs/rl/ppo-jax-2e7.yml "
                          "--tier structure --agent ppo-jax-2e7-structure"),
    "ppo-jax-2e7-noise": AgentEntry(
        "ppo_jax", "ppo-jax at the declared budget (2e7 env steps per run) trained on each scene's noise tier, "
                   "tested there only", folder="ppo-jax-2e7-noise", default_folder=False, config=None,
        eval_freq=-1, tier="noise",
        why_not_trainable="it trains in JAX: python baselines/train_jax.py --config configs/rl/ppo-jax-2e7.yml "
                          "--tier noise --agent ppo-jax-2e7-noise"),
    "ppo-structure": AgentEntry("ppo", "PPO trained on each scene's structure tier (its cells drawn per episode), "
                                       "tested there only: the in-distribution track", folder="ppo-structure",
                                config="ppo-structure", eval_freq=-1, tier="structure"),
    "ppo-noise": AgentEntry("ppo", "PPO trained on each scene's noise tier (its cells drawn per episode), tested "
                                   "there only: the in-distribution track", folder="ppo-noise", config="ppo-noise",
                            eval_freq=-1, tier="noise"),
    "ppo-lstm-noise": AgentEntry("ppo_lstm", "RecurrentPPO (sb3-contrib) trained on each scene's noise tier, tested "
                                             "there only: the in-distribution track", folder="ppo-lstm-noise",
                                 config="ppo-lstm-noise", eval_freq=-1, tier="noise"),
    "ppo-jax-gru-noise": AgentEntry("ppo_jax_rnn", "PPO with a GRU policy in JAX (footstep_gym/rl/ppo_jax_rnn.py) "
                                                   "trained on each scene's noise tier at the 2e7-step budget, tested "
                                                   "there only: the in-distribution track", folder="ppo-jax-gru-noise",
                                    config=None, eval_freq=-1, tier="noise",
                                    why_not_trainable="it trains in JAX, not through rl_zoo3: python baselines/"
                                                      "train_jax.py --recurrent (configs/rl/ppo-jax-gru.yml)"),
}

#: The environment variable naming the agents folder (:func:`default_agents_dir`).
AGENTS_DIR_ENV_VAR = "FOOTSTEP_GYM_AGENTS_DIR"
#: The agents folder without argument or variable, relative to the current working directory.
DEFAULT_AGENTS_DIR = Path("baselines") / "agents"


def default_agents_dir() -> Path:
    """The agents folder when none is passed (absolute): ``$FOOTSTEP_GYM_AGENTS_DIR``; else ``./baselines/agents``
    in the current working directory if it is a folder (a checkout's root, as the README's commands run); else the
    ``baselines/agents`` of the checkout ``footstep_gym`` is imported from (an editable install, or ``PYTHONPATH``
    on a checkout), if there is one; else ``./baselines/agents`` (which does not exist: :func:`agent_runs` says so).

    A non-editable install has no agents (they are not part of the package): set the variable or pass
    ``agents_dir``.
    """
    env = os.environ.get(AGENTS_DIR_ENV_VAR)
    if env:
        return Path(env).expanduser().absolute()
    here = Path.cwd() / DEFAULT_AGENTS_DIR
    if here.is_dir():
        return here
    checkout = Path(__file__).resolve().parents[2]  # footstep_gym/rl/registry.py -> the folder above the package
    if (checkout / "pyproject.toml").is_file() and (checkout / DEFAULT_AGENTS_DIR).is_dir():
        return checkout / DEFAULT_AGENTS_DIR
    return here


def agents_folder(agents_dir: str | Path | None = None) -> Path:
    """``agents_dir`` (absolute), else :func:`default_agents_dir`; ``FileNotFoundError`` in one line naming it and how
    to point at the agents when it is not a folder."""
    root = Path(agents_dir).expanduser().absolute() if agents_dir is not None else default_agents_dir()
    if not root.is_dir():
        how = ("agents_dir" if agents_dir is not None
               else f"${AGENTS_DIR_ENV_VAR}" if os.environ.get(AGENTS_DIR_ENV_VAR)
               else "the default: ./baselines/agents in the working directory, else the checkout footstep_gym "
                    "is imported from")
        raise FileNotFoundError(f"agents folder {root} does not exist ({how}); pass agents_dir, set "
                                f"{AGENTS_DIR_ENV_VAR} or run from a checkout's root (its baselines/agents)")
    return root


def agent_entry(name: str) -> AgentEntry:
    """The :class:`AgentEntry` of ``name``; ``ValueError`` naming the registered agents otherwise."""
    try:
        return AGENTS[name]
    except KeyError:
        raise ValueError(f"unknown agent {name!r}; registered: {', '.join(AGENTS)}") from None


def agent_runs(name: str, env_id: str, agents_dir: str | Path | None = None) -> list[Path]:
    """The shipped training runs of agent ``name`` for evaluation on ``env_id`` (sorted by seed; [] if the agents
    folder holds none).

    ``env_id``: an env id or a scene's name (``door``). ``agents_dir``: the agents folder; None:
    :func:`default_agents_dir`. A run is ``<agents_dir>/<folder>/<EnvId>_<seed>/`` holding ``<EnvId>.zip``, where
    ``EnvId`` is the env the agent was trained on (``trained_on``, else ``env_id``). The paths are absolute
    (evaluation workers may run elsewhere). Raises ``ValueError`` for an unknown agent or env id
    (:class:`~footstep_gym.errors.ConfigError`) and ``FileNotFoundError`` when the agents folder does not exist
    (:func:`agents_folder`), each in one line.
    """
    from footstep_gym.scenarios import resolve_env_id

    entry = agent_entry(name)
    env_id = resolve_env_id(env_id, mix=True)
    root = agents_folder(agents_dir)
    trained_on = entry.trained_on or env_id
    folder = root / entry.folder
    runs = [p for p in folder.glob(f"{trained_on}_*") if p.is_dir() and (p / f"{trained_on}.zip").is_file()]

    def seed_of(p: Path) -> tuple[int, str]:
        tail = p.name.rsplit("_", 1)[-1]
        return (int(tail), p.name) if tail.isdigit() else (1 << 30, p.name)

    return sorted(runs, key=seed_of)


def missing_agents_note(missing: dict[str, list[str]], agents_dir: str | Path | None = None) -> str:
    """One line: which agents (name -> env ids) have no run under the agents folder, and how to point at one."""
    root = Path(agents_dir) if agents_dir is not None else default_agents_dir()
    where = f"in {root}" if root.is_dir() else (f"{root} does not exist; set --agents-dir or {AGENTS_DIR_ENV_VAR} "
                                                f"to a checkout's baselines/agents")
    return (f"note: no shipped agent ({where}) for "
            + "; ".join(f"{name} on {', '.join(envs)}" for name, envs in missing.items())
            + ": those rows are skipped")


def default_agent_folder(algo: str) -> str:
    """The agents folder a run of ``algo`` ships to when no agent is named: the algorithm's own name if a
    registered agent of that algorithm has it (``ppo``), else the one folder of its registered agents
    (``sac_sbx`` -> ``sac``, SB3's ``sac`` -> ``sac-sb3``; agents marked ``default_folder=False`` left
    out), else the algorithm's name."""
    folders = {e.folder for e in AGENTS.values() if e.algo == algo and e.default_folder}
    if algo in folders or len(folders) != 1:
        return algo
    return folders.pop()
