"""Tracking what is sensed: a Kalman filter per moving obstacle, between ``sensing()`` and the prediction.

The env's sensing options (``configs/env.yaml``, ``sensing_noise_*``) add fresh Gaussian noise to every
moving obstacle's pose and velocity at every footstep. A planner that extrapolates each raw reading walks
into what the noise hides (a door's fixed pivot sensed drifting at 5 cm/s). :class:`Tracker` keeps, per
moving obstacle, a filtered estimate across footsteps and hands the planner a
:class:`~footstep_gym.sensing.Snapshot` of the same form whose moving views are the estimates.

**Model.** Each axis of a shape's position (``x``, ``y``) and, for a rod (a segment), its angle is one
channel ``[value, rate]`` (position and velocity; angle and turn rate) with a constant-rate model whose rate
changes by a random step over each footstep: ``rate_k = rate_{k-1} + w_k``, ``value_k = value_{k-1} +
rate_k dt`` (the env holds each obstacle's velocity through a footstep and senses it at the footstep's end),
``w_k ~ N(0, q dt)``; so ``F = [[1, dt], [0, 1]]`` and ``Q = q dt [[dt^2, dt], [dt, 1]]``. Both the value
and the rate are measured, ``H = I``, ``R = diag(sigma_value^2, sigma_rate^2)``. A circle's angle and turn
rate are not sensed (its outline has none) and pass through. A footstep's elapsed time is its prediction
step; a track starts on first sight at its reading, which its first filtered step takes as the prior (covariance
``R``), and starts afresh at a reading that falls outside the gate (a car re-entering the scene).

**Noise levels.** Nothing is read from the env. The readings' stds are the sensor's profile
(``tracking.measurement_noise``: the one the env documents) or estimated from the readings themselves
(``tracking.estimate_noise``), and the linear rate-step density ``q`` is estimated beyond a floor, all
pooled over the obstacles and the episode (:class:`NoiseEstimator`). Three residuals of consecutive readings have
expectations linear in them: the *consistency* ``c = z_k - z_{k-1} - dz_k dt`` (``2 s_v^2 + dt^2 s_r^2``,
free of the motion), the rate's change (``2 s_r^2 + q dt``) and the middle reading of three against the
line through the outer two (``(1 + a^2 + (1 - a)^2) s_v^2 + q dt h^2``). While the consistency residual's
median is below ``tracking.noise_floor_*`` the readings are taken as exact and the tracker hands them on
unchanged (a noise-free env plans exactly as without it).

**Still or moving.** Beside the moving model, each shape's position is also filtered as standing still
(a door's pivot, a member waiting); the evidence of the readings for one over the other, with a prior for
"still" and earlier footsteps discounted, picks the estimate handed on (shapes keep their sensed size).

**A shared velocity.** Cars of a lane move at one velocity. With ``tracking.shared_velocity_gate`` above 0, the
moving tracks whose estimated velocities agree (normalised squared difference below the gate) are each handed on
conditioned on the precision-weighted mean velocity of the others, the filters' own states untouched (so no
reading counts twice across footsteps): a lane's velocity from all its cars, each car's position corrected along.

**Steady or not.** The prediction shortens the horizon of a shape whose velocity changed since the previous
footstep (``prediction.unsteady_*``). A filtered velocity moves each footstep by the filter's correction even
when the motion is steady; :meth:`Tracker.rate_change_stds` gives that correction's std (``P_pred S^-1 P_pred``),
and ``tracking.steady_stds`` of it are added to the tolerance.

The maths is vectorised over channels (:func:`predict`, :func:`update`); the tests hold it to a textbook
matrix Kalman filter and to synthetic tracks with known truth (``tests/test_tracking.py``).
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from footstep_gym.planners.params import TrackingParams
from footstep_gym.sensing import ObstacleView, Snapshot

#: The kinds of channel: a shape's position axes (m, m/s) and a rod's angle (rad, rad/s).
LINEAR, ANGULAR = "linear", "angular"
#: The median of a chi-square variable of one degree of freedom: ``median(e^2) / this`` estimates ``var(e)``.
CHI2_1_MEDIAN = 0.454936423119572


# ---------------------------------------------------------------- the filter's maths, batched over channels
def transition(dt: np.ndarray) -> np.ndarray:
    """``F (C, 2, 2)``: constant rate over ``dt (C,)`` [s]."""
    dt = np.asarray(dt, dtype=float)
    F = np.zeros(dt.shape + (2, 2))
    F[..., 0, 0] = F[..., 1, 1] = 1.0
    F[..., 0, 1] = dt
    return F


def process_noise(dt: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``Q (C, 2, 2)``: a rate step ``w ~ N(0, q dt)`` over the footstep, ``Q = q dt [[dt^2, dt], [dt, 1]]``."""
    dt = np.asarray(dt, dtype=float)
    g = np.stack([dt, np.ones_like(dt)], axis=-1)
    return (np.asarray(q, dtype=float) * dt)[..., None, None] * g[..., :, None] * g[..., None, :]


def predict(x: np.ndarray, P: np.ndarray, dt: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Channels ``x (C, 2)``, ``P (C, 2, 2)`` moved ``dt (C,)`` [s] ahead with rate-step density ``q (C,)``."""
    F = transition(dt)
    x = np.einsum("cij,cj->ci", F, x)
    P = F @ P @ np.swapaxes(F, -1, -2) + process_noise(dt, q)
    return x, P


def update(x: np.ndarray, P: np.ndarray, z: np.ndarray, r: np.ndarray, wrap: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Measure both components of each channel: ``z (C, 2)`` with variances ``r (C, 2)`` (``R = diag(r)``).

    Returns the posterior ``x``, ``P`` (Joseph form) and each channel's normalised innovation squared ``(C,)``.
    ``wrap (C,)`` bool: the channel's value is an angle, its innovation taken in ``[-pi, pi)``.
    """
    y = np.asarray(z, dtype=float) - x
    if wrap is not None:
        y[:, 0] = np.where(wrap, (y[:, 0] + math.pi) % (2 * math.pi) - math.pi, y[:, 0])
    R = np.zeros_like(P)
    R[:, 0, 0], R[:, 1, 1] = r[:, 0], r[:, 1]
    S = P + R
    S_inv = np.linalg.inv(S)
    K = P @ S_inv
    x = x + np.einsum("cij,cj->ci", K, y)
    I_K = np.eye(2) - K
    P = I_K @ P @ np.swapaxes(I_K, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    nis = np.einsum("ci,cij,cj->c", y, S_inv, y)
    return x, P, nis


# ---------------------------------------------------------------- the noise levels, estimated from the readings
@dataclass(frozen=True)
class NoiseLevels:
    """One kind of channel's levels: reading stds and the rate-step density (``q``, per second)."""

    value: float  # [m] or [rad] std of a reading's value
    rate: float  # [m/s] or [rad/s] std of a reading's rate
    q: float  # [m^2/s^3] or [rad^2/s^3] variance per second of the rate's steps


class NoiseEstimator:
    """Pooled residuals of consecutive readings of one kind of channel, and the levels they imply.

    Each residual enters as ``(kind, e^2, coefficients)`` with ``E[e^2] = coefficients . (s_v^2, s_r^2, q)``;
    the latest ``window`` of each kind are kept. A residual beyond ``outlier`` times its kind's median square is
    left out of the means (a teleport, not noise).
    """

    KINDS = ("consistency", "rate_change", "middle")

    def __init__(self, window: int, outlier: float, noise_floor: float) -> None:
        self.outlier = outlier
        self.noise_floor = noise_floor
        self._res: dict[str, deque[tuple[float, tuple[float, float, float]]]] = {
            k: deque(maxlen=window) for k in self.KINDS}

    def add(self, kind: str, residual: float, coefficients: tuple[float, float, float]) -> None:
        self._res[kind].append((residual * residual, coefficients))

    def noisy(self) -> bool:
        """Whether the readings are noisy: the consistency residual's median above the floor (``noise_floor``
        is a std, in the channel's unit)."""
        res = self._res["consistency"]
        if not res:
            return False
        median = float(np.median([e2 for e2, _ in res]))
        return median / CHI2_1_MEDIAN > self.noise_floor ** 2

    def _means(self, kinds: tuple[str, ...]) -> dict[str, tuple[float, np.ndarray]] | None:
        """Per kind of residual of ``kinds``: the mean square and the mean coefficients, outliers left out
        (``None``: one of them has no residual yet)."""
        out = {}
        for kind in kinds:
            res = self._res[kind]
            if not res:
                return None
            e2 = np.array([e for e, _ in res])
            keep = e2 <= self.outlier * max(float(np.median(e2)), 1e-300)
            out[kind] = (float(e2[keep].mean()), np.array([c for _, c in res])[keep].mean(axis=0))
        return out

    def levels(self, stds: tuple[float, float] | None = None, q: float | None = None) -> NoiseLevels | None:
        """The levels, or ``None`` while a residual they need has none yet.

        ``stds``: the readings' ``(value, rate)`` stds, known (the sensor's profile); then ``q`` (unless given)
        from the rate's change, what is left of it beyond the readings' noise. Without ``stds``, each std from
        the residual that isolates it best, ``q`` as given: the value's from the middle reading (its rate-step
        term, ``q dt h^2``, left out: small beside the reading's), the rate's from its change (its rate steps
        counted as noise: an upper bound, the filter then leans on the model).
        """
        if stds is None and q is None:
            raise ValueError("estimate the stds or q, not both: give one of them")
        means = self._means(("middle", "rate_change") if stds is None else () if q is not None else ("rate_change",))
        if means is None:
            return None
        if stds is None:
            e2, c = means["middle"]
            s_v2 = e2 / c[0]
            e2, c = means["rate_change"]
            s_r2 = max(e2 - c[2] * q, 0.0) / c[1]
        else:
            s_v2, s_r2 = stds[0] ** 2, stds[1] ** 2
            if q is None:
                e2, c = means["rate_change"]
                q = max(e2 - c[1] * s_r2, 0.0) / c[2]
        return NoiseLevels(math.sqrt(s_v2), math.sqrt(s_r2), q)


# ---------------------------------------------------------------- tracks
def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


@dataclass
class _Reading:
    time: float
    values: np.ndarray  # (K,) x, y (and the angle of a rod)
    rates: np.ndarray  # (K,)


@dataclass
class Track:
    """One obstacle's filter: channels ``x``, ``y`` (and a rod's ``angle``); ``state (K, 2)``, ``cov (K, 2, 2)``
    (``nan``: a channel not filtered yet, its readings taken as exact so far)."""

    time: float  # [s] of the last reading
    state: np.ndarray
    cov: np.ndarray
    readings: deque  # the last two readings, for the noise estimate
    # The second model of the position (x, y): a shape that stays where it is (a door's pivot, a member at rest).
    still: np.ndarray = dataclasses.field(default_factory=lambda: np.full(2, np.nan))  # [m] its position
    still_var: np.ndarray = dataclasses.field(default_factory=lambda: np.full(2, np.nan))  # [m^2]
    evidence: float = 0.0  # log-likelihood of the readings under "still" minus under "moving", forgetting old steps
    # Per channel, the variance of the last update's correction of the rate were the motion steady (the model's):
    # ``(P_pred S^-1 P_pred)[1, 1]``; 0 where the readings are taken as exact.
    rate_change_var: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))


def _reading(view: ObstacleView, time: float) -> _Reading:
    if view.kind == "segment":
        values = np.array([view.position[0], view.position[1], view.angle], dtype=float)
        rates = np.array([view.velocity[0], view.velocity[1], view.angular_velocity], dtype=float)
    else:
        values = np.array(view.position, dtype=float)
        rates = np.array(view.velocity, dtype=float)
    return _Reading(time, values, rates)


class Tracker:
    """Kalman filters of the sensed moving obstacles, kept across footsteps (see the module doc).

    ``update(snapshot)`` takes what was sensed now and returns the snapshot with each moving view replaced by its
    track's estimate (static views, the robot's state and a circle's angle as sensed). Call :meth:`reset` at an
    episode's start. Seeded by nothing: the same readings give the same estimates.
    """

    def __init__(self, params: TrackingParams) -> None:
        self.params = params
        self.tracks: dict[str, Track] = {}
        self.estimators = {
            LINEAR: NoiseEstimator(params.window, params.outlier, params.noise_floor_m),
            ANGULAR: NoiseEstimator(params.window, params.outlier, params.noise_floor_rad),
        }
        self.restarts = 0
        self._levels: dict[str, NoiseLevels | None] = {LINEAR: None, ANGULAR: None}
        #: Whether the last update found the readings noisy for the first time: the estimates handed on before
        #: were the raw readings, not comparable with the filtered ones from now on.
        self.revised = False

    def reset(self) -> None:
        """Forget every track and residual (a new episode)."""
        self.__init__(self.params)

    # ------------------------------------------------------------ noise
    def _observe_residuals(self, track: Track, reading: _Reading) -> None:
        previous = track.readings[-1]
        dt = reading.time - previous.time
        if not dt > 0:
            return
        for ch in range(len(reading.values)):
            est = self.estimators[ANGULAR if ch == 2 else LINEAR]
            change = reading.values[ch] - previous.values[ch]
            if ch == 2:
                change = _wrap(change)
            est.add("consistency", change - reading.rates[ch] * dt, (2.0, dt * dt, 0.0))
            est.add("rate_change", reading.rates[ch] - previous.rates[ch], (0.0, 2.0, dt))
            if len(track.readings) >= 2:
                first = track.readings[-2]
                dt0 = previous.time - first.time
                if dt0 > 0:
                    a = dt / (dt0 + dt)  # weight of the first reading in the line at the middle one's time
                    before, after = previous.values[ch] - first.values[ch], reading.values[ch] - previous.values[ch]
                    if ch == 2:
                        before, after = _wrap(before), _wrap(after)
                    middle = a * before - (1.0 - a) * after
                    h = dt0 * dt / (dt0 + dt)
                    est.add("middle", middle, (1.0 + a * a + (1.0 - a) ** 2, 0.0, dt * h * h))

    def levels(self) -> dict[str, NoiseLevels | None]:
        """The noise levels the filters use now, per kind of channel (``None``: readings taken as exact)."""
        out: dict[str, NoiseLevels | None] = {}
        known = self.params.measurement_noise
        for kind, est in self.estimators.items():
            stds = None if self.params.estimate_noise else (tuple(known[:2]) if kind == LINEAR else tuple(known[2:]))
            floor = self.params.process_noise_linear if kind == LINEAR else self.params.process_noise_angular
            if not est.noisy():
                out[kind] = None
            elif stds is not None and kind == LINEAR:  # the sensor known: a velocity's steps estimated (a crowd's)
                levels = est.levels(stds)
                out[kind] = None if levels is None else dataclasses.replace(levels, q=max(levels.q, floor))
            else:  # a rod turns steadily or not at all; or the readings' stds estimated: the model's steps
                out[kind] = est.levels(stds, q=floor)
        return out

    # ------------------------------------------------------------ the footstep
    def update(self, snapshot: Snapshot) -> Snapshot:
        """Fold in what ``snapshot`` senses; return it with the moving views replaced by the estimates."""
        readings: dict[str, _Reading] = {}
        for view in snapshot.obstacles:
            if view.static:
                continue
            reading = _reading(view, snapshot.time)
            readings[view.name] = reading
            track = self.tracks.get(view.name)
            if track is not None and len(track.state) == len(reading.values):
                self._observe_residuals(track, reading)
        levels = self.levels()
        self.revised = any(v is not None for v in levels.values()) and all(v is None for v in self._levels.values())
        self._levels = levels
        self._filter(readings, levels)
        if all(v is None for v in levels.values()):
            return snapshot  # every reading taken as exact: nothing to change
        sensed = [v.name for v in snapshot.obstacles if not v.static]
        shared = self._shared_velocity(sensed) if self.params.shared_velocity_gate > 0 else {}
        views = tuple(self._estimate(v, shared.get(v.name)) if not v.static else v for v in snapshot.obstacles)
        return dataclasses.replace(snapshot, obstacles=views)

    def _moving(self, name: str) -> bool:
        """Whether ``name``'s position is filtered and handed on by the moving model."""
        track = self.tracks[name]
        filtered = not np.isnan(track.cov[:2]).any()
        still = not np.isnan(track.still).any() and track.evidence + self.params.still_prior > 0.0
        return filtered and not still

    def _shared_velocity(self, names: list[str]) -> dict[str, np.ndarray]:
        """Per moving track, its ``(x, y)`` channels ``(2, 2)`` conditioned on the velocity its peers share: the
        tracks whose estimated velocity agrees with its own (normalised squared difference, 2 dof, below
        ``shared_velocity_gate``), as the cars of a lane do. Their precision-weighted mean velocity, the track's own
        left out, is a measurement of its velocity (each axis a Kalman update with ``H = [0, 1]``). The filters
        keep their own states: only what is handed on this footstep is conditioned."""
        moving = [n for n in names if self._moving(n)]
        if len(moving) < 2:
            return {}
        x = np.stack([self.tracks[n].state[:2] for n in moving])  # (M, 2 axes, [value, rate])
        P = np.stack([self.tracks[n].cov[:2] for n in moving])  # (M, 2 axes, 2, 2)
        v, var = x[:, :, 1], P[:, :, 1, 1]  # (M, 2)
        d2 = ((v[:, None] - v[None]) ** 2 / (var[:, None] + var[None])).sum(axis=-1)  # (M, M)
        peers = d2 < self.params.shared_velocity_gate
        np.fill_diagonal(peers, False)
        out: dict[str, np.ndarray] = {}
        for i, name in enumerate(moving):
            if not peers[i].any():
                continue
            w = 1.0 / var[peers[i]]  # (J, 2)
            mean, mean_var = (w * v[peers[i]]).sum(axis=0) / w.sum(axis=0), 1.0 / w.sum(axis=0)
            state = x[i].copy()
            for axis in range(2):
                Pa = P[i, axis]
                s = Pa[1, 1] + mean_var[axis]
                innovation = mean[axis] - state[axis, 1]
                state[axis] += Pa[:, 1] / s * innovation
            out[name] = state
        return out

    def _filter(self, readings: dict[str, _Reading], levels: dict[str, NoiseLevels | None]) -> None:
        rows: list[tuple[str, int, float]] = []  # (name, channel, dt) of the channels filtered this step
        for name, reading in readings.items():
            track = self.tracks.get(name)
            k = len(reading.values)
            if track is None or len(track.state) != k:  # first sight
                self.tracks[name] = Track(reading.time, np.stack([reading.values, reading.rates], 1),
                                          np.full((k, 2, 2), np.nan), deque([reading], maxlen=2))
                continue
            dt = max(reading.time - track.time, 0.0)
            for ch in range(k):
                if levels[ANGULAR if ch == 2 else LINEAR] is None:  # exact readings: the reading itself
                    track.state[ch] = (reading.values[ch], reading.rates[ch])
                    track.cov[ch] = np.nan
                    track.rate_change_var[ch] = 0.0
                else:
                    rows.append((name, ch, dt))
            track.readings.append(reading)
            track.time = reading.time
        if not rows:
            return
        n = len(rows)
        x, P = np.empty((n, 2)), np.empty((n, 2, 2))
        z, r, q = np.empty((n, 2)), np.empty((n, 2)), np.empty(n)
        dt = np.array([d for _, _, d in rows])
        angular = np.array([ch == 2 for _, ch, _ in rows])
        for i, (name, ch, _) in enumerate(rows):
            track, reading = self.tracks[name], readings[name]
            lv = levels[ANGULAR if ch == 2 else LINEAR]
            floor = self.params.noise_floor_rad if ch == 2 else self.params.noise_floor_m
            r[i] = (max(lv.value, floor) ** 2, max(lv.rate, floor) ** 2)
            z[i] = (reading.values[ch], reading.rates[ch])
            q[i] = lv.q
            x[i], P[i] = track.state[ch], track.cov[ch]
        # A channel filtered for the first time: its previous reading is the prior, as uncertain as a reading.
        fresh = np.isnan(P).any(axis=(1, 2))
        P[fresh] = 0.0
        P[fresh, 0, 0], P[fresh, 1, 1] = r[fresh, 0], r[fresh, 1]
        x_pred, P_pred = predict(x, P, dt, q)
        x_post, P_post, nis = update(x_pred, P_pred, z, r, angular)
        # Gate: a channel beyond it restarts its whole track at the reading (a shape re-entering the scene).
        restart = {name for (name, _, _), bad in zip(rows, nis > self.params.gate) if bad}
        S = P_pred.copy()  # the innovations' covariance
        S[:, 0, 0] += r[:, 0]
        S[:, 1, 1] += r[:, 1]
        # The correction K y of the rate has covariance K S K^T = P_pred S^-1 P_pred when the model holds.
        correction_var = (P_pred @ np.linalg.inv(S) @ P_pred)[:, 1, 1]
        self.restarts += len(restart)
        # Evidence for "still" over "moving" from the position channels: the still model's innovation of the
        # position and its reading of velocity (zero) against the moving model's innovation.
        log_moving = -0.5 * (nis + np.log(np.linalg.det(S)))
        memory = self.params.model_memory
        step_evidence: dict[str, float] = {}
        for i, (name, ch, _) in enumerate(rows):
            track = self.tracks[name]
            if name in restart:
                track.state[ch], track.cov[ch] = z[i], np.diag(r[i])
                track.rate_change_var[ch] = r[i, 1] + P_pred[i, 1, 1]  # the reading's rate against the old estimate
                if ch < 2:
                    track.still[ch], track.still_var[ch] = z[i, 0], r[i, 0]
                    step_evidence[name] = -math.inf  # no evidence yet: start over
                continue
            track.state[ch], track.cov[ch] = x_post[i], P_post[i]
            track.rate_change_var[ch] = correction_var[i]
            if ch < 2:
                if fresh[i]:
                    track.still[ch], track.still_var[ch] = x[i, 0], r[i, 0]
                s_var = track.still_var[ch] + r[i, 0]
                y = z[i, 0] - track.still[ch]
                gain = track.still_var[ch] / s_var
                track.still[ch] += gain * y
                track.still_var[ch] *= 1.0 - gain
                log_still = -0.5 * (y * y / s_var + math.log(s_var) + z[i, 1] ** 2 / r[i, 1] + math.log(r[i, 1]))
                step_evidence[name] = step_evidence.get(name, 0.0) + log_still - float(log_moving[i])
        for name, ev in step_evidence.items():
            track = self.tracks[name]
            track.evidence = 0.0 if ev == -math.inf else memory * track.evidence + ev

    def rate_change_stds(self) -> dict[str, tuple[float, float]]:
        """``{name: (speed std [m/s], turn std [rad/s])}``: per track, the std of the change of its estimated
        velocity (the norm over x and y) and of a rod's turn rate that the readings' noise alone makes at the last
        update, were the motion steady. 0 where the readings were taken as exact."""
        out = {}
        for name, track in self.tracks.items():
            v = track.rate_change_var
            out[name] = (math.sqrt(float(v[0] + v[1])), math.sqrt(float(v[2])) if len(track.state) == 3 else 0.0)
        return out

    def _estimate(self, view: ObstacleView, shared: np.ndarray | None = None) -> ObstacleView:
        track = self.tracks[view.name]
        s = track.state if shared is None else np.concatenate([shared, track.state[2:]])
        if view.kind == "segment":
            angle, omega = float(s[2, 0]), float(s[2, 1])
        else:
            angle, omega = view.angle, view.angular_velocity
        still = not np.isnan(track.still).any()  # the position is filtered (its readings are noisy)
        if still and track.evidence + self.params.still_prior > 0.0:  # the still model: it stands there
            position, velocity = (float(track.still[0]), float(track.still[1])), (0.0, 0.0)
        else:
            position, velocity = (float(s[0, 0]), float(s[1, 0])), (float(s[0, 1]), float(s[1, 1]))
        return ObstacleView(view.name, view.kind, False, position, angle, velocity, omega, view.radius, view.a, view.b)
