"""The scene layer: each scenario's maths written once with an array namespace (``xp``).

Per scenario (:mod:`.door`, :mod:`.crossing`, :mod:`.crowd`), pure functions for

* a cell's parameters from its scenario config (``cell``: plain numbers, computed on the host) and its walls
  (``walls``: :class:`Wall` s, never moving);
* the per-episode draw: ``draw_numpy(rng, cfg)`` takes the episode's standard uniforms from the reference env's
  ``numpy.random.Generator`` (in the order the reference always drew them), the batched backend takes the same
  uniforms from a JAX key; ``start(xp, cell, u, m)`` turns them into the moving obstacles at 0 s
  (:class:`Bodies`) and the episode's scene state;
* the moving obstacles' poses at time ``t`` (``positions``) and where they are and how they move over the
  footstep from ``t`` (``before_step``; ``MOVES``: whether it puts them elsewhere than they were).

The reference env calls them with ``xp = numpy`` (float64, its episodes bit for bit as before), the batched
backend (:mod:`footstep_gym.jax.scenes`) with ``xp = jax.numpy``. ``m``: the moving obstacles an env holds (the
reference: the episode's own; the batched backend: the most of its tier's cells, the others :data:`PARKED`).
Nothing here imports pymunk, JAX or the benchmark layer.
"""

from __future__ import annotations

from typing import Any, NamedTuple

#: [m] where a padding obstacle stands (a cell with fewer moving obstacles than the env holds): far beyond any
#: sweep's horizon and the sensing range, still; never the nearest shape.
PARKED = 1.0e6


class Wall(NamedTuple):
    """A static wall: a thick segment from ``a`` to ``b`` [m] (world frame) of total ``thickness`` [m]."""

    name: str
    a: tuple[float, float]
    b: tuple[float, float]
    thickness: float


class Bodies(NamedTuple):
    """The moving obstacles' bodies ``(M, ...)``: ``position`` ``(M, 2)`` [m], ``angle`` ``(M,)`` [rad],
    ``velocity`` ``(M, 2)`` [m/s], ``angular_velocity`` ``(M,)`` [rad/s] (the shape in the body's frame is the
    scene's ``shape``)."""

    position: Any
    angle: Any
    velocity: Any
    angular_velocity: Any


class Shape(NamedTuple):
    """Each moving obstacle's thick segment in its body's frame: endpoints ``a``, ``b`` [m] and half thickness
    ``r`` [m] (a circle: ``a == b``)."""

    a: tuple[float, float]
    b: tuple[float, float]
    r: float


def uniform(lo: Any, hi: Any, u: Any) -> Any:
    """A draw in ``[lo, hi)`` from a standard uniform ``u`` (``numpy.random.Generator.uniform``'s arithmetic,
    so ``uniform(lo, hi, rng.random())`` is ``rng.uniform(lo, hi)`` bit for bit)."""
    return lo + (hi - lo) * u


def float_of(xp: Any, x: Any, like: Any) -> Any:
    """``x`` (a number or an integer array) as an array of ``like``'s float dtype."""
    return xp.asarray(x, dtype=like.dtype)


def draw_config(cfg: Any, rng: Any) -> dict[str, float]:
    """``{key: value}`` of every ``randomize`` key of scenario config ``cfg``, drawn from the reference env's
    generator ``rng`` in the order given (the batched backend draws the same :func:`uniform` from a JAX key)."""
    return {k: float(uniform(float(lo), float(hi), rng.random())) for k, (lo, hi) in cfg.randomize.items()}
