"""Running evaluation episodes (in this process, in worker processes or as Ray tasks) and recording them.

:func:`run_episode` builds a fresh env and policy, seeds both with the episode's seed
(``env.reset(seed=s)``, ``policy.reset(seed=s)``), so an episode's result does not depend
on which process ran it or what ran before, and returns an
:class:`~footstep_gym.evaluation.stats.EpisodeResult`. With ``record=True`` it also returns
a :class:`Trace`: everything the figures and command tables need, taken from what the env
records (``env.unwrapped.history``, the ``info`` of each step) and from ``sensing()``
before every footstep and once after the last one (obstacle poses, CoM, robot centre).

The policy's act time is measured after a warm-up (:func:`warm_up`): the first acts of a
policy in a fresh process load (or compile) the planners' numba kernels and an agent's
torch graph, which is start-up, not planning; so each process first acts
:data:`WARMUP_ACTS` times untimed, on a throwaway env, with each cell's policy.
An ``on_step`` hook (:func:`run_episode`) sees every footstep's timings (sensing, act, env
step) and the policy's ``last_info``: the speed run (``baselines/speed.py``) times
the planners through this loop.

:func:`run_tasks` runs many episodes on a backend (``"local"``: worker processes on this
machine; ``"ray"``: Ray tasks on a local Ray or a cluster), with a progress bar that moves
as episodes finish; the results are the same whatever the backend.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterator, Sequence

import gymnasium as gym
import numpy as np

import footstep_gym  # noqa: F401  (registers the envs)
from footstep_gym.errors import ActionError, FootstepGymError
from footstep_gym.evaluation.stats import EpisodeResult

if TYPE_CHECKING:
    from footstep_gym.registry import PolicyEntry

#: ``factory(cell, robot, seed) -> policy`` with ``reset(seed=...)`` and ``act(obs, snapshot)``.
PolicyFactory = Callable[..., Any]


@dataclass(frozen=True)
class ActTiming:
    """One footstep of an episode as :func:`run_episode`'s ``on_step`` hook sees it, right after it.

    ``act_s`` is the time ``EpisodeResult.plan_ms`` records (in seconds); ``sense_s`` the
    ``sensing()`` call that made the snapshot this act saw (after the reset or the previous
    step); ``step_s`` the ``env.step``. ``last_info`` is the policy's ``last_info`` after the
    act (``{}`` without one: per-stage times such as ``time_pso_ms``, ``pso_ran``).
    """

    footstep: int  # 1 for the episode's first
    sense_s: float  # [s]
    act_s: float  # [s]
    step_s: float  # [s]
    action: Any  # what the policy returned
    last_info: dict[str, Any]
    info: dict[str, Any]  # env.step's info
    terminated: bool
    truncated: bool


#: ``on_step(timing) -> stop``: called after every footstep of :func:`run_episode` (never during the warm-up);
#: a true return ends the episode there (it is then reported as a timeout, the outcome of an episode cut short).
StepHook = Callable[[ActTiming], Any]

BACKENDS = ("local", "ray")

#: Untimed acts of each cell's policy, once per process, before its first timed episode (:func:`warm_up`).
WARMUP_ACTS = 10


def safe_name(*parts: str) -> str:
    """One file name from ``parts`` joined by ``_``, safe on every file system and shell.

    Every character other than a letter, a digit, ``.``, ``-`` or ``_`` becomes ``-``:
    ``safe_name("door_17", "agent:FootstepDoor-v0_1")`` is ``door_17_agent-FootstepDoor-v0_1``.
    Every file an evaluation names after a setting or a policy goes through this.
    """
    return re.sub(r"[^A-Za-z0-9._-]", "-", "_".join(parts))


class PolicyFailed(FootstepGymError, RuntimeError):
    """The policy itself failed (built, reset or acted wrongly) in an episode: one line naming it and the episode."""


@dataclass(frozen=True)
class Cell:
    """One evaluation cell: an env id, a policy's name, env keyword arguments (``params``) and, for a trained agent,
    the training run evaluated (a zoo run folder or a model ``.zip``; ``algo`` and ``vecnormalize`` for a ``.zip``
    without the zoo's files).

    ``entry``: the policy's :class:`~footstep_gym.registry.PolicyEntry`, resolved once by whoever made the cell
    (the benchmark, an evaluation's settings) and carried to the workers with it; a cell made with a name alone
    (a test's, a speed run's) has its name resolved by :attr:`policy_entry` when its policy is built."""

    env_id: str
    scenario: str  # a key of footstep_gym.scenarios.SCENARIOS (door / crossing / crowd)
    policy: str
    params: tuple[tuple[str, float], ...] = ()  # (key, value) pairs of the scenario's sweep_axes, in their order
    run: str | None = None  # agents: path of the training run; planners: None
    algo: str | None = None  # agents: the algorithm, where the run does not name it (a plain .zip)
    vecnormalize: str | None = None  # agents: a VecNormalize file given apart from the run
    entry: PolicyEntry | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.entry is not None and self.entry.name != self.policy:
            raise ValueError(f"Cell: entry {self.entry.name!r} is not policy {self.policy!r}")

    @property
    def policy_entry(self) -> PolicyEntry:
        """The policy's entry: the one the cell carries, else its name resolved (:func:`footstep_gym.registry.resolve`)."""
        if self.entry is not None:
            return self.entry
        from footstep_gym import registry

        return registry.resolve(self.policy)

    @property
    def params_dict(self) -> dict[str, float]:
        return dict(self.params)

    @property
    def setting(self) -> str:
        """Short name of the env and its parameters, e.g. ``door_17`` (file names, figure titles); a benchmark
        cell's text values as they are (``door_paper_door-17``)."""
        return "_".join([self.scenario] + [f"{v:g}" if isinstance(v, (int, float)) else str(v)
                                           for _, v in self.params])

    @property
    def run_name(self) -> str | None:
        """The training run's folder name (``FootstepDoor-v0_1``), or None for a planner."""
        return None if self.run is None else Path(self.run).name


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
def planner_notes(last_info: dict[str, Any] | None) -> tuple[np.ndarray | None, bool | None]:
    """``(command before PSO or None, whether PSO ran or None)`` from a policy's ``last_info`` after ``act``.

    The reference planners report ``command_pre_pso`` (``None`` for ``pso-only``, which has
    no earlier stage) and ``pso_ran``; a policy without ``last_info`` reports neither.
    """
    info = last_info or {}
    pre = info.get("command_pre_pso")
    ran = info.get("pso_ran")
    return (None if pre is None else np.asarray(pre, dtype=float).reshape(5),
            None if ran is None else bool(ran))


# ---------------------------------------------------------------- running
def bind_truth(policy: Any, env: Any) -> bool:
    """Hand ``env`` to ``policy`` if it declares ``reads_truth = True`` (the oracle, an upper bound); return whether.

    The one place the evaluation gives a policy more than ``env.unwrapped.sensing()`` and the
    observation: a policy that reads the true future (:class:`footstep_gym.planners.oracle.OraclePlanner`)
    gets the env through its ``bind_truth`` here, once per env, and every other policy gets nothing.
    """
    if getattr(policy, "reads_truth", False) is not True:
        return False
    policy.bind_truth(env.unwrapped)
    return True


def default_factory(cell: Cell, robot: Any, seed: int) -> Any:
    """The cell's policy, built from the entry it carries (:attr:`Cell.policy_entry`) for ``robot``, seeded ``seed``."""
    return cell.policy_entry.make(robot, seed, run=cell.run, algo=cell.algo, vecnormalize=cell.vecnormalize)


def _poses(snapshot: Any) -> np.ndarray:
    return np.array([(o.position[0], o.position[1], o.angle) for o in snapshot.obstacles], dtype=float).reshape(-1, 3)


def _finite_min(values: list[float]) -> float | None:
    """Smallest value; None if nothing was measured or nothing ever came near (inf)."""
    best = min(values, default=math.inf)
    return None if math.isinf(best) else best


def _polyline_length(points: np.ndarray) -> float:
    if len(points) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


#: What this process has warmed up: (env id, params, policy, run, factory) of each cell.
_warmed: set[tuple[Any, ...]] = set()


def warm_up(cell: Cell, seed: int, factory: PolicyFactory = default_factory, acts: int = WARMUP_ACTS) -> bool:
    """Once per process and cell: ``acts`` untimed acts of a throwaway policy on a throwaway env.

    A fresh process's first acts load the planners' compiled kernels from numba's disk
    cache (a few hundred ms; seconds of compilation after an install or an edit of the
    kernels) and build an agent's torch graph. The kernels a policy needs appear in its
    first few acts (each loads once per process); this runs them before any act is timed.
    The warm-up's env and policy are discarded: the timed episode builds and seeds its own,
    so results do not depend on it. Returns whether it ran (False: this process is warm).
    """
    key = (cell.env_id, cell.params, cell.policy, cell.run, factory)
    if key in _warmed:
        return False
    env = gym.make(cell.env_id, **cell.params_dict)
    try:
        policy, obs = _start(env, cell, seed, factory)
        _play(env, cell, seed, policy, obs, label="warm-up act {}", limit=acts)
    finally:
        env.close()
    _warmed.add(key)
    return True


def _start(env: gym.Env, cell: Cell, seed: int, factory: PolicyFactory) -> tuple[Any, np.ndarray]:
    """An episode's start: the policy made for the env's robot (the truth bound where it reads it), env and policy
    seeded with ``seed``; ``(policy, first observation)``."""
    policy = _policy_call(cell, seed, "building it", factory, cell, env.unwrapped.robot, seed)
    bind_truth(policy, env)
    obs, _ = env.reset(seed=seed)
    _policy_call(cell, seed, "reset", policy.reset, seed=seed)
    return policy, obs


def _policy_call(cell: Cell, seed: int, what: str, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)``, a failure raised as :class:`PolicyFailed` naming the policy, the episode and ``what``
    it was doing."""
    try:
        return fn(*args, **kwargs)
    except PolicyFailed:
        raise
    except Exception as exc:
        run = f" run={cell.run_name}" if cell.run else ""
        raise PolicyFailed(f"policy {cell.policy}{run} failed ({what}) on env={cell.env_id} params={cell.params_dict} "
                           f"seed={seed}: {type(exc).__name__}: {exc}") from exc


def _step(env: gym.Env, cell: Cell, seed: int, footstep: int, action: Any) -> tuple[Any, ...]:
    """``env.step(action)``; an action the env refuses (its shape, a non-finite field) is the policy's failure."""
    try:
        return env.step(action)
    except ActionError as exc:
        raise PolicyFailed(f"policy {cell.policy} returned a bad action at footstep {footstep} on env={cell.env_id} "
                           f"params={cell.params_dict} seed={seed}: {exc}") from exc


def _sense(env: gym.Env) -> tuple[Any, float]:
    """``env.unwrapped.sensing()`` and the seconds it took."""
    t0 = time.perf_counter()
    snapshot = env.unwrapped.sensing()
    return snapshot, time.perf_counter() - t0


#: ``visit(timing, snapshot) -> stop``: :func:`_play` calls it after every footstep with the snapshot sensed after
#: the step (the next act's); a true return ends the episode there.
Visit = Callable[[ActTiming, Any], Any]


def _play(env: gym.Env, cell: Cell, seed: int, policy: Any, obs: Any, first: tuple[Any, float] | None = None, *,
          label: str = "act at footstep {}", limit: int | None = None, visit: Visit | None = None
          ) -> tuple[dict[str, Any], bool, bool]:
    """The one episode loop: sense, act, step, until the episode ends, ``limit`` footsteps were taken or ``visit``
    returns true. ``first``: the snapshot after the reset and its sensing time (sensed here if None); ``label``
    names an act in a failure (``{}``: the footstep). Returns the last step's ``info``, ``terminated`` and
    ``truncated``."""
    snapshot, sense_s = first if first is not None else _sense(env)
    info: dict[str, Any] = {}
    terminated = truncated = False
    k = 0
    while not (terminated or truncated) and (limit is None or k < limit):
        k += 1
        t0 = time.perf_counter()
        action = _policy_call(cell, seed, label.format(k), policy.act, obs, snapshot)
        t1 = time.perf_counter()
        obs, _, terminated, truncated, info = _step(env, cell, seed, k, action)
        step_s = time.perf_counter() - t1
        snapshot, next_sense_s = _sense(env)
        if visit is not None and visit(ActTiming(k, sense_s, t1 - t0, step_s, action,
                                                 getattr(policy, "last_info", None) or {}, info, terminated,
                                                 truncated), snapshot):
            break
        sense_s = next_sense_s
    return info, terminated, truncated


def run_episode(task: Task, factory: PolicyFactory = default_factory, warm: bool = True,
                on_step: StepHook | None = None) -> EpisodeResult:
    """Run ``task``'s episode to its end; record a :class:`Trace` if ``task.record``.

    ``warm``: run :func:`warm_up` first (it acts only on a process's first episode of the cell).
    ``on_step``: called with an :class:`ActTiming` after every footstep (see :data:`StepHook`).
    """
    cell, seed = task.cell, task.seed
    try:
        if warm:
            warm_up(cell, seed, factory)
        return _run(task, factory, on_step)
    except PolicyFailed:
        raise
    except Exception as exc:  # name the episode: a worker's traceback alone does not
        run = f" run={cell.run_name}" if cell.run else ""
        raise RuntimeError(f"episode failed: env={cell.env_id} params={cell.params_dict} "
                           f"policy={cell.policy}{run} seed={seed}: {type(exc).__name__}: {exc}") from exc


def _run(task: Task, factory: PolicyFactory, on_step: StepHook | None = None) -> EpisodeResult:
    cell, seed = task.cell, task.seed
    env = gym.make(cell.env_id, **cell.params_dict)
    try:
        base = env.unwrapped
        policy, obs = _start(env, cell, seed, factory)
        first = _sense(env)
        snaps = [first[0]]
        plan_ms: list[float] = []
        periods: list[float] = []
        pso_ran: list[bool | None] = []
        clearance: list[float] = []
        zmp_margin: list[float] = []
        applied, planned, pre_pso = [], [], []

        def visit(timing: ActTiming, snapshot: Any) -> Any:
            info = timing.info
            pre, ran = planner_notes(timing.last_info)
            plan_ms.append(1e3 * timing.act_s)
            applied.append(info["command"])
            planned.append(np.asarray(timing.action, dtype=float).reshape(5))
            pre_pso.append(pre if pre is not None else np.full(5, np.nan))
            pso_ran.append(ran)
            periods.append(float(info["period"]))
            if info["clearance"] is not None:
                clearance.append(float(info["clearance"]))
            zmp_margin.append(float(info["zmp_margin"]))
            snaps.append(snapshot)
            return on_step is not None and on_step(timing)

        info, terminated, _ = _play(env, cell, seed, policy, obs, first, visit=visit)
        outcome = info["termination"] if terminated else "timeout"
        centre = np.array([s.centre for s in snaps], dtype=float)
        com_path = np.asarray(base.history["com"], dtype=float).reshape(-1, 2)
        result = EpisodeResult(
            cell_index=task.cell_index, seed=seed, outcome=outcome, steps=int(info["steps"]),
            time=float(info["time"]), path_length=_polyline_length(centre),
            com_path_length=_polyline_length(com_path), plan_ms=plan_ms, periods=periods, pso_ran=pso_ran,
            obstacle=info.get("obstacle"), min_clearance=_finite_min(clearance), min_zmp_margin=min(zmp_margin),
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


# ---------------------------------------------------------------- many episodes
def _local(tasks: list[Task], workers: int, factory: PolicyFactory) -> Iterator[EpisodeResult]:
    if workers <= 1:
        for task in tasks:
            yield run_episode(task, factory)
        return
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from multiprocessing import get_context

    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")  # one process per core; no nested BLAS threads
    # "spawn": each worker imports the package afresh (no state inherited from this process).
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"))
    try:
        pending = {pool.submit(run_episode, task, factory) for task in tasks}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                yield fut.result()  # re-raises an episode's error (it names the episode)
    finally:  # on an error or Ctrl-C, drop the queued episodes instead of running them
        pool.shutdown(wait=True, cancel_futures=True)


def _ray(tasks: list[Task], workers: int, address: str | None, factory: PolicyFactory) -> Iterator[EpisodeResult]:
    try:
        import ray
    except ImportError as exc:
        raise RuntimeError('--backend ray needs Ray: pip install "footstep_gym[ray]"') from exc
    started = not ray.is_initialized()
    if started:
        if address:
            ray.init(address=address, log_to_driver=False)
        else:  # a local Ray for this run, one CPU per worker
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
    try:
        remote = ray.remote(num_cpus=1)(run_episode)
        pending = [remote.remote(task, factory) for task in tasks]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            try:
                yield ray.get(done[0])
            except ray.exceptions.RayTaskError as exc:  # the episode's own error (it names the episode)
                raise exc.as_instanceof_cause() from None
    finally:
        if started:
            ray.shutdown()


def run_tasks(tasks: list[Task], workers: int = 1, backend: str = "local", address: str | None = None,
              progress: bool = True, factory: PolicyFactory = default_factory) -> list[EpisodeResult]:
    """Run every task; results sorted by (cell, seed), the same for every backend and worker count.

    ``backend="local"``: ``workers`` spawned processes (this process if 1); ``"ray"``: Ray
    tasks on the cluster at ``address`` (a local Ray of ``workers`` CPUs if None). The
    progress bar moves as each episode finishes. ``factory`` makes each episode's policy; it goes
    to the workers pickled (the default: the registry, by the cell's policy name).
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {BACKENDS}")
    if backend == "local" and address is not None:
        raise ValueError("address applies to backend='ray' only")
    from tqdm import tqdm

    stream = _ray(tasks, workers, address, factory) if backend == "ray" else _local(tasks, workers, factory)
    results: list[EpisodeResult] = []
    with tqdm(total=len(tasks), desc="episodes", unit="ep", dynamic_ncols=True, disable=not progress) as bar:
        for result in stream:
            results.append(result)
            bar.update()
    results.sort(key=lambda r: (r.cell_index, r.seed))
    return results


def record_video(cell: Cell, seed: int, folder: str | Path, name: str | None = None,
                 factory: PolicyFactory = default_factory) -> Path:
    """Play one episode of ``cell`` at ``seed`` and save it as ``<folder>/<name>.mp4`` (real time).

    The env draws frames inside every footstep (``render_mode="rgb_array_list"``), so the
    video plays at the env's ``video_fps`` in simulated time. Needs pygame-ce and moviepy.
    """
    from footstep_gym.wrappers import RecordVideo

    folder = Path(folder)
    name = safe_name(name or safe_name(cell.setting, cell.policy))
    folder.mkdir(parents=True, exist_ok=True)
    # The recorder writes into a folder of its own that does not exist yet (an existing one
    # makes Gymnasium warn that it overwrites videos), and the file is moved out of it.
    scratch = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=folder))
    try:
        env = gym.make(cell.env_id, render_mode="rgb_array_list", **cell.params_dict)
        env = RecordVideo(env, str(scratch / "recording"), name_prefix=name, episode_trigger=lambda _: True,
                          disable_logger=True)
        try:
            policy, obs = _start(env, cell, seed, factory)
            _play(env, cell, seed, policy, obs)
        finally:
            env.close()
        path = scratch / "recording" / f"{name}-episode-0.mp4"
        if not path.is_file():
            raise RuntimeError(f"RecordVideo wrote no {path.name} for {name}")
        final = folder / f"{name}.mp4"
        path.replace(final)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return final


def check_policy(cell: Cell, factory: PolicyFactory = default_factory, seed: int = 0) -> str | None:
    """Why ``cell``'s policy cannot run, as one line, or None: it is built for the cell's env (seeded ``seed``),
    reset, and acts once on the env's first observation; the command must be 5 finite numbers. What a submitted
    policy (``module:attr``, a callable) goes through before anything runs."""
    env = gym.make(cell.env_id, **cell.params_dict)
    try:
        base = env.unwrapped
        obs, _ = env.reset(seed=seed)
        try:
            policy = factory(cell, base.robot, seed)
            bind_truth(policy, env)
            policy.reset(seed=seed)
            action = policy.act(obs, base.sensing())
        except Exception as exc:
            from footstep_gym.registry import PolicyLoadError

            if isinstance(exc, PolicyLoadError):
                return str(exc)
            return f"policy {cell.policy}: {type(exc).__name__}: {exc}"
        try:
            command = np.asarray(action, dtype=float)
        except (TypeError, ValueError) as exc:
            return f"policy {cell.policy}: act returned {type(action).__name__}, not 5 numbers ({exc})"
        if command.shape != (5,):
            return (f"policy {cell.policy}: act returned shape {command.shape}, expected (5,): the footstep command "
                    "[S, L, theta, T_SS, T_DS]")
        if not np.all(np.isfinite(command)):
            return f"policy {cell.policy}: act returned a non-finite command {command.tolist()}"
    finally:
        env.close()
    return None


def check_cells(cells: "Sequence[Cell]", describe: "Callable[[Cell], str] | None" = None,
                factory: PolicyFactory = default_factory) -> str | None:
    """The first problem of any cell, as one line, or None: each setting's env is built once (its configuration
    checked, e.g. a door speed above ``max_door_speed``), each agent's files are checked (without loading it), and
    a submitted policy (imported by ``module:attr``, or any ``factory`` but the registry's) is built and acts once
    (:func:`check_policy`), in this process, before anything runs. ``describe(cell)`` names a cell's setting in
    the message (default: its keyword arguments)."""
    from footstep_gym.rl.agents import check_run

    built: set[tuple[str, Any]] = set()
    checked: set[Any] = set()
    for cell in cells:
        if (cell.env_id, cell.params) not in built:
            built.add((cell.env_id, cell.params))
            try:
                gym.make(cell.env_id, **cell.params_dict).close()
            except (ValueError, TypeError, KeyError) as exc:
                what = describe(cell) if describe is not None else (cell.params_dict or "its defaults")
                return f"{cell.env_id} with {what}: {exc}"
        if factory is not default_factory:
            if ("policy", cell.policy) not in checked:
                checked.add(("policy", cell.policy))
                problem = check_policy(cell, factory)
                if problem:
                    return problem
            continue
        try:
            entry = cell.policy_entry
        except ValueError as exc:
            return str(exc)
        if entry.kind == "import" and ("policy", cell.policy) not in checked:
            checked.add(("policy", cell.policy))
            problem = check_policy(cell, factory)
            if problem:
                return problem
        if cell.run is not None and cell.run not in checked:
            checked.add(cell.run)
            try:
                check_run(cell.run, cell.algo or (entry.agent.algo if entry.agent is not None else None),
                          cell.vecnormalize)
            except (OSError, ValueError) as exc:
                return f"{cell.policy}: {exc}"
    return None
