"""Running one evaluation episode (in the main process or a worker) and recording it.

:func:`run_episode` is what the worker processes of ``eval_planner.py`` execute: it builds a
fresh env and policy, seeds both with the episode's seed (``env.reset(seed=s)``,
``policy.reset(seed=s)``), so an episode's result does not depend on which process ran it
or what ran before, and returns an :class:`~eval_stats.EpisodeResult`. With
``record=True`` it also returns a :class:`Trace`: everything the figures and command
tables need, taken from what the env records (``env.unwrapped.history``, the ``info`` of
each step) and from ``sensing()`` before every footstep and once after the last one
(obstacle poses, CoM, robot centre).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import gymnasium as gym
import numpy as np

import footstep_gym  # noqa: F401  (registers the envs)
from eval_stats import EpisodeResult

#: ``factory(name, robot, seed) -> policy`` with ``reset(seed=...)`` and ``act(obs, snapshot)``.
PolicyFactory = Callable[..., Any]


@dataclass(frozen=True)
class Cell:
    """One evaluation cell: an env id, a policy name and env keyword arguments (``params``)."""

    env_id: str
    scenario: str  # door / crossing / crowd
    policy: str
    params: tuple[tuple[str, float], ...] = ()  # sorted (key, value) pairs: hashable and ordered

    @property
    def params_dict(self) -> dict[str, float]:
        return dict(self.params)

    @property
    def setting(self) -> str:
        """Short name of the env and its parameters, e.g. ``door_17`` (file names, figure titles)."""
        return "_".join([self.scenario] + [f"{v:g}" for _, v in self.params])


@dataclass(frozen=True)
class Task:
    cell_index: int
    cell: Cell
    seed: int
    record: bool = False


@dataclass(frozen=True)
class ObstacleShape:
    """The fixed geometry of one obstacle shape (body frame), as :class:`~footstep_gym.sensing.ObstacleView` has it."""

    name: str
    kind: str  # "circle" | "segment"
    static: bool
    radius: float  # [m]
    a: tuple[float, float]
    b: tuple[float, float]


@dataclass
class Trace:
    """A recorded episode. Index ``k`` of the per-snapshot arrays is the state before footstep ``k + 1``.

    ``times``, ``com``, ``centre`` and ``poses`` have one more entry than there were
    footsteps: the last is the state after the episode ended (at the instant of contact
    after a collision).
    """

    env_id: str
    scenario: str
    policy: str
    params: dict[str, float]
    seed: int
    outcome: str
    obstacle: str | None
    robot: dict[str, float]  # foot_length, foot_width, body_radius [m]
    start: tuple[float, float]  # robot centre at reset [m]
    goal: tuple[float, float]
    goal_tolerance: float
    shapes: list[ObstacleShape]
    times: np.ndarray  # (K + 1,) [s]
    poses: np.ndarray  # (K + 1, n_shapes, 3): body x, y, angle of every shape [m, m, rad]
    com: np.ndarray  # (K + 1, 2) [m]
    centre: np.ndarray  # (K + 1, 2) [m]
    footprints: list[tuple[tuple[float, float, float], int]]  # env.history["footprints"]: (pose, side)
    com_path: np.ndarray  # env.history["com"] (M, 2)
    zmp: np.ndarray  # env.history["zmp"] (M, 2)
    commands: np.ndarray  # (K, 5) applied [S, L, theta, T_SS, T_DS] (after the env's clipping)
    planned: np.ndarray  # (K, 5) what the policy returned
    pre_pso: np.ndarray  # (K, 5) the command before PSO; NaN where the policy did not report one
    pso_ran: list[bool | None] = field(default_factory=list)

    def shape_world(self, k: int, i: int) -> tuple[np.ndarray, np.ndarray]:
        """World endpoints ``a``, ``b`` of shape ``i`` at snapshot ``k`` [m]."""
        x, y, ang = self.poses[k, i]
        c, s = math.cos(ang), math.sin(ang)
        sh = self.shapes[i]
        out = []
        for px, py in (sh.a, sh.b):
            out.append(np.array([x + c * px - s * py, y + s * px + c * py]))
        return out[0], out[1]


# ---------------------------------------------------------------- the policy's own report
def planner_notes(policy: Any) -> tuple[np.ndarray | None, bool | None]:
    """``(command before PSO or None, whether PSO ran or None)`` from ``policy.last_info`` after ``act``.

    The reference planners report ``command_pre_pso`` (``None`` for ``pso-only``, which has
    no earlier stage) and ``pso_ran``; a policy without ``last_info`` reports neither.
    """
    info = getattr(policy, "last_info", None) or {}
    pre = info.get("command_pre_pso")
    ran = info.get("pso_ran")
    return (None if pre is None else np.asarray(pre, dtype=float).reshape(5),
            None if ran is None else bool(ran))


# ---------------------------------------------------------------- running
def default_factory(name: str, robot: Any, seed: int) -> Any:
    """The real planners' registry (imported here so workers resolve it themselves)."""
    from footstep_gym.planners import make_policy

    return make_policy(name, robot, seed=seed)


def _poses(snapshot: Any) -> np.ndarray:
    return np.array([(o.position[0], o.position[1], o.angle) for o in snapshot.obstacles], dtype=float).reshape(-1, 3)


def _polyline_length(points: np.ndarray) -> float:
    if len(points) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def run_episode(task: Task, factory: PolicyFactory = default_factory) -> EpisodeResult:
    """Run ``task``'s episode to its end; record a :class:`Trace` if ``task.record``."""
    cell, seed = task.cell, task.seed
    try:
        return _run(task, factory)
    except Exception as exc:  # name the episode: a worker's traceback alone does not
        raise RuntimeError(f"episode failed: env={cell.env_id} params={cell.params_dict} "
                           f"policy={cell.policy} seed={seed}: {type(exc).__name__}: {exc}") from exc


def _run(task: Task, factory: PolicyFactory) -> EpisodeResult:
    cell, seed = task.cell, task.seed
    env = gym.make(cell.env_id, **cell.params_dict)
    try:
        base = env.unwrapped
        policy = factory(cell.policy, base.robot, seed)
        obs, _ = env.reset(seed=seed)
        policy.reset(seed=seed)
        snapshot = base.sensing()
        snaps = [snapshot]
        plan_ms: list[float] = []
        periods: list[float] = []
        pso_ran: list[bool | None] = []
        applied, planned, pre_pso = [], [], []
        info: dict[str, Any] = {}
        terminated = truncated = False
        while not (terminated or truncated):
            t0 = time.perf_counter()
            action = policy.act(obs, snapshot)
            plan_ms.append(1e3 * (time.perf_counter() - t0))
            pre, ran = planner_notes(policy)
            obs, _, terminated, truncated, info = env.step(action)
            applied.append(info["command"])
            planned.append(np.asarray(action, dtype=float).reshape(5))
            pre_pso.append(pre if pre is not None else np.full(5, np.nan))
            pso_ran.append(ran)
            periods.append(float(info["period"]))
            snapshot = base.sensing()
            snaps.append(snapshot)
        outcome = info["termination"] if terminated else "timeout"
        centre = np.array([s.centre for s in snaps], dtype=float)
        com_path = np.asarray(base.history["com"], dtype=float).reshape(-1, 2)
        result = EpisodeResult(
            cell_index=task.cell_index, seed=seed, outcome=outcome, steps=int(info["steps"]),
            time=float(info["time"]), path_length=_polyline_length(centre),
            com_path_length=_polyline_length(com_path), plan_ms=plan_ms, periods=periods, pso_ran=pso_ran,
            obstacle=info.get("obstacle"),
        )
        if task.record:
            cfg = base.episode_config
            robot = base.robot
            result.trace = Trace(
                env_id=cell.env_id, scenario=cell.scenario, policy=cell.policy, params=cell.params_dict,
                seed=seed, outcome=outcome, obstacle=info.get("obstacle"),
                robot={"foot_length": robot.foot_length, "foot_width": robot.foot_width,
                       "body_radius": robot.body_radius},
                start=tuple(centre[0]), goal=tuple(float(v) for v in cfg.goal),
                goal_tolerance=float(cfg.goal_tolerance),
                shapes=[ObstacleShape(o.name, o.kind, o.static, float(o.radius), tuple(o.a), tuple(o.b))
                        for o in snaps[0].obstacles],
                times=np.array([s.time for s in snaps], dtype=float),
                poses=np.stack([_poses(s) for s in snaps]),
                com=np.array([s.com for s in snaps], dtype=float),
                centre=centre,
                footprints=[(tuple(float(v) for v in pose), int(side)) for pose, side in base.history["footprints"]],
                com_path=com_path,
                zmp=np.asarray(base.history["zmp"], dtype=float).reshape(-1, 2),
                commands=np.asarray(applied, dtype=float).reshape(-1, 5),
                planned=np.asarray(planned, dtype=float).reshape(-1, 5),
                pre_pso=np.asarray(pre_pso, dtype=float).reshape(-1, 5),
                pso_ran=pso_ran,
            )
        return result
    finally:
        env.close()
