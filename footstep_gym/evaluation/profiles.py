"""What an evaluation runs: its profiles, its settings and its cells.

* :data:`PROFILES`: the defaults of a run (``quick``, ``paper``, ``ablation``, ``agents``);
* :func:`sweep_axes`: every registered scenario's ``sweep_axes`` (one command-line flag each,
  :func:`flag_of`: ``door_speed`` -> ``--door-speed``);
* :class:`Settings` and :func:`evaluation_settings`: a run's settings from its options, checked
  (a bad value raises :class:`OptionError` with one line; nothing is run);
* :func:`make_cells` and :func:`check_cells`: the cells of a run, in a fixed order, and why one cannot run.

``baselines/eval_planner.py`` is the command line of this module.
"""

from __future__ import annotations

import itertools
import os
import sys
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import footstep_gym
from footstep_gym import registry
from footstep_gym.evaluation.runner import Cell
from footstep_gym.evaluation.runner import check_cells as runner_check_cells
from footstep_gym.evaluation.splits import split_seeds
from footstep_gym.evaluation.submission import AgentArg, SubmissionError, parse_agents
from footstep_gym.scenarios import SCENARIOS, resolve_env_id, scene_of


class OptionError(ValueError):
    """A bad option of a run: one line saying why (the command line turns it into its usage error)."""


@dataclass(frozen=True)
class Profile:
    """Defaults of a run; options given on the command line override them.

    ``scenes``: the scenes it runs (``None``: every scenario registered in ``SCENARIOS`` when the run is set up,
    a plugin's or a test's included); :attr:`envs` resolves it.
    """

    scenes: tuple[str, ...] | None
    episodes: int
    #: ``{scene: {key: values}}`` over the scenes' ``sweep_axes``: one cell per value (the product over a
    #: scene's keys); a key not given (or given no values) stays at the scenario's default.
    sweeps: dict[str, dict[str, tuple[float, ...]]]
    policies: tuple[str, ...] | None  # None: every registered policy

    @property
    def envs(self) -> tuple[str, ...]:
        """The scenes of the run: :attr:`scenes`, or every registered scenario (in ``SCENARIOS`` order)."""
        return tuple(SCENARIOS) if self.scenes is None else self.scenes


#: The paper's scenes (its protocol and the shipped agents' settings are defined on them).
PAPER_SCENES = ("door", "crossing", "crowd")

PROFILES = {
    # Every registered scene, every planner and every shipped agent, 3 seeds.
    "quick": Profile(scenes=None, episodes=3, sweeps={"door": {"door_speed": (17.0,)}},
                     policies=None),
    # The paper's protocol: door at 8, 14, 17 deg/s, crossing, crowd; >= 20 seeds per cell.
    "paper": Profile(scenes=PAPER_SCENES, episodes=20,
                     sweeps={"door": {"door_speed": (8.0, 14.0, 17.0)}},
                     policies=("period-aware", "fixed-period", "pso-only", "paper-period-aware",
                               "paper-fixed-period")),
    # period-aware with each addition switched off in turn, and the paper's planner with each switched on in turn
    # (filled in by --ablation: footstep_gym.planners.ablation_variants()).
    "ablation": Profile(scenes=None, episodes=10, sweeps={"door": {"door_speed": (17.0,)}},
                        policies=()),
    # The agents against both planners on every setting docs/results.md reports (the scenes they were trained on).
    "agents": Profile(scenes=PAPER_SCENES, episodes=20,
                      sweeps={"door": {"door_speed": (8.0, 11.0, 14.0, 17.0, 20.0)},
                              "crowd": {"crowd_speed": (0.16, 0.2)}},
                      policies=("period-aware", "fixed-period", "ppo", "ppo-fixed-period", "ppo-wide", "ppo-all",
                                "sac", "td3")),
}


def sweep_axes() -> dict[str, list[tuple[str, str]]]:
    """``{key: [(scene, unit), ...]}``: every registered scenario's ``sweep_axes``, each key with the scenes
    sweeping it (in ``SCENARIOS`` order). Each key is a flag: ``door_speed`` -> ``--door-speed``."""
    axes: dict[str, list[tuple[str, str]]] = {}
    for scene, cls in SCENARIOS.items():
        for key, unit in cls.sweep_axes.items():
            axes.setdefault(key, []).append((scene, unit))
    return axes


def flag_of(key: str) -> str:
    """The command-line flag of sweep key ``key`` (``door_speed`` -> ``--door-speed``)."""
    return "--" + key.replace("_", "-")


def _list(values: Sequence[float]) -> str:
    return ", ".join(f"{v:g}" for v in values) or "the scenario's default"


def describe_sweep(profile: Profile, scene: str) -> str:
    """``door at 8, 14, 17 deg/s`` (``scene`` with the profile's sweep of it), or just ``scene``."""
    axes = {k: v for k, v in profile.sweeps.get(scene, {}).items() if v}
    units = SCENARIOS[scene].sweep_axes if scene in SCENARIOS else {}
    if len(axes) == 1:
        (key, values), = axes.items()
        return f"{scene} at {_list(values)} {units.get(key, '')}".rstrip()
    parts = [f"{key} {_list(values)} {units.get(key, '')}".rstrip() for key, values in axes.items()]
    return f"{scene} at {', '.join(parts)}" if parts else scene


def unique(items: Sequence[Any]) -> tuple[Any, ...]:
    """``items`` without repeats, in their order."""
    return tuple(dict.fromkeys(items))


def usable_cores() -> int:
    """The CPUs this process may run on (the default number of workers)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


@dataclass(frozen=True)
class Settings:
    profile: str
    envs: tuple[str, ...]
    policies: tuple[str, ...]
    agents: tuple[AgentArg, ...]  # a user's agents (--agent [SCENE=]PATH)
    agents_dir: Path | None
    episodes: int
    split: str
    offset: int
    #: ``{scene: {key: values}}`` for every scenario with sweep axes (the flags', else the profile's values;
    #: ``()``: the scenario's default); :func:`make_cells` reads the scenes in ``envs``.
    sweeps: dict[str, dict[str, tuple[float, ...]]]
    out: Path
    workers: int
    backend: str
    ray_address: str | None
    figures: bool
    video: bool
    #: Each policy's entry and each user agent's (``agent:<label>``), by name: resolved once, here, and carried by
    #: the cells (:func:`make_cells`).
    entries: dict[str, registry.PolicyEntry] = dataclasses.field(default_factory=dict, compare=False, repr=False)

    @property
    def seeds(self) -> list[int]:
        return split_seeds(self.split, self.episodes, self.offset)


def evaluation_settings(profile_name: str, *, envs: Sequence[str] | None, policies: Sequence[str] | None,
                        agents: Sequence[str | Path] | None, agents_dir: Path | None, episodes: int | None, split: str,
                        offset: int, sweeps: dict[str, Sequence[float] | None], out: Path, workers: int | None,
                        backend: str, ray_address: str | None, figures: bool, video: bool, algo: str | None = None,
                        vecnormalize: Sequence[str] | None = None) -> Settings:
    """The settings of an evaluation from its options (``None``: the profile's default), checked in the command
    line's order: the first bad value raises :class:`OptionError`. ``sweeps`` maps each key of
    :func:`sweep_axes` to the values given for it; ``agents`` are ``--agent`` values (``PATH`` or ``SCENE=PATH``,
    :func:`~footstep_gym.evaluation.submission.parse_agents`)."""
    profile = PROFILES[profile_name]
    try:
        scenes = unique([scene_of(resolve_env_id(e)) for e in (envs or profile.envs)])
    except ValueError as exc:
        raise OptionError(str(exc)) from None
    available = registry.policy_names()
    entries: dict[str, registry.PolicyEntry] = {}
    if policies:
        unknown = []
        for p in policies:
            try:
                entries[p] = registry.resolve(p)
            except registry.PolicyLoadError as exc:
                raise OptionError(str(exc)) from None
            except ValueError:
                unknown.append(p)
        if unknown:
            raise OptionError(f"unknown policy {', '.join(map(repr, unknown))}; choose from {', '.join(available)}, "
                              "or give a policy of your own as module:attr")
        chosen = unique(policies)
    elif agents:
        chosen = ()  # only the user's agents
    elif profile_name == "ablation":
        from footstep_gym.planners.ablation import ablation_variants

        chosen = ablation_variants()
    elif profile.policies is not None:
        chosen = tuple(p for p in profile.policies if p in available)
    else:  # every registered policy but an upper bound (oracle), which runs only when named
        entries = {p: registry.resolve(p) for p in available}
        chosen = tuple(p for p in available if not entries[p].reads_truth)
    if (algo or vecnormalize) and not agents:
        raise OptionError("--algo and --vecnormalize go with --agent")
    try:
        user_agents = tuple(parse_agents([str(a) for a in agents or ()], algo, vecnormalize))
    except SubmissionError as exc:
        raise OptionError(str(exc)) from None
    for key, owners in sweep_axes().items():
        owning = [s for s, _ in owners]
        if sweeps.get(key) and not set(owning) & set(scenes):
            raise OptionError(f"{flag_of(key)} applies to the {' and '.join(owning)} env only; "
                              f"add {' or '.join(f'--env {s}' for s in owning)}")
    swept = {scene: {key: unique(sweeps.get(key) or profile.sweeps.get(scene, {}).get(key, ()))
                     for key in cls.sweep_axes} for scene, cls in SCENARIOS.items() if cls.sweep_axes}
    if ray_address and backend != "ray":
        raise OptionError("--ray-address needs --backend ray")
    episodes = episodes or profile.episodes
    try:
        split_seeds(split, episodes, offset)
    except ValueError as exc:
        raise OptionError(str(exc)) from None
    entries = {p: entries.get(p) or registry.resolve(p) for p in chosen}
    for agent in user_agents:
        name = f"{registry.USER_AGENT_PREFIX}{agent.label}"
        entries[name] = registry.resolve(name)
    return Settings(
        profile=profile_name, envs=scenes, policies=chosen, agents=user_agents,
        agents_dir=agents_dir, episodes=episodes, split=split, offset=offset, sweeps=swept, out=out,
        workers=workers or usable_cores(), backend=backend, ray_address=ray_address, figures=figures, video=video,
        entries=entries,
    )


def make_cells(settings: Settings) -> list[Cell]:
    """Cells in a fixed order: envs, settings, policies as given; an agent once per training run.

    A scene's settings are the product of its sweep's values (``settings.sweeps[scene]``, keys in
    its ``sweep_axes`` order; a key without values stays at the default; no sweep: one setting).
    An agent with no run for an env is skipped there, said in one line on stderr; a user's agent of one scene
    runs on that scene only.
    """
    from footstep_gym.rl.registry import agent_runs, missing_agents_note

    entry = settings.entries.get
    shipped = {p for p in settings.policies if (entry(p) or registry.resolve(p)).kind == "agent"}
    cells = []
    missing: dict[str, list[str]] = {}
    for scenario in settings.envs:
        env_id = footstep_gym.ENV_IDS[scenario]
        axes = [(key, values) for key, values in settings.sweeps.get(scenario, {}).items() if values]
        variants = [tuple(zip([key for key, _ in axes], combo)) for combo in itertools.product(*(v for _, v in axes))]
        runs_of = {}
        for policy in settings.policies:
            if policy in shipped:
                try:
                    runs_of[policy] = agent_runs(policy, env_id, settings.agents_dir)
                except FileNotFoundError:  # no agents folder: skipped, said in the note below
                    runs_of[policy] = []
                if not runs_of[policy]:
                    missing.setdefault(policy, []).append(env_id)
        for params in variants:
            for policy in settings.policies:
                if policy in shipped:
                    cells += [Cell(env_id, scenario, policy, params, run=str(r), entry=entry(policy))
                              for r in runs_of[policy]]
                else:
                    cells.append(Cell(env_id=env_id, scenario=scenario, policy=policy, params=params,
                                      entry=entry(policy)))
            for agent in settings.agents:
                if agent.scene in (None, scenario):
                    name = f"{registry.USER_AGENT_PREFIX}{agent.label}"
                    cells.append(Cell(env_id, scenario, name, params, run=agent.path, algo=agent.algo,
                                      vecnormalize=agent.vecnormalize, entry=entry(name)))
    if missing:
        print(missing_agents_note(missing, settings.agents_dir), file=sys.stderr)
    return cells


def describe_cells(cells: Sequence[Cell]) -> str:
    """``41 cells (83 with the agents' training runs)``: the rows of the run's table (a setting and policy each, an
    agent's training runs pooled into one), then the runner's cells where an agent has several runs."""
    rows = len({(c.env_id, c.params, c.policy) for c in cells})
    runs = f" ({len(cells)} with the agents' training runs)" if len(cells) != rows else ""
    return f"{rows} cell{'' if rows == 1 else 's'}{runs}"


def check_cells(cells: list[Cell]) -> str | None:
    """:func:`footstep_gym.evaluation.runner.check_cells`, each setting named by its command-line flags."""
    return runner_check_cells(
        cells, lambda cell: " ".join(f"--{k.replace('_', '-')} {v:g}" for k, v in cell.params) or "its defaults")
