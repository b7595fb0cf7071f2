"""Stage 1: the walking period by binary search (paper Algorithm 1, Fig. 2).

Between a short period ``T0`` and the nominal ``T_n`` find the **longest** period ``T``
for which ``ObstacleCollision(T)`` is false. The collision predicate is an argument of
:func:`longest_free_period`, so the search is testable with hand-made predicates;
:class:`GoalRollouts` is the one the reference planner uses.

Algorithm 1 as printed tests ``ObstacleCollision(T1)`` at every pass and never moves
``T1`` back up once a free value is found, so it returns the first free value of the
sequence ``T_n, T_n/2, ...`` rather than the longest free period its text describes
("the walking period determined using the binary search is the longest walking
period for coping with dynamic obstacles"). :func:`longest_free_period` is the
bisection the text describes, assuming the predicate is monotone (a shorter period
never collides where a longer one does not):

* ``T_n`` free -> ``T_n`` (the robot keeps its nominal period);
* ``T0`` colliding -> ``T0`` (no period clears the way; walk as fast as allowed);
* else bisect with ``free(lo)``, ``collides(hi)`` for ``iterations`` passes and return
  ``lo``: the longest free period to within ``(T_n - T0) / 2**iterations``.

:class:`GoalRollouts` is the predicate: "can the robot, walking at period ``T``, keep
heading for the goal through the obstacles predicted from the snapshot over the
prediction horizon?" It rolls out a small library of goal-directed walks (a few lanes
beside the straight line to the goal, a few stride lengths up to the maximum, each
turning at most the hardware angle limits per step) and checks the body path of each
against the obstacles predicted at the time the robot would be there; the period
collides iff every rollout does. This is Fig. 2's test ("the predicted obstacle after
T lies in the selectable range of the next node") extended over the horizon, so that
a wing that will close the gap in three steps shortens the period now, not when it is
too late.

:func:`shortest_feasible_period` is ``T0`` made state-dependent: the shortest period
the robot *can use from its current CoM state* (the paper: "T0 is determined to be a
short walking period that the robot can use"). Cutting ``T_SS`` from 0.6 s to 0.1 s in
one step is infeasible for the LIPM (DESIGN §3) and the PSO's ``ΔT_SS <= 0`` can only
make it worse, so the search starts from the shortest period one step can reach.
:func:`stride_window` is the same idea for the stride: at a short period the CoM's
momentum forbids stopping (or lengthening the stride) in one step, so the first step
of the rollouts and of the RRT keeps to the front strides the LIPM accepts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.footstep import LEFT, RIGHT
from footstep_gym.planners.prediction import BodyModel, body_path_points, support_normal
from footstep_gym.robot import Robot


@dataclass(frozen=True)
class PeriodSearchResult:
    """What the binary search found: ``period`` [s] and how it got there."""

    period: float  # [s] the longest collision-free period (T0 if none, T_n if T_n is free)
    nominal_free: bool  # ObstacleCollision(T_n) was false
    any_free: bool  # some period in [T0, T_n] was free
    evaluations: int  # calls of the predicate


def longest_free_period(collides: Callable[[float], bool], t_short: float, t_nominal: float,
                        iterations: int) -> PeriodSearchResult:
    """Algorithm 1: the longest ``T`` in ``[t_short, t_nominal]`` with ``collides(T)`` false.

    ``iterations`` is ``N``; the answer is within ``(t_nominal - t_short) / 2**N`` of the
    boundary, on its free side.
    """
    if t_short > t_nominal:
        raise ValueError(f"t_short={t_short} must not exceed t_nominal={t_nominal}")
    if not collides(t_nominal):
        return PeriodSearchResult(t_nominal, True, True, 1)
    if collides(t_short):
        return PeriodSearchResult(t_short, False, False, 2)
    lo, hi = t_short, t_nominal
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        if collides(mid):
            hi = mid
        else:
            lo = mid
    return PeriodSearchResult(lo, False, True, 2 + iterations)


@dataclass(frozen=True)
class WalkStart:
    """Where a walk (a rollout or the RRT) starts, in the paper's node convention.

    ``node``: the support foot's node (the point ``half_width`` inside the support foot,
    perpendicular to its yaw, i.e. the inverse of :func:`footstep.foot_from_node`);
    ``heading``: the support foot's yaw; ``side``: the support side (+1 left, -1 right);
    ``body``: where the body (CoM ground projection) is now; ``previous_node``: the swing
    foot's node.
    """

    node: np.ndarray  # (2,) [m]
    heading: float  # [rad]
    side: int
    body: np.ndarray  # (2,) [m]
    previous_node: np.ndarray  # (2,) [m]


def node_of_foot(foot_pose: Sequence[float], side: int, half_width: float) -> np.ndarray:
    """The node a foot stands for: inverse of :func:`footstep.foot_from_node`."""
    x, y, yaw = foot_pose
    return np.array([x + side * half_width * np.sin(yaw), y - side * half_width * np.cos(yaw)])


def walk_start(snapshot, half_width: float) -> WalkStart:
    """The :class:`WalkStart` of a :class:`~footstep_gym.sensing.Snapshot`."""
    side = int(snapshot.support_side)
    return WalkStart(
        node=node_of_foot(snapshot.support_foot, side, half_width),
        heading=float(snapshot.support_foot[2]),
        side=side,
        body=np.asarray(snapshot.com, dtype=float),
        previous_node=node_of_foot(snapshot.swing_foot, -side, half_width),
    )


class GoalRollouts:
    """``ObstacleCollision(T)``: every goal-directed rollout at period ``T`` collides within the horizon.

    The rollouts are a small library of walks towards the goal: rollout ``(k, j)`` follows
    the *lane* parallel to the line from the start node to the goal, offset sideways by
    ``lane_offsets[k]`` [m] (pure pursuit of the lane point ``lookahead`` ahead; the lane
    closes onto the goal over the last ``lookahead``), with a stride of
    ``stride_fractions[j] * step_size`` [m] after ``wait_steps[w]`` steps in place (so that
    "let the wing pass, then go" is in the library), the first stride clipped into
    ``first_stride(T)`` (what the LIPM allows from the current CoM state at that period). Every step turns
    at most the side-dependent hardware limits. The body follows the midpoints of
    consecutive nodes (the robot centre between its feet), so step ``d`` moves it from
    ``(n[d-2] + n[d-1]) / 2`` to ``(n[d-1] + n[d]) / 2`` during ``[(d - 1) T, d T]``; each
    such segment is checked at ``edge_samples`` points by ``body.free`` (a
    :class:`~footstep_gym.planners.prediction.BodyModel`: the obstacles predicted at those
    times, the CoM's sway towards the support foot). A rollout that reaches the goal
    stops there.
    Rollouts span ``ceil(horizon / T)`` steps, but no more than the slowest of them needs
    to reach the goal (so a long horizon costs nothing once the goal is within it).

    :meth:`free_walks` gives the free rollouts of a period already evaluated (the
    evidence that the period works; the planner seeds its RRT with them).

    ``committed``: the walk ``(nodes (k + 1, 2), headings (k + 1,))`` the planner chose at
    its previous step, now starting at the current node. It joins the library (re-timed
    at every period tried), and :meth:`committed_free` tells whether it still holds at
    its own period, checked with ``committed_body`` (the margin it was chosen under; default
    ``body``): a greedy planner that re-plans from scratch every step can otherwise
    put off forever a plan that starts with "wait three steps" (it is again "wait three
    steps" one step later).
    """

    def __init__(self, body: BodyModel, robot: Robot, start: WalkStart,
                 goal: Sequence[float], goal_radius: float, *, horizon: float, step_size: float,
                 lane_offsets: Sequence[float], stride_fractions: Sequence[float], lookahead: float,
                 edge_samples: int, wait_steps: Sequence[int] = (0,),
                 first_stride: Callable[[float], tuple[float, float] | None] | None = None,
                 committed: tuple[np.ndarray, np.ndarray] | None = None,
                 committed_body: BodyModel | None = None) -> None:
        self.body = body
        self.robot = robot
        self.start = start
        self.goal = np.asarray(goal, dtype=float)
        self.goal_radius = goal_radius
        self.horizon = horizon
        self.lookahead = lookahead
        self.edge_samples = edge_samples
        self.first_stride = first_stride
        off, frac, wait = np.meshgrid(np.asarray(lane_offsets, float), np.asarray(stride_fractions, float),
                                      np.asarray(wait_steps, dtype=int), indexing="ij")
        self._offsets = off.ravel()
        self._strides = frac.ravel() * step_size
        self._waits = wait.ravel()
        axis = self.goal - start.node
        self._length = float(np.linalg.norm(axis))
        # Steps the slowest rollout needs to reach the goal (with some slack for the lanes'
        # detours): deeper rollouts would only re-check a robot already standing at the goal.
        self._max_depth = int(np.ceil(self._length / float(self._strides.min()) * 1.2)) + int(self._waits.max()) + 2
        self._dir = axis / self._length if self._length > 0 else np.array([np.cos(start.heading),
                                                                           np.sin(start.heading)])
        self.committed = committed
        self.committed_body = committed_body if committed_body is not None else body
        self._walk_cache: dict[tuple[float, float] | None, tuple[np.ndarray, np.ndarray]] = {}
        self.calls = 0
        self._free_walks: dict[float, list[np.ndarray]] = {}

    def nodes(self, period: float) -> tuple[np.ndarray, np.ndarray]:
        """Rollout nodes ``(R, D + 1, 2)`` and headings ``(R, D + 1)`` (index 0: the start) for ``period`` [s]."""
        depth = max(1, min(int(np.ceil(self.horizon / period - 1e-9)), self._max_depth))
        window = self.first_stride(period) if self.first_stride is not None else None
        if window not in self._walk_cache:  # the walks depend on the period only through the first stride
            self._walk_cache[window] = self._pursue(window, self._max_depth)
        nodes, headings = self._walk_cache[window]
        return nodes[:, : depth + 1], headings[:, : depth + 1]

    def _pursue(self, window: tuple[float, float] | None, depth: int) -> tuple[np.ndarray, np.ndarray]:
        """Pure pursuit of every rollout's lane for ``depth`` steps (2D points as complex numbers)."""
        n_roll = self._offsets.size
        node0 = complex(*self.start.node)
        axis = complex(*self._dir)
        goal = complex(*self.goal)
        lane = self._offsets * (1j * axis)
        limits = {side: footstep.turn_bounds(side, self.robot) for side in (LEFT, RIGHT)}
        pos = np.full(n_roll, node0)
        heading = np.full(n_roll, float(self.start.heading))
        out = np.empty((n_roll, depth + 1), dtype=complex)
        headings = np.empty((n_roll, depth + 1))
        out[:, 0], headings[:, 0] = pos, heading
        side = self.start.side
        for d in range(1, depth + 1):
            # Aim at the lane point ``lookahead`` ahead; the lane closes onto the goal over the last lookahead.
            ahead = ((pos - node0) * axis.conjugate()).real + self.lookahead
            taper = np.clip((self._length - ahead) / self.lookahead, 0.0, 1.0)
            aim = node0 + np.minimum(ahead, self._length) * axis + taper * lane
            lo, hi = limits[side]
            heading = heading + np.clip(np.angle((aim - pos) * np.exp(-1j * heading)), lo, hi)
            stride = np.where(d <= self._waits, 0.0, self._strides)
            if d == 1 and window is not None:
                stride = np.clip(stride, *window)
            dist = np.abs(goal - pos)
            stride = np.where(dist <= self.goal_radius, 0.0, np.minimum(stride, dist))
            pos = pos + stride * np.exp(1j * heading)
            out[:, d], headings[:, d] = pos, heading
            side = -side
        return np.stack([out.real, out.imag], axis=-1), headings

    def _with_committed(self, nodes: np.ndarray, headings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rollouts plus the committed walk, padded (standing at its end) or cut to the same depth."""
        walk, walk_headings = self.committed
        n_nodes = nodes.shape[1]
        idx = np.minimum(np.arange(n_nodes), len(walk) - 1)
        return (np.concatenate([nodes, walk[idx][None]], axis=0),
                np.concatenate([headings, walk_headings[idx][None]], axis=0))

    def committed_free(self, period: float) -> bool:
        """Whether the committed walk alone is still free at ``period`` (``False`` without one)."""
        if self.committed is None or len(self.committed[0]) < 2:
            return False
        walk, headings = self.committed
        return bool(self._free(walk[None], headings[None], period, self.committed_body)[0])

    def __call__(self, period: float) -> bool:
        self.calls += 1
        nodes, headings = self.nodes(period)
        ok = self._free(nodes, headings, period)
        if self.committed is not None:
            nodes, headings = self._with_committed(nodes, headings)
            ok = np.append(ok, self._free(nodes[-1:], headings[-1:], period, self.committed_body))
        walks = [self._trim(nodes[i]) for i in np.flatnonzero(ok)]
        # Nearest the goal at the end first, then the quickest there; the committed walk (last row) leads if free.
        order = sorted(range(len(walks)), key=lambda i: (round(float(np.linalg.norm(walks[i][-1] - self.goal)), 3),
                                                         len(walks[i])))
        if self.committed is not None and ok[-1]:
            order.remove(len(walks) - 1)
            order.insert(0, len(walks) - 1)
        self._free_walks[period] = [walks[i] for i in order]
        return not bool(ok.any())

    def _free(self, nodes: np.ndarray, headings: np.ndarray, period: float,
              body: BodyModel | None = None) -> np.ndarray:
        """``(R,)`` bool: walk ``r`` (nodes ``(R, D + 1, 2)``, step ``d`` during ``[(d-1) T, d T]``) stays free."""
        body = self.body if body is None else body
        n_roll, n_nodes, _ = nodes.shape
        prev = np.concatenate([np.tile(self.start.previous_node, (n_roll, 1, 1)), nodes[:, :-1]], axis=1)
        bodies = 0.5 * (prev + nodes)  # body at the end of step d = midpoint(n[d-1], n[d])
        bodies[:, 0] = self.start.body
        starts = bodies[:, :-1].reshape(-1, 2)
        ends = bodies[:, 1:].reshape(-1, 2)
        d = np.tile(np.arange(n_nodes - 1, dtype=float), n_roll)
        pts, times = body_path_points(starts, ends, d * period, (d + 1) * period, self.edge_samples)
        sides = self.start.side * np.where(np.arange(n_nodes - 1) % 2 == 0, 1.0, -1.0)
        normals = support_normal(headings[:, :-1], sides[None, :]).reshape(-1, 2)
        normals = np.repeat(normals, self.edge_samples, axis=0)
        free = body.free(pts, times, normals, period).reshape(n_roll, -1)
        # Once a rollout has reached the goal the episode is over: do not check it further.
        reached = np.linalg.norm(nodes[:, 1:] - self.goal, axis=-1) <= self.goal_radius
        done_before = np.concatenate([np.zeros((n_roll, 1), bool), np.cumsum(reached, axis=1)[:, :-1] > 0], axis=1)
        return (free | np.repeat(done_before, self.edge_samples, axis=1)).all(axis=1)

    def free_walks(self, period: float, limit: int | None = None) -> list[np.ndarray]:
        """Free walks ``(k + 1, 2)`` at ``period``: the committed one if free, then those ending nearest the goal."""
        walks = self._free_walks.get(period)
        if walks is None:
            self(period)
            walks = self._free_walks[period]
        return walks[:limit] if limit is not None else walks

    def _trim(self, nodes: np.ndarray) -> np.ndarray:
        """A rollout's nodes up to (and including) the first one in the goal region."""
        inside = np.flatnonzero(np.linalg.norm(nodes[1:] - self.goal, axis=1) <= self.goal_radius)
        return nodes[: inside[0] + 2] if inside.size else nodes


def shortest_feasible_period(robot: Robot, com_local: Sequence[float], vel_local: Sequence[float],
                             support_side: int, strides: Sequence[float], t_short: float,
                             t_nominal: float, grid: int) -> float:
    """The shortest period in ``[t_short, t_nominal]`` (on a ``grid``) reachable in one step.

    Tries ``[S, nominal L, 0, T - nominal T_DS, nominal T_DS]`` for each ``S`` in ``strides``
    with one batched :func:`lipm.check_steps`; returns the shortest ``T`` feasible for all
    of them, or ``t_short`` if no grid period is (then the PSO has to sort it out).
    """
    periods = np.linspace(t_short, t_nominal, grid)
    t_ds = robot.nominal_t_ds
    s = np.asarray(strides, dtype=float)
    cmd = np.empty((s.size, grid, 5))
    cmd[..., 0] = s[:, None]
    cmd[..., 1] = robot.nominal_side_stride
    cmd[..., 2] = 0.0
    cmd[..., 3] = periods[None, :] - t_ds
    cmd[..., 4] = t_ds
    ok = lipm.check_steps(robot, com_local, vel_local, cmd.reshape(-1, 5), support_side).feasible
    ok = ok.reshape(s.size, grid).all(axis=0)
    if not ok.any():
        return float(t_short)
    return float(periods[np.argmax(ok)])


def stride_window(robot: Robot, com_local: Sequence[float], vel_local: Sequence[float], support_side: int,
                  period: float, max_stride: float, grid: int) -> tuple[float, float] | None:
    """``(lo, hi)`` of the front strides ``S`` in ``[0, max_stride]`` feasible now at ``period``.

    Tries ``[S, nominal L, 0, period - nominal T_DS, nominal T_DS]`` on a ``grid`` of ``S``
    with one batched :func:`lipm.check_steps`. ``None`` when none is feasible (the PSO has
    to sort it out).
    """
    strides = np.linspace(0.0, max_stride, grid)
    t_ds = robot.nominal_t_ds
    cmd = np.empty((grid, 5))
    cmd[:, 0] = strides
    cmd[:, 1] = robot.nominal_side_stride
    cmd[:, 2] = 0.0
    cmd[:, 3] = max(period - t_ds, robot.t_ss[0])
    cmd[:, 4] = t_ds
    ok = lipm.check_steps(robot, com_local, vel_local, cmd, support_side).feasible
    if not ok.any():
        return None
    idx = np.flatnonzero(ok)
    return float(strides[idx[0]]), float(strides[idx[-1]])
