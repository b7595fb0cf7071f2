"""``FootstepMix-v0``: one env whose every episode is one of the scenes, drawn at reset.

The scenes (every scenario of ``footstep_gym.scenarios.SCENARIOS``: door, crossing, crowd)
share their action and observation layout, so one agent can be trained across them (the
``ppo-all`` baseline). Each scene keeps its own settings, given under its name:
``gymnasium.make("FootstepMix-v0", door={"randomize": {"door_speed": [5, 20]}}, crowd={...})``.
``tier=`` (``configs/benchmark.yaml``) is passed to every scene: ``gymnasium.make("FootstepMix-v0",
tier="train")`` is the mix of the three scenes' training distributions.
"""

from __future__ import annotations

from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import EnvSpec

from footstep_gym.env import FootstepEnv, with_step_limit
from footstep_gym.errors import ConfigError
from footstep_gym.scenarios import SCENARIOS


class FootstepMixEnv(gym.Env):
    r"""The footstep scenes in one env: each episode draws its scene, then runs it unchanged.

    ## Description
    At every ``reset`` the scene is drawn from ``scenes`` with probabilities ``weights``
    using the env's seeded generator, then that scene's :class:`~footstep_gym.env.FootstepEnv`
    is reset with a seed drawn from the same generator. ``reset(seed=s)`` therefore fixes
    the scene and the episode; resets without a seed continue the stream.

    ## Action and Observation Spaces
    Those of :class:`~footstep_gym.env.FootstepEnv` (identical for all scenes; where the
    scenes' ``sensing_range`` or ``observation_position_scale`` differ, the observation box is
    the smallest holding each scene's).

    ## Episode End
    Each scene's, at its own ``max_steps``; ``env.spec.max_episode_steps`` is the largest of them.

    ## Info
    The scene env's info plus ``scene`` (its name: ``"door"``, ``"crossing"``, ``"crowd"``).

    ## Errors
    Those of the scene env, named ``"FootstepMix-v0 (scene 'door')"``: a bad action raises
    ``ActionError``; ``step`` before ``reset`` or after the episode ended raises
    ``gymnasium.error.ResetNeeded``.

    ## Arguments
    * ``scenes``: the scenes to draw from (default every scenario of ``SCENARIOS``, in its order);
    * ``weights``: their probabilities (default uniform);
    * ``render_mode``: as :class:`~footstep_gym.env.FootstepEnv`;
    * ``tier``: a benchmark tier (``configs/benchmark.yaml``; default none: the file is not read), passed to every
      scene's env,
      each drawing its tier's cells per episode as :class:`~footstep_gym.env.FootstepEnv` does; a scene's own
      mapping may name another ``tier`` (and a ``tier_cell``, a cell's name being per scene);
    * ``<scene>=...`` (``door``, ``crossing``, ``crowd``, ...): a mapping of keyword overrides of that
      scene's env (any key ``gymnasium.make("FootstepDoor-v0", ...)`` takes, ``randomize`` included).
      A name that is no scenario raises ``ConfigError`` naming the known ones.

    ## Version History
    * v0: initial release.
    """

    metadata = FootstepEnv.metadata
    _spec: EnvSpec | None = None

    def __init__(self, scenes: tuple[str, ...] | list[str] | None = None, weights: list[float] | None = None,
                 render_mode: str | None = None, tier: str | None = None,
                 **scene_kwargs: Mapping[str, Any] | None) -> None:
        known = tuple(SCENARIOS)
        scenes = known if scenes is None else tuple(scenes)
        unknown = [s for s in scenes if s not in known]
        if not scenes or unknown:
            raise ConfigError(f"scenes must be a non-empty subset of {known}, got {scenes!r}")
        if len(set(scenes)) != len(scenes):
            raise ConfigError(f"scenes must not repeat, got {scenes!r}")
        if weights is None:
            probs = np.full(len(scenes), 1.0 / len(scenes))
        else:
            probs = np.asarray(weights, dtype=float)
            if probs.shape != (len(scenes),) or not np.all(np.isfinite(probs)) or np.any(probs < 0) or probs.sum() <= 0:
                raise ConfigError(f"weights must be {len(scenes)} finite numbers >= 0, not all 0; got {weights!r}")
            probs = probs / probs.sum()
        unknown = [name for name in scene_kwargs if name not in known]
        if unknown:
            raise ConfigError(f"FootstepMixEnv: unknown keyword(s) {', '.join(map(repr, unknown))}; besides scenes, "
                              f"weights, render_mode and tier it takes a scene's overrides under its name: "
                              f"{', '.join(known)}")
        for name, value in scene_kwargs.items():
            if value is not None and not isinstance(value, Mapping):
                raise ConfigError(f"{name} must be a mapping of that scene's env keywords, got {value!r}")
        overrides = {name: scene_kwargs.get(name) for name in known}
        self.scenes = scenes
        self.weights = probs
        self.render_mode = render_mode
        self.tier = tier
        self.envs = {s: _scene_env(s, render_mode, {"tier": tier, **dict(overrides[s] or {})}) for s in scenes}
        for name, env in self.envs.items():
            env.display_name = f"{type(self).__name__} (scene {name!r})"  # reset() puts the registered id in
        first = self.envs[scenes[0]]
        for name, env in self.envs.items():
            if env.action_space != first.action_space or env.observation_space.shape != first.observation_space.shape:
                raise ConfigError(f"scene {name!r} has other spaces than {scenes[0]!r}; "
                                  "robot and n_obstacles_observed must agree across scenes")
        self.action_space = first.action_space
        # The scenes' bounds differ where their sensing_range or observation_position_scale do: the box holding all.
        boxes = [env.observation_space for env in self.envs.values()]
        self.observation_space = gym.spaces.Box(np.min([b.low for b in boxes], axis=0),
                                                np.max([b.high for b in boxes], axis=0), dtype=np.float32)
        self.scene = scenes[0]

    @property
    def spec(self) -> EnvSpec | None:
        """The spec ``gymnasium.make`` gave this env, its ``max_episode_steps`` the largest of the
        scenes' ``max_steps`` (each scene's episodes truncate at its own)."""
        return self._spec

    @spec.setter
    def spec(self, spec: EnvSpec | None) -> None:
        self._spec = with_step_limit(spec, max(env.step_limit for env in self.envs.values()))

    @property
    def current(self) -> FootstepEnv:
        """The scene env of the episode under way."""
        return self.envs[self.scene]

    # What evaluation and planners read off an env, taken from the scene under way.
    @property
    def robot(self) -> Any:
        return self.current.robot

    @property
    def history(self) -> dict[str, list]:
        return self.current.history

    @property
    def episode_config(self) -> Any:
        return self.current.episode_config

    @property
    def scenario_name(self) -> str:
        return self.scene

    def sensing(self) -> Any:
        return self.current.sensing()

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self.scene = self.scenes[int(self.np_random.choice(len(self.scenes), p=self.weights))]
        own = self.spec.id if self.spec is not None else type(self).__name__
        self.current.display_name = f"{own} (scene {self.scene!r})"  # errors name the mix and the scene
        obs, info = self.current.reset(seed=int(self.np_random.integers(2**31 - 1)), options=options)
        info["scene"] = self.scene
        return obs, info

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.current.step(action)
        info["scene"] = self.scene
        return obs, reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:
        return self.current.render()

    def close(self) -> None:
        for env in self.envs.values():
            env.close()


def _scene_env(scene: str, render_mode: str | None, kwargs: dict[str, Any]) -> FootstepEnv:
    """Scene ``scene``'s env from its keywords: with a ``tier`` (or ``tier_cell``), through
    :func:`footstep_gym.tiers.make_env`, which resolves them; without, the env itself (no tiers' file read)."""
    if kwargs.get("tier") is None and kwargs.get("tier_cell") is None:
        kwargs = {k: v for k, v in kwargs.items() if k not in ("tier", "tier_cell")}
        return FootstepEnv(scene, render_mode, **kwargs)
    from footstep_gym.tiers import make_env

    return make_env(scene, render_mode, **kwargs)
