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
from footstep_gym.scenes import PARKED, Bodies, crossing, crowd, door, orca, uniform

__all__ = ["PARKED", "SCENES", "CrowdParams", "CrowdState", "Scene", "SceneParams", "cell_arrays", "pad_to"]


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

    def before_step(self, scene: Any, rods: Rods, t: jax.Array, duration: jax.Array) -> tuple[Rods, Any]:
        """The obstacles for the footstep from ``t`` to ``t + duration`` [s] (the reference's ``before_step``) and
        the scene state after it (a scene whose obstacles react, as ORCA's pedestrians, carries theirs on)."""
        if not self.moves:
            return rods, scene
        position, velocity = self.module.before_step(jnp, scene, rods.position, rods.velocity, t, duration)
        return _place(rods, scene.active, position, velocity), scene

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


def _place(rods: Rods, active: jax.Array, position: jax.Array, velocity: jax.Array) -> Rods:
    """``rods`` at ``position`` moving at ``velocity`` where ``active`` ``(M,)``, :data:`PARKED` at rest elsewhere
    (a moving scene's state says which of the env's bodies are its)."""
    keep = active[:, None]
    return rods._replace(position=jnp.where(keep, position, PARKED), velocity=jnp.where(keep, velocity, 0.0))


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


class CrowdState(NamedTuple):
    """A crowd episode's state where the tier has ORCA cells: which model moves it (``orca``), the scripted ring's
    state (:class:`footstep_gym.scenes.crowd.State`) and the pedestrians' (:class:`~footstep_gym.scenes.crowd.
    OrcaState`); each env holds both, its episode's model decides which moves the bodies."""

    orca: jax.Array
    ring: crowd.State
    pedestrians: crowd.OrcaState

    @property
    def active(self) -> jax.Array:
        """The env's bodies that are its episode's members ``(M,)``."""
        return jnp.where(self.orca, self.pedestrians.active, self.ring.active)


#: ``k`` -> :func:`_orca_envs`'s function (one per neighbour-slot count).
_ORCA_ENVS: dict[int, Any] = {}
#: How many sizes :func:`_orca_envs` steps the crowds still walking in: eighths of the batch.
ORCA_BUCKETS = 8


def _orca_envs(k: int) -> Any:
    """``(model, pedestrians, duration) -> (pedestrians, positions, chords)``: :func:`footstep_gym.scenes.crowd.
    orca_before_step` (``k`` neighbour slots) whose batched form (``vmap`` over envs) steps only the crowds that
    still walk. The envs are ordered by how many ORCA steps their footstep takes (:func:`orca.substeps`; none for
    an env of a scripted cell, ``model`` false), longest first, and each step runs on the smallest of
    :data:`ORCA_BUCKETS` leading slices (eighths of the batch) that holds the crowds still walking, those past
    their last step kept as they are, as ``vmap`` keeps them. Each crowd steps alone, so an ORCA env's result is the
    one it gets in any company; an env of a scripted cell keeps its (unused) pedestrians and gets their places and
    zero chords, as :meth:`CrowdScene._combine` made its inactive pedestrians give."""
    if k in _ORCA_ENVS:
        return _ORCA_ENVS[k]

    def one(peds: Any, duration: Any) -> tuple[Any, Any, Any]:
        return crowd.orca_before_step(jnp, peds, duration, k)

    @jax.custom_batching.custom_vmap
    def step(model: Any, peds: Any, duration: Any) -> tuple[Any, Any, Any]:
        return one(peds, duration)

    @step.def_vmap
    def batched(axis_size: int, in_batched: list, model: Any, peds: Any, duration: Any) -> tuple[tuple, Any]:
        model, peds, duration = orca.broadcast_batch(axis_size, in_batched, (model, peds, duration))
        n = peds.crowd.goal.shape[1]
        steps = jnp.where(model, orca.substeps(duration, peds.time_step, jnp), 0)
        dt = duration / jnp.maximum(steps, 1)  # an ORCA env's duration / steps, as orca.advance divides
        order = jnp.argsort(-steps, stable=True)
        steps_s, dt_s = steps[order], dt[order]
        start = peds.crowd.agents.position[:, :n]
        sizes = sorted({max(1, -(-axis_size * j // ORCA_BUCKETS)) for j in range(1, ORCA_BUCKETS + 1)})
        walk = jax.vmap(lambda c, d, i: orca.crowd_step(c, i, d, None, k, jnp), in_axes=(0, 0, None))

        def leading(size: int, i: Any, c: Any) -> Any:
            def run() -> Any:
                head = jax.tree.map(lambda a: a[:size], c)
                walked = walk(head, dt_s[:size], i)
                on = steps_s[:size] > i
                head = jax.tree.map(lambda w, h: jnp.where(on.reshape((-1,) + (1,) * (w.ndim - 1)), w, h),
                                    walked, head)
                return jax.tree.map(lambda a, h: a.at[:size].set(h), c, head)
            return run

        def body(i: Any, c: Any) -> Any:
            walking = jnp.sum(steps_s > i)
            return jax.lax.switch(jnp.searchsorted(jnp.asarray(sizes), walking),
                                  [leading(size, i, c) for size in sizes])

        sorted_crowd = jax.tree.map(lambda a: a[order], peds.crowd)
        walked = jax.lax.fori_loop(0, steps_s[0], body, sorted_crowd)
        back = jnp.argsort(order)
        new_crowd = jax.tree.map(lambda a: a[back], walked)
        new_crowd, now, chords = jax.vmap(lambda c, s0, d: orca.chords(c, s0, d, jnp))(new_crowd, start, duration)
        out = (peds._replace(crowd=new_crowd), now, jnp.where(peds.active[:, :, None], chords, 0.0))
        return out, jax.tree.map(lambda _: True, out)

    _ORCA_ENVS[k] = step
    return step


class CrowdParams(NamedTuple):
    """A crowd cell's scene: the scripted ring's ``Cell``, the ORCA layout's ``OrcaCell`` (both as arrays) and which
    model the cell is (``orca``)."""

    ring: Any
    orca: Any
    model: jax.Array


class CrowdScene(Scene):
    """``FootstepCrowd-v0``: the scripted ring (:mod:`footstep_gym.scenes.crowd`) and ORCA's pedestrians
    (``crowd_model: orca``, every ``crowd_layout``; :func:`footstep_gym.scenes.crowd.orca_start`, the ORCA step of
    :mod:`footstep_gym.scenes.orca`) with the robot invisible to them. A tier without ORCA cells holds the ring's
    state alone; one with them holds a :class:`CrowdState`."""

    name, module = "crowd", crowd

    def __init__(self, cfgs: list[Any], dtype: Any) -> None:
        super().__init__(cfgs, dtype)
        #: Whether the cells include ORCA pedestrians (then the state is a :class:`CrowdState`).
        self.has_orca = any(c.crowd_model == "orca" for c in cfgs)
        #: ORCA's neighbour slots: the most any cell's pedestrian considers, at most ``size - 1``.
        self.k = orca.neighbor_slots([c.orca_max_neighbors for c in cfgs if c.crowd_model == "orca"], self.size)

    def unsupported(self, cfg: Any) -> str | None:
        if cfg.crowd_model == "orca" and cfg.robot_visible:
            return "crowd_model='orca' with robot_visible=True (the robot as an ORCA agent; the tiers' cells hide it)"
        return super().unsupported(cfg)

    def cell_params(self, cfg: Any) -> SceneParams:
        p = super().cell_params(cfg)
        if not self.has_orca:
            return p
        return p._replace(cell=CrowdParams(p.cell, cell_arrays(crowd.orca_cell(cfg), self.dtype),
                                           jnp.asarray(cfg.crowd_model == "orca")))

    def _crowd_rods(self, p: SceneParams, bodies: Any, radius: jax.Array) -> Rods:
        m = self.size
        return Rods(*bodies, jnp.broadcast_to(p.a, (m, 2)), jnp.broadcast_to(p.b, (m, 2)), radius)

    def _combine(self, p: SceneParams, ring: tuple, peds: tuple) -> tuple[Rods, CrowdState]:
        """The ring's and the pedestrians' ``(bodies, state)`` as one env's rods (the cell's model's bodies) and
        :class:`CrowdState`."""
        (rb, rs), (pb, ps) = ring, peds
        model = p.cell.model
        active = ps.active & model  # a scripted episode has no pedestrians
        ps = ps._replace(active=active, crowd=ps.crowd._replace(agents=ps.crowd.agents._replace(active=active)))
        bodies = jax.tree.map(lambda a, b: jnp.where(model, a, b), pb, rb)
        radius = jnp.where(model, ps.crowd.radius, jnp.broadcast_to(p.r, (self.size,)))
        return self._crowd_rods(p, bodies, radius), CrowdState(model, rs, ps)

    def draw(self, key: jax.Array, p: SceneParams) -> tuple[Rods, Any]:
        if not self.has_orca:
            return super().draw(key, p)
        k_ring, k_orca = jax.random.split(key)
        ring_p = p._replace(cell=p.cell.ring)
        rods, ring = super().draw(k_ring, ring_p)
        shapes = crowd.orca_draw_shapes(self.size)
        keys = jax.random.split(k_orca, len(shapes))
        u = crowd.OrcaDraws(*(jax.random.uniform(kk, shape, self.dtype) for kk, shape in zip(keys, shapes)))
        peds = crowd.orca_start(jnp, p.cell.orca, u, self.size, self.dtype)
        return self._combine(p, (Bodies(*rods[:4]), ring), peds)

    def before_step(self, scene: Any, rods: Rods, t: jax.Array, duration: jax.Array) -> tuple[Rods, Any]:
        if not self.has_orca:
            return super().before_step(scene, rods, t, duration)
        ring_pos, ring_vel = crowd.before_step(jnp, scene.ring, rods.position, rods.velocity, t, duration)
        peds, ped_pos, ped_vel = _orca_envs(self.k)(scene.orca, scene.pedestrians, duration)
        position = jnp.where(scene.orca, ped_pos.astype(self.dtype), ring_pos)
        velocity = jnp.where(scene.orca, ped_vel.astype(self.dtype), ring_vel)
        return _place(rods, scene.active, position, velocity), scene._replace(pedestrians=peds)

    def start_from(self, start: dict[str, Any], p: SceneParams, cfg: Any) -> tuple[Rods, Any]:
        if not self.has_orca:
            return super().start_from(start, p, cfg)
        m, draws = self.size, start["draws"]
        orca_cfg = cfg.crowd_model == "orca"
        ring_shapes, orca_shapes = crowd.draw_shapes(m), crowd.orca_draw_shapes(m)
        ring_u = type(ring_shapes)(*(np.full(s, 0.5) for s in ring_shapes)) if orca_cfg else type(ring_shapes)(
            *(_pad_draw(np.asarray(x, np.float64), s) for x, s in zip(draws, ring_shapes)))
        orca_u = crowd.OrcaDraws(*(_pad_draw(np.asarray(x, np.float64), s) for x, s in zip(draws, orca_shapes))) \
            if orca_cfg else crowd.OrcaDraws(*(np.full(s, 0.5) for s in orca_shapes))
        ring = crowd.start(np, crowd.cell(cfg), ring_u, m)
        peds = crowd.orca_start(np, crowd.orca_cell(cfg), orca_u, m, np.float64)

        def cast(x: Any) -> jax.Array:
            x = np.asarray(x)
            keep = x.dtype == np.float32 or not np.issubdtype(x.dtype, np.floating)  # ORCA's float32 agents stay
            return jnp.asarray(x, None if keep else self.dtype)

        ring, peds = jax.tree.map(cast, ring), jax.tree.map(cast, peds)
        return self._combine(p, ring, peds)


SCENES: dict[str, type[Scene]] = {cls.name: cls for cls in (DoorScene, CrossingScene, CrowdScene)}
