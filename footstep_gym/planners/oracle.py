"""The oracle: the period-aware planner told the truth. An upper bound, never a baseline.

``oracle`` (:class:`OraclePlanner`) is ``period-aware`` with one change: where the planner
predicts the obstacles from what it senses now (constant velocity, a sensed acceleration, short
horizons for unsteady shapes), the oracle asks the env's own model of every obstacle where it
will be, and it reads the true state rather than the sensed one (the env's sensing noise, range
and field of view, ``configs/env.yaml``'s ``sensing_*``, act on the moving obstacles' views only:
the oracle reads every body off the world, noise-free, with the robot's own state from
``sensing()``, which is always true). Everything else is period-aware's: the same three stages,
margins, additions and random numbers. What it scores is how far better prediction could take
this planner, so the evaluation tables mark it "(upper bound)" and no comparison should count it
as a competitor.

**Where the truth comes from.** The env is handed to the oracle through one labelled door,
:meth:`OraclePlanner.bind_truth`, which the evaluation runner calls for policies that declare
``reads_truth = True`` and for no other (:func:`footstep_gym.evaluation.runner.bind_truth`);
an unbound oracle refuses to act. Each step it builds a :class:`TruthModel` from the scenario at
the current time, for each obstacle ``tau -> pose``:

* walls: where they are;
* a shape whose scenario never changes velocities (the door's rod turning at ``door_speed``,
  the crossing's car): its true velocity and angular velocity, exactly;
* a member of the scripted crowd: its schedule, :meth:`~footstep_gym.scenarios.crowd.Crowd.positions`
  (the env moves it along the chord between two places of the schedule over each footstep);
* a scheduled shape of another scenario (a scenario whose ``members`` follow ``positions(t)``,
  such as the crossing's steady traffic): its scheduled place at each footstep's start, where the
  env puts it, and its own velocity through the footstep;
* an ORCA pedestrian (``crowd_model: orca``): ORCA itself, run forward on a copy of the scene's
  :class:`~footstep_gym.scenarios.orca.OrcaCrowd` (every pedestrian's goal, preferred speed,
  radius and RVO2 state) for :data:`ORCA_HORIZON_S` seconds in steps of ``orca_time_step``.

**Approximations (documented, not hidden).** (1) The env places a scheduled shape (and sets its
velocity) at each footstep's start; the oracle knows the footsteps' boundaries only for the walk
it is checking, whose steps all take the walk's period ``T``, so it places the shape at
``now + kT`` (a crowd member then on the chord to its place at ``now + (k + 1) T``): exact for that
walk, and off only where the planner later changes the period (the PSO's repair, the next
replanning). For constant motion the steps are the motion itself. (2) ORCA pedestrians react
to the robot (``robot_visible``): the oracle cannot know its own future steps while planning
them, so in the forward run the robot walks from its CoM straight at the goal at its nominal
walking speed (the longest front stride per nominal period)
and stops there; the env also cuts a footstep of ``T`` into ``ceil(T / orca_time_step)``
equal ORCA steps where the forward run takes steps of exactly ``orca_time_step``. Beyond
:data:`ORCA_HORIZON_S` (ORCA's own time horizon, 5 s) a pedestrian is not predicted, as the
planner leaves any moving shape out beyond its horizon. A scenario that moves obstacles some
other way has no true model here: the oracle raises ``NotImplementedError`` rather than guess.

**A bound on prediction, not on every episode.** The oracle is as greedy as period-aware: it
replans every footstep, its period search checks walks with a wider margin than its RRT, and its
RRT's path need not be one the LIPM can follow. Knowing the truth, it walks closer to a crowd, and
now and then a step it takes leaves no free walk a step later where period-aware's rougher guess
had kept it farther off: on some seeds it fails where period-aware does not, and on a fast scripted
crowd more often than period-aware. It bounds what better prediction buys where the prediction is
what fails (sensing noise, obstacles that change speed; ``tests/test_oracle.py``), not each episode
or every cell.

**Kernels.** The compiled kernels read one constant-velocity row per shape, so the oracle plans
with the numpy kernels (``kernels.compiled: false``, set by its registry entry; a config that asks
for the compiled ones is refused): :class:`TruthBody` is a
:class:`~footstep_gym.planners.prediction.BodyModel` whose checks pass the walk's period down to
:class:`TruthPredictor`, an :class:`~footstep_gym.planners.prediction.ObstaclePredictor` whose
shapes stand where the truth puts them at each point's own time.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from typing import Any, Callable

import numpy as np

from footstep_gym.kernels import ShapeTable
from footstep_gym.planners.params import PlannerConfig
from footstep_gym.kernels.numpy_kernels import centre_line_gap2
from footstep_gym.planners.prediction import BodyModel, ObstaclePredictor
from footstep_gym.planners.staged import PeriodAwarePlanner
from footstep_gym.planners.walks import WalkStart
from footstep_gym.robot import Robot
from footstep_gym.sensing import ObstacleView, Snapshot

#: [s] How far ahead an ORCA pedestrian is simulated (and predicted): ORCA's own time horizon in
#: configs/scenarios/crowd.yaml (``orca_time_horizon``), beyond which the forward run's guess of the
#: robot's motion dominates what the pedestrians do.
ORCA_HORIZON_S = 5.0

#: The registry's one line on it (``eval_planner.py --help``, the tables).
DESCRIPTION = ("UPPER BOUND, not a baseline: period-aware told every obstacle's true future (the scenario's "
               "schedule, ORCA run forward) and the noise-free state; runs only where the evaluation binds it "
               "to the env (bind_truth)")


def true_snapshot(env: Any) -> Snapshot:
    """What ``env`` (a :class:`~footstep_gym.env.FootstepEnv`) senses now, with every obstacle's true view.

    ``env.sensing()`` with its obstacles replaced by the world's bodies as they are
    (``World.views``): none of the sensing noise, range or field of view of ``configs/env.yaml``
    (which act on the moving obstacles only; the robot's own state in ``sensing()`` is true).
    """
    return dataclasses.replace(env.sensing(), obstacles=env.world.views())


class TruthModel:
    """Every obstacle of ``views`` (the true views at ``env.time``) over the next ``horizon`` [s], from the env's
    own model of it: :meth:`boundaries` gives each shape's body pose at ``tau = 0, T, 2T, ...`` after now and
    its velocity through each step of ``T``, :meth:`poses` its pose at any time of a walk of period ``T``.

    ``horizons`` (per shape, ``(S,)`` [s]): how far the truth is known (``inf``; :data:`ORCA_HORIZON_S`
    for an ORCA pedestrian). See the module's doc for where each shape's truth comes from.
    """

    def __init__(self, env: Any, views: tuple[ObstacleView, ...], horizon: float,
                 orca_horizon: float = ORCA_HORIZON_S) -> None:
        from footstep_gym.scenarios.base import Scenario
        from footstep_gym.scenarios.crowd import Crowd

        self.t0 = float(env.time)
        self.horizon = float(horizon)
        self.orca_horizon = float(orca_horizon)
        n = len(views)
        self.position = np.array([complex(*v.position) for v in views], dtype=complex).reshape(n)
        self.velocity = np.array([complex(*v.velocity) for v in views], dtype=complex).reshape(n)
        self.angle = np.array([v.angle for v in views], dtype=float).reshape(n)
        self.omega = np.array([v.angular_velocity for v in views], dtype=float).reshape(n)
        self.horizons = np.full(n, np.inf)
        self._cache: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
        # Shapes a scenario puts on a schedule (its ``members``): their columns, their rows of the schedule, the
        # schedule ``taus (K,) -> (K, n)`` complex centres, and whether a step follows the chord between two of
        # its places (the crowd) or the shape's own velocity from the step's first place (steady traffic).
        self._scheduled: list[tuple[np.ndarray, np.ndarray, Callable[[np.ndarray], np.ndarray], bool]] = []

        scenario = env.scenario
        members = {o.name: i for i, o in enumerate(getattr(scenario, "members", None) or [])}
        steady = type(scenario).before_step is Scenario.before_step  # never changes a velocity or a place
        columns, rows = [], []
        for s, v in enumerate(views):
            if v.static:
                continue
            if v.name in members and not steady:  # a steady scenario's members move as they are moving
                columns.append(s)
                rows.append(members[v.name])
            elif not steady:
                raise NotImplementedError(f"oracle: no true model of {v.name!r} in {type(scenario).__name__}, whose "
                                          "before_step moves it")
        if not columns:
            return
        cols, idx = np.array(columns), np.array(rows)
        orca = getattr(scenario, "orca", None)
        if orca is not None:
            model = self._orca_model(env, orca, min(self.horizon, orca_horizon))
            self.horizons[cols] = min(self.horizon, orca_horizon)
        elif callable(getattr(scenario, "positions", None)):
            model = self._schedule_model(scenario)
        else:
            raise NotImplementedError(f"oracle: no true model of {type(scenario).__name__}'s members (no "
                                      "positions(t) schedule, no ORCA crowd)")
        self._scheduled.append((cols, idx, model, isinstance(scenario, Crowd)))

    # ------------------------------------------------------------ the models
    def _schedule_model(self, scenario: Any) -> Callable[[np.ndarray], np.ndarray]:
        """``taus (K,) -> (K, n)`` complex centres: the scenario's own schedule, ``positions(t)`` (``positions_at``,
        all the times in one call, where the scenario has it)."""
        t0 = self.t0
        many = getattr(scenario, "positions_at", None)
        if callable(many):
            def model_at(taus: np.ndarray) -> np.ndarray:
                rows = np.asarray(many(t0 + np.asarray(taus, dtype=float)), dtype=float)
                return (rows[..., 0] + 1j * rows[..., 1]).reshape(len(taus), -1)

            return model_at

        def model(taus: np.ndarray) -> np.ndarray:
            rows = [np.asarray(scenario.positions(t0 + float(tau)), dtype=float) for tau in taus]
            return np.array([r[:, 0] + 1j * r[:, 1] for r in rows]).reshape(len(taus), -1)

        return model

    def _orca_model(self, env: Any, orca: Any, horizon: float) -> Callable[[np.ndarray], np.ndarray]:
        """``taus (K,) -> (K, n)`` complex pedestrian centres: ORCA run forward on a copy of the scene's crowd,
        the robot walking straight at the goal at its nominal speed (the module's doc); linear between ORCA
        steps, held at the last one beyond ``horizon`` (where the predictor ignores them anyway)."""
        sim = copy.deepcopy(orca)
        dt = float(sim.params.time_step)
        steps = max(1, math.ceil(horizon / dt - 1e-9))
        robot = env.robot
        speed = float(robot.stride_front[1]) / robot.nominal_period
        com = complex(env.com)
        goal = complex(*(float(g) for g in env.episode_config.goal))
        distance = abs(goal - com)
        heading = (goal - com) / distance if distance > 0 else 0j
        arrive = distance / speed if speed > 0 else 0.0
        table = [np.array([complex(x, y) for x, y in sim.positions])]
        for j in range(steps):
            s = j * dt
            position = com + heading * speed * min(s, arrive)
            velocity = heading * speed if s < arrive else 0j
            sim.advance(dt, (position.real, position.imag), (velocity.real, velocity.imag))
            table.append(np.array([complex(x, y) for x, y in sim.positions]))
        grid = dt * np.arange(steps + 1)
        positions = np.stack(table)  # (steps + 1, n)

        def model(taus: np.ndarray) -> np.ndarray:
            taus = np.clip(np.asarray(taus, dtype=float), 0.0, grid[-1])
            out = np.empty((len(taus), positions.shape[1]), dtype=complex)
            for i in range(positions.shape[1]):
                out[:, i] = (np.interp(taus, grid, positions[:, i].real)
                             + 1j * np.interp(taus, grid, positions[:, i].imag))
            return out

        return model

    # ------------------------------------------------------------ queries
    def boundaries(self, period: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """For a walk whose steps take ``T = period`` [s]: at ``tau = kT``, ``k = 0..K`` (``K T`` just past the
        horizon), body centres ``(K + 1, S)`` complex [m] and angles [rad]; through step ``k`` (from ``kT`` to
        ``(k + 1) T``) the velocities ``(K + 1, S)`` complex [m/s] and angular velocities [rad/s] the env gives
        the bodies. Remembered per period."""
        key = float(period)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        if not key > 0:
            raise ValueError(f"oracle: a walk's period must be > 0, got {period!r}")
        k_max = (max(1, math.ceil(self.horizon / key)) + 1) if math.isfinite(self.horizon) else 1
        taus = key * np.arange(k_max + 2)
        centres = self.position[None, :] + self.velocity[None, :] * taus[:, None]
        angles = self.angle[None, :] + self.omega[None, :] * taus[:, None]
        velocities = np.broadcast_to(self.velocity, centres.shape).copy()
        for cols, idx, model, chord in self._scheduled:
            places = model(taus)[:, idx]
            centres[:, cols] = places
            angles[:, cols] = self.angle[cols][None, :]
            if chord:  # the env moves the member along the chord between two places of its schedule
                velocities[:-1, cols] = (places[1:] - places[:-1]) / key
                velocities[-1, cols] = velocities[-2, cols]
        omegas = np.broadcast_to(self.omega, angles.shape)
        out = (centres[:-1], angles[:-1], velocities[:-1], omegas[:-1])
        self._cache[key] = out
        return out

    def poses(self, taus: np.ndarray, period: float, columns: np.ndarray | None = None
              ) -> tuple[np.ndarray, np.ndarray]:
        """Body centres ``(N, S)`` complex [m] and angles ``(N, S)`` [rad] at ``taus (N,)`` [s] after now, for a walk
        whose steps take ``period`` [s]: from the step's first place at the velocity of the step. ``columns``: only
        these shapes' (indices; ``S`` of them)."""
        centres, angles, velocities, omegas = self.boundaries(period)
        if columns is not None:
            centres, angles = centres[:, columns], angles[:, columns]
            velocities, omegas = velocities[:, columns], omegas[:, columns]
        k, dt = _step_of(taus, period, len(centres))
        return centres[k] + velocities[k] * dt, angles[k] + omegas[k] * dt


def _complex_points(points: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points ``(N, 2)`` [m] as complex ``(N,)`` and their times ``(N,)`` [s] (a scalar time broadcast)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    p = pts[:, 0] + 1j * pts[:, 1]
    return p, np.broadcast_to(np.asarray(times, dtype=float), p.shape)


def _repeated_row(times: np.ndarray, shortest: int = 64) -> int:
    """The length ``L`` of the row of times that ``times (N,)`` repeats (``N / L`` copies of ``times[:L]``, as a
    library's walks share their steps' times), or ``N`` where it repeats none (or ``N < shortest``: not worth it)."""
    n = len(times)
    if n < shortest:
        return n
    again = np.flatnonzero(times[1:] == times[0])
    if again.size:
        row = int(again[0]) + 1
        if n % row == 0 and (times.reshape(-1, row) == times[:row]).all():
            return row
    return n


def _step_of(taus: np.ndarray, period: float, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """For times ``taus (N,)`` [s] of a walk of period ``period`` [s]: each one's step ``k (N,)`` (at most
    ``steps - 1``, the last row of :meth:`TruthModel.boundaries`) and its time into that step ``(N, 1)`` [s]."""
    x = np.maximum(np.asarray(taus, dtype=float), 0.0) / float(period)
    k = np.minimum(np.floor(x).astype(int), steps - 1)
    return k, ((x - k) * float(period))[:, None]


class TruthPredictor(ObstaclePredictor):
    """An :class:`ObstaclePredictor` whose shapes stand where a :class:`TruthModel` puts them.

    Its shapes (geometry, order) are the snapshot's; their poses at a point's time come from the
    truth, on the chords of a walk of period ``T`` (:meth:`free_at`, :meth:`clearance_at`). A moving
    shape is left out beyond ``horizon`` [s] (and beyond its own truth's horizon), as the planner's
    predictor leaves it out. Its shape table would be the constant-velocity prediction: the checks that
    do not pass the walk's period (:meth:`free`, :meth:`clearance`) are refused.
    """

    def __init__(self, snapshot: Snapshot, truth: TruthModel, horizon: float) -> None:
        super().__init__(snapshot, horizon=horizon)
        self.truth = truth
        n = len(snapshot.obstacles)
        moving = np.array([not v.static for v in snapshot.obstacles], dtype=bool).reshape(n)
        self._truth_horizon = np.where(moving, np.minimum(float(horizon), truth.horizons), np.inf)
        geometry = [(complex(*v.a), complex(*(v.b if v.kind == "segment" else v.a)), v.radius)
                    for v in snapshot.obstacles]
        self._la = np.array([g[0] for g in geometry], dtype=complex).reshape(n)
        self._lab = np.array([g[1] - g[0] for g in geometry], dtype=complex).reshape(n)
        self._lab2 = np.abs(self._lab) ** 2
        self._r = np.array([g[2] for g in geometry], dtype=float).reshape(n)
        # Shapes the truth never moves (static, at rest): their pose at any time is the one now, so their centre
        # lines are placed once, not at every point's time (the same numbers: the truth's pose of a shape at rest
        # is its place plus a zero velocity times the time).
        fixed = ~moving & (truth.velocity == 0) & (truth.omega == 0)
        self._fixed, self._moves = np.flatnonzero(fixed), np.flatnonzero(~fixed)
        m = self._moves
        self._r_moves = self._r[m]
        self._moves_horizon = self._truth_horizon[m] if np.isfinite(self._truth_horizon[m]).any() else None
        # Moving shapes none of which turns (no angular velocity; a scheduled shape keeps its angle): each one's
        # angle at any time is its angle now plus zero, so it is turned once, not at every point's time (the same
        # numbers: exp(i (angle + 0)) is exp(i angle)).
        self._moves_rot = np.exp(1j * truth.angle[m]) if not truth.omega[m].any() else None
        #: Per walk period: the truth's boundaries of the moving shapes (TruthModel.boundaries' columns ``m``).
        self._tables: dict[float, tuple[np.ndarray, ...]] = {}
        self._fixed_pose = (truth.position[fixed], np.exp(1j * truth.angle[fixed]))
        origin = self._fixed_pose[0] + self._fixed_pose[1] * self._la[fixed]
        ends = np.stack([origin, origin + self._fixed_pose[1] * self._lab[fixed]])
        self._fixed_box = (ends.real.min(axis=0), ends.real.max(axis=0), ends.imag.min(axis=0), ends.imag.max(axis=0))

    def _near_fixed(self, p: np.ndarray, reach: np.ndarray) -> np.ndarray:
        """Indices of the fixed shapes whose centre line may come within ``reach (F,)`` [m] of some point of ``p (N,)``
        (complex): the others' bounding boxes lie farther (plus a micrometre) from the points' bounding box."""
        lo_x, hi_x, lo_y, hi_y = self._fixed_box
        gap_x = np.maximum(np.maximum(lo_x - p.real.max(), p.real.min() - hi_x), 0.0)
        gap_y = np.maximum(np.maximum(lo_y - p.imag.max(), p.imag.min() - hi_y), 0.0)
        return np.flatnonzero(np.hypot(gap_x, gap_y) <= reach + 1e-6)

    def _fixed_gap2(self, p: np.ndarray, shapes: np.ndarray | None = None) -> np.ndarray:
        """Squared distances ``(N, F)`` from each point ``p (N,)`` (complex) to the fixed shapes' centre lines
        (``shapes``: only these of them, indices into the fixed shapes)."""
        centre, rot = self._fixed_pose
        f = self._fixed
        if shapes is not None:
            f, centre, rot = f[shapes], centre[shapes], rot[shapes]
        return centre_line_gap2(p, centre, rot, self._la[f], self._lab[f], self._lab2[f])

    def _moving_gap2(self, p: np.ndarray, times: np.ndarray, period: float) -> np.ndarray:
        """Squared distances ``(N, M)`` from each point ``p (N,)`` (complex) at its time ``times (N,)`` [s] to each
        moving shape's centre line where the truth puts it for a walk of period ``period`` [s], ``inf`` beyond the
        shape's horizon (not checked); the columns in ``self._moves``' order."""
        m = self._moves
        if not m.size:
            return np.empty((len(p), 0))
        centres, angles, velocities, omegas = self._moving_table(period)
        # The poses at the times of one row: the walks of a library share their steps' times, and a shape's pose
        # depends on the time alone, so each is computed once and repeated for every walk (the same numbers).
        row = _repeated_row(times)
        k, dt = _step_of(times[:row], period, len(centres))
        centre = centres[k] + velocities[k] * dt  # TruthModel.poses, of the moving shapes
        rot = self._moves_rot if self._moves_rot is not None else np.exp(1j * (angles[k] + omegas[k] * dt))
        if row < len(times):
            rows = (len(times) // row, 1)
            centre = np.tile(centre, rows)
            rot = rot if rot.ndim == 1 else np.tile(rot, rows)
        moving = centre_line_gap2(p, centre, rot, self._la[m], self._lab[m], self._lab2[m])
        horizon = self._moves_horizon
        if horizon is not None and len(times) and times.max() > horizon.min():
            moving[times[:, None] > horizon] = np.inf
        return moving

    def _moving_table(self, period: float) -> tuple[np.ndarray, ...]:
        """:meth:`TruthModel.boundaries` at ``period`` [s], the moving shapes' columns only (remembered per period)."""
        key = float(period)
        table = self._tables.get(key)
        if table is None:
            table = self._tables[key] = tuple(a[:, self._moves] for a in self.truth.boundaries(key))
        return table

    def free_at(self, points: np.ndarray, times: np.ndarray, safe_distance: float, period: float) -> np.ndarray:
        """``clearance >= safe_distance`` for each point at its time, a walk of period ``period`` [s]: ``(N,)`` bool."""
        p, tt = _complex_points(points, times)
        free = np.ones(len(p), dtype=bool)
        if self._fixed.size and len(p):
            reach = self._r[self._fixed] + safe_distance
            near = self._near_fixed(p, reach)
            if near.size:
                free &= (self._fixed_gap2(p, near) >= reach[near] ** 2).all(axis=1)
        if self._moves.size:
            free &= (self._moving_gap2(p, tt, period) >= (self._r_moves + safe_distance) ** 2).all(axis=1)
        return free

    def clearance_at(self, points: np.ndarray, times: np.ndarray, period: float) -> np.ndarray:
        """Distance [m] from each point (at its time, a walk of period ``period``) to the nearest shape, ``(N,)``."""
        p, tt = _complex_points(points, times)
        return np.minimum((np.sqrt(self._fixed_gap2(p)) - self._r[self._fixed]).min(axis=1, initial=np.inf),
                          (np.sqrt(self._moving_gap2(p, tt, period)) - self._r_moves).min(axis=1, initial=np.inf))

    def free(self, points: np.ndarray, times: np.ndarray, safe_distance: float) -> np.ndarray:
        raise TypeError("the oracle's truth depends on the walk's period: use free_at (TruthBody passes it)")

    def clearance(self, points: np.ndarray, times: np.ndarray) -> np.ndarray:
        raise TypeError("the oracle's truth depends on the walk's period: use clearance_at (TruthBody passes it)")


class TruthBody(BodyModel):
    """:class:`BodyModel` over a :class:`TruthPredictor`: each check passes its walk's period to the truth.
    It has no shape table, so only the numpy kernels check it."""

    predictor: TruthPredictor

    @property
    def shapes(self) -> ShapeTable:
        raise TypeError("the oracle's truth has no shape table for the compiled kernels: it plans with the numpy "
                        "kernels only (kernels.compiled: false)")

    def free(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray, period: float) -> np.ndarray:
        pts, needed = self.centres(points, support_normals, period)
        return self.predictor.free_at(pts, times, needed, period)

    def slack(self, points: np.ndarray, times: np.ndarray, support_normals: np.ndarray, period: float) -> np.ndarray:
        pts, needed = self.centres(points, support_normals, period)
        return self.predictor.clearance_at(pts, times, period) - needed


class TruthBound:
    """The one labelled door to the truth, shared by the privileged planners (``oracle``, ``oracle-lookahead``):
    ``reads_truth``, :meth:`bind_truth` (the evaluation runner's call), and an :meth:`act` that refuses to act
    unbound and otherwise plans on the bound env's true snapshot (:func:`true_snapshot`), ignoring the one given.
    Mixed in before the planner class it wraps."""

    reads_truth = True
    _env: Any = None

    def bind_truth(self, env: Any) -> None:
        """Let the planner read the truth of ``env`` (a ``FootstepEnv``, or a wrapper of one): the one door."""
        self._env = getattr(env, "unwrapped", env)

    @property
    def bound(self) -> bool:
        return self._env is not None

    def act(self, observation: Any, snapshot: Snapshot | None) -> np.ndarray:
        if self._env is None:
            raise RuntimeError(f"{self.name} is an upper bound that reads the true future: it acts only once bound "
                               "to its env with bind_truth(env), which the evaluation runner does for policies "
                               "with reads_truth = True")
        return super().act(observation, true_snapshot(self._env))  # type: ignore[misc]


class OraclePlanner(TruthBound, PeriodAwarePlanner):
    """``period-aware`` told the truth (the module's doc): an upper bound, labelled so in every table.

    ``reads_truth``: the evaluation runner binds it to the env (:meth:`bind_truth`) before its first act;
    no other registered policy declares it. Unbound, :meth:`act` raises ``RuntimeError``. The snapshot
    passed to :meth:`act` is ignored: the oracle reads the true one off the bound env.
    """

    name = "oracle"

    def __init__(self, robot: Robot, config: PlannerConfig, seed: int | None = None, name: str | None = None) -> None:
        if config.kernels.compiled:
            raise ValueError("the oracle plans with the numpy kernels: kernels.compiled must be false (its registry "
                             "entry sets it; the compiled kernels assume constant velocities)")
        super().__init__(robot, config, seed, name)
        self._env: Any = None
        self.orca_horizon = ORCA_HORIZON_S

    def _predict(self, snapshot: Snapshot, start: WalkStart) -> tuple[BodyModel, BodyModel, int]:
        """The body checks of the RRT and of the period search over the true future of the obstacles."""
        truth = TruthModel(self._env, snapshot.obstacles, self.horizon, self.orca_horizon)
        predictor = TruthPredictor(snapshot, truth, self.horizon)
        self.predictor = predictor
        body = TruthBody(predictor, self.robot, self.margin, sway=self.com_sway)
        search_body = TruthBody(predictor, self.robot, self.search_margin, sway=self.com_sway)
        return body, search_body, 0
