"""The scenes of the batched backend: each scene's maths (:mod:`footstep_gym.scenes`) with its uniforms drawn from a
JAX key and its moving obstacles held as :class:`~footstep_gym.jax.shapes.Rods`.

A :class:`Scene` turns each tier cell's config into arrays (:class:`SceneParams`, stacked over the cells by
:class:`~footstep_gym.jax.env.FootstepJaxEnv`), draws an episode from a JAX key (:meth:`Scene.draw`: the
``randomize`` keys, then the scene's uniforms, then the same ``start`` the reference env calls), sets the obstacles
before a footstep (:meth:`Scene.before_step`) and starts from a reference episode's uniforms for a replay
(:meth:`Scene.start_from`). The door's rods, the crossing's capsules and the crowd's cylinders are all rods (a
circle is a rod of zero length, the same distance in Chipmunk's arithmetic).
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from footstep_gym.jax.shapes import Rods
from footstep_gym.scenes import PARKED, crossing, crowd, door, uniform

__all__ = ["PARKED", "SCENES", "Scene", "SceneParams", "cell_arrays", "pad_to"]


def _arr(x: Any, dtype: Any) -> jax.Array:
    return jnp.asarray(np.asarray(x, dtype=np.float64), dtype)


def _range(cfg: Any, key: str) -> tuple[float, float]:
    """``(lo, hi)`` of a numeric key: its ``randomize`` range, else its value twice."""
    lo, hi = cfg.randomize.get(key, (getattr(cfg, key), getattr(cfg, key)))
    return float(lo), float(hi)


def pad_to(x: Any, size: int, value: float, dtype: Any) -> jax.Array:
    """``x`` as ``dtype``, its leading axis filled up to ``size`` with ``value`` (unchanged if it has as many)."""
    x = jnp.asarray(x, dtype)
    extra = size - x.shape[0]
    return jnp.concatenate([x, jnp.full((extra,) + x.shape[1:], value, dtype)]) if extra > 0 else x


def cell_arrays(cell: Any, dtype: Any) -> Any:
    """A scene module's ``Cell`` of plain numbers as arrays: integers int32, the rest ``dtype``."""
    def arr(v: Any) -> jax.Array:
        if isinstance(v, (bool, np.bool_)):
            return jnp.asarray(v)
        if isinstance(v, (int, np.integer)):
            return jnp.asarray(v, jnp.int32)
        return _arr(v, dtype)
    return type(cell)(*(arr(v) for v in cell))


class SceneParams(NamedTuple):
    """One tier cell's scene (leaves lead with the cell axis in ``FootstepJaxEnv``'s params): its ``cell`` (the
    scene module's ``Cell`` as arrays), the ``(lo, hi)`` ``ranges`` of the keys an episode draws (the module's
    ``RANDOMIZABLE``; ``lo == hi`` where the cell randomizes none) and the moving obstacles' segment in their
    body's frame (``a``, ``b`` ``(2,)`` [m], ``r`` [m])."""

    cell: Any
    ranges: dict
    a: jax.Array
    b: jax.Array
    r: jax.Array


class Scene:
    """A scene of the batched backend (module docstring). ``cfgs``: the tier cells' scenario configs."""

    name: ClassVar[str]
    #: The scene's maths (:mod:`footstep_gym.scenes`).
    module: ClassVar[ModuleType]
    #: The ``randomize`` keys an episode may draw (others raise ``ConfigError`` when the env is made).
    randomizable: ClassVar[tuple[str, ...]] = ()
    #: Whether :meth:`before_step` puts the bodies elsewhere than they were (then a sweep's first check sees
    #: them where pymunk last cached them: ``shapes.sweep``'s ``cached``).
    moves: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.randomizable, cls.moves = cls.module.RANDOMIZABLE, cls.module.MOVES

    def __init__(self, cfgs: list[Any], dtype: Any) -> None:
        self.dtype = dtype
        #: Moving obstacles held per env: the most of the tier's cells (the others stand :data:`PARKED`).
        self.size = max(self.module.size(c) for c in cfgs)

    def unsupported(self, cfg: Any) -> str | None:
        """What of a cell's config this backend does not do (a phrase), or ``None``."""
        extra = sorted(set(cfg.randomize) - set(self.randomizable))
        return f"randomize of {', '.join(extra)}" if extra else None

    def cell_params(self, cfg: Any) -> SceneParams:
        """The params of one scenario config."""
        dt = self.dtype
        a, b, r = self.module.shape(cfg)
        return SceneParams(cell_arrays(self.module.cell(cfg), dt),
                           {k: _arr(_range(cfg, k), dt) for k in self.randomizable}, _arr(a, dt), _arr(b, dt), _arr(r, dt))

    def _rods(self, p: SceneParams, bodies: Any) -> Rods:
        m = self.size
        return Rods(*bodies, jnp.broadcast_to(p.a, (m, 2)), jnp.broadcast_to(p.b, (m, 2)), jnp.broadcast_to(p.r, (m,)))

    def draw(self, key: jax.Array, p: SceneParams) -> tuple[Rods, Any]:
        """An episode's moving obstacles at 0 s and its scene state (what :meth:`before_step` reads)."""
        dt, mod = self.dtype, self.module
        shapes = mod.draw_shapes(self.size)
        keys = jax.random.split(key, len(self.randomizable) + len(shapes))
        drawn = {k: uniform(p.ranges[k][0], p.ranges[k][1], jax.random.uniform(kk, (), dt))
                 for k, kk in zip(self.randomizable, keys)}
        u = type(shapes)(*(jax.random.uniform(kk, shape, dt) for kk, shape in
                           zip(keys[len(self.randomizable):], shapes)))
        bodies, scene = mod.start(jnp, p.cell._replace(**drawn), u, self.size)
        return self._rods(p, bodies), scene

    def before_step(self, scene: Any, rods: Rods, t: jax.Array, duration: jax.Array) -> Rods:
        """The obstacles for the footstep from ``t`` to ``t + duration`` [s] (the reference's ``before_step``)."""
        if not self.moves:
            return rods
        position, velocity = self.module.before_step(jnp, scene, rods.position, rods.velocity, t, duration)
        keep = scene.active[:, None]  # a moving scene's state says which of the env's bodies are its (the others parked)
        return rods._replace(position=jnp.where(keep, position, PARKED), velocity=jnp.where(keep, velocity, 0.0))

    @staticmethod
    def reference_start(env: Any) -> dict[str, Any]:
        """A reset reference env's (``FootstepEnv``) uniforms of its scene."""
        if getattr(env.scenario, "draws", None) is None:
            raise ValueError(f"reference_start: {type(env.scenario).__name__} has no batched version")
        return {"draws": env.scenario.draws}

    def start_from(self, start: dict[str, Any], p: SceneParams, cfg: Any) -> tuple[Rods, Any]:
        """:meth:`draw`'s answer for a reference episode (its :meth:`reference_start` and scenario config
        ``cfg``): the same ``start`` on the same uniforms (padded to :attr:`size`) in numpy float64, then cast,
        so the obstacles and the scene state are the reference's bit for bit (up to the cast)."""
        mod, m = self.module, self.size
        shapes = mod.draw_shapes(m)
        u = type(shapes)(*(_pad_draw(np.asarray(x, np.float64), shape) for x, shape in zip(start["draws"], shapes)))
        bodies, scene = mod.start(np, mod.cell(cfg), u, m)

        def cast(x: Any) -> jax.Array:
            x = np.asarray(x)
            return jnp.asarray(x, self.dtype if np.issubdtype(x.dtype, np.floating) else None)

        return self._rods(p, jax.tree.map(cast, bodies)), jax.tree.map(cast, scene)


def _pad_draw(x: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """A reference's uniforms ``x`` filled up to ``shape`` with 0.5 (obstacles it does not have)."""
    out = np.full(shape, 0.5)
    out[tuple(slice(0, n) for n in x.shape)] = x
    return out


class DoorScene(Scene):
    """``FootstepDoor-v0`` (:mod:`footstep_gym.scenes.door`), one door or two."""

    name, module = "door", door


class CrossingScene(Scene):
    """``FootstepCrossing-v0`` (:mod:`footstep_gym.scenes.crossing`): the timed car or the traffic's lanes."""

    name, module = "crossing", crossing


class CrowdScene(Scene):
    """``FootstepCrowd-v0``'s scripted ring (:mod:`footstep_gym.scenes.crowd`). ORCA pedestrians have no batched
    version."""

    name, module = "crowd", crowd

    def unsupported(self, cfg: Any) -> str | None:
        if cfg.crowd_model != "scripted":
            return f"crowd_model={cfg.crowd_model!r} (ORCA pedestrians have no JAX version)"
        return super().unsupported(cfg)


SCENES: dict[str, type[Scene]] = {cls.name: cls for cls in (DoorScene, CrossingScene, CrowdScene)}
