"""ORCA pedestrians through ``pyrvo`` (the RVO2 library): the crowd scene's ``crowd_model: orca``.

:class:`OrcaCrowd` holds one ``pyrvo.RVOSimulator`` with an agent per pedestrian (and, when the
robot is visible to them, one for the robot after them). The env holds one velocity per body per
footstep; :meth:`OrcaCrowd.advance` runs ORCA over a footstep of ``duration`` in
``ceil(duration / time_step)`` equal steps and returns each pedestrian's position at the
footstep's start and its chord velocity over the footstep, which the scenario gives the
pedestrian's pymunk body (as the scripted crowd does with the chord of its schedule).

Before every ORCA step each pedestrian's preferred velocity points at its goal:
``(goal - position)`` capped at its preferred speed (RVO2's examples and CrowdNav's ORCA, whose
cap is 1 m/s: a pedestrian slows down in its last ``speed x 1 s`` before the goal). One within its
radius of its goal takes a new goal, the point it started from, and walks back (CrowdNav++'s
``end_goal_changing`` regenerates a goal instead of stopping a pedestrian; walking back keeps the
layout's lanes without a random draw or a jump of the body). A pedestrian's ORCA max speed is its
preferred speed, so its chord is never faster (clamped to it against float32 rounding).

The robot, when visible, is an ORCA agent that sees no one (``max_neighbors`` 0): before every
ORCA step it is put on the robot's CoM chord over the footstep, at that chord's velocity, which
the pedestrians then avoid reciprocally (each assumes the other takes half), as CrowdNav's
humans do with a visible robot. Invisible: no robot agent.

RVO2 computes in float32 and deterministically: every agent's new velocity is computed from the
old ones before any agent moves, so the result does not depend on thread count (this wheel's
``libRVO`` is built without OpenMP anyway), and the same inputs give the same bits. The
simulator is rebuilt exactly from the agents' positions and velocities when pickled (RVO2 keeps
no other state between steps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

from footstep_gym.errors import ConfigError


def require_pyrvo() -> Any:
    """The ``pyrvo`` module, or a :class:`ConfigError` saying how to install it (the ``orca`` extra)."""
    try:
        import pyrvo
    except ImportError as exc:
        raise ConfigError('crowd_model="orca" needs pyrvo (the RVO2 library\'s bindings): '
                          'pip install "footstep_gym[orca]"') from exc
    return pyrvo

#: Where the robot's agent waits when :meth:`OrcaCrowd.advance` is given no robot: beyond anyone's sight [m].
_PARKED = (1.0e6, 1.0e6)


@dataclass(frozen=True)
class OrcaParams:
    """RVO2's parameters, shared by every pedestrian (the crowd YAML's ``orca_*`` keys)."""

    time_step: float  # [s] longest ORCA step; a footstep is cut into equal steps no longer than this
    neighbor_dist: float  # [m] centre to centre: others farther away are not considered
    max_neighbors: int  # the nearest this many others are considered
    time_horizon: float  # [s] velocities are chosen collision-free for this long (also used for obstacles: none)
    safety_space: float  # [m] added to every radius ORCA sees (not to the bodies the robot collides with)


def substeps(duration: float, time_step: float) -> int:
    """The number of equal ORCA steps, none longer than ``time_step``, over ``duration`` [s]."""
    return max(1, math.ceil(duration / time_step - 1e-9))  # 0.8 / 0.1 = 8.000000000000002: 8 steps


class OrcaCrowd:
    """``n`` ORCA pedestrians walking from ``starts`` towards ``goals`` (lists of ``(x, y)`` [m]), each with its
    own ``radii`` [m] and preferred ``speeds`` [m/s]; ``robot_radius`` [m]: the robot is an agent too (``None``: not).
    """

    def __init__(self, starts: Sequence[Sequence[float]], goals: Sequence[Sequence[float]],
                 radii: Sequence[float], speeds: Sequence[float], params: OrcaParams,
                 robot_radius: float | None = None) -> None:
        self.params = params
        self.radii = [float(r) for r in radii]
        self.speeds = [float(s) for s in speeds]
        self.origins = [(float(x), float(y)) for x, y in starts]  # where each walks back to from its goal
        self.goals = [(float(x), float(y)) for x, y in goals]
        self.robot_radius = None if robot_radius is None else float(robot_radius)
        n = len(self.radii)
        if not (len(self.origins) == len(self.goals) == len(self.speeds) == n):
            raise ValueError("OrcaCrowd: starts, goals, radii and speeds must have one entry per pedestrian")
        states = [(p, (0.0, 0.0)) for p in self.origins]
        if self.robot_radius is not None:
            states.append((_PARKED, (0.0, 0.0)))
        self._sim = self._build(states)
        self.positions = [self._sim.get_agent_position(i).to_tuple() for i in range(n)]  # ORCA's (float32) values

    def _build(self, states: list[tuple[tuple[float, float], tuple[float, float]]]) -> Any:
        """A simulator with the pedestrians (then the robot) at ``states`` ``[(position, velocity)]``."""
        p = self.params
        sim = require_pyrvo().RVOSimulator(p.time_step, p.neighbor_dist, p.max_neighbors, p.time_horizon, p.time_horizon,
                                 self.radii[0] if self.radii else 0.1, max(self.speeds, default=0.0))
        for i, (r, v_max) in enumerate(zip(self.radii, self.speeds)):
            position, velocity = states[i]
            sim.add_agent(position, p.neighbor_dist, p.max_neighbors, p.time_horizon, p.time_horizon,
                          r + p.safety_space, v_max, velocity)
        if self.robot_radius is not None:
            position, velocity = states[len(self.radii)]
            # Sees no one (its velocity is set, never computed); any speed it is given.
            sim.add_agent(position, 0.0, 0, p.time_horizon, p.time_horizon, self.robot_radius + p.safety_space,
                          1.0e3, velocity)
        return sim

    # ------------------------------------------------------------ pickling: rebuilt from the agents' state
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        sim = state.pop("_sim")
        state["_agents"] = [(sim.get_agent_position(i).to_tuple(), sim.get_agent_velocity(i).to_tuple())
                            for i in range(sim.get_num_agents())]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        agents = state.pop("_agents")
        self.__dict__.update(state)
        self._sim = self._build(agents)

    # ------------------------------------------------------------ one footstep
    def advance(self, duration: float, robot_position: tuple[float, float] | None = None,
                robot_velocity: tuple[float, float] = (0.0, 0.0)
                ) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
        """Run ORCA over the next ``duration`` [s]; the pedestrians' positions at its start [m] and chord velocities [m/s].

        ``robot_position`` [m] / ``robot_velocity`` [m/s]: the robot's CoM at the start and its chord velocity over
        the footstep (used only if the robot is an agent; ``None``: not seen during this footstep).
        """
        sim, n = self._sim, len(self.radii)
        start = self.positions
        k = substeps(duration, self.params.time_step)
        dt = duration / k
        sim.set_time_step(dt)
        robot = self.robot_radius is not None
        if robot and robot_position is None:
            sim.set_agent_position(n, _PARKED)
            sim.set_agent_velocity(n, (0.0, 0.0))
            sim.set_agent_pref_velocity(n, (0.0, 0.0))
            robot = False
        rx, ry = robot_position if robot else (0.0, 0.0)
        rvx, rvy = robot_velocity
        goals, origins, radii, speeds = self.goals, self.origins, self.radii, self.speeds
        set_pref, get_position, hypot = sim.set_agent_pref_velocity, sim.get_agent_position, math.hypot
        agents = range(n)
        positions = start
        for step in range(k):
            if robot:
                s = step * dt
                sim.set_agent_position(n, (rx + rvx * s, ry + rvy * s))
                sim.set_agent_velocity(n, (rvx, rvy))
                set_pref(n, (rvx, rvy))
            for i in agents:
                x, y = positions[i]
                gx, gy = goals[i]
                dx, dy = gx - x, gy - y
                d = hypot(dx, dy)
                if d < radii[i]:  # reached: walk back to where it came from
                    goals[i], origins[i] = origins[i], goals[i]
                    gx, gy = goals[i]
                    dx, dy = gx - x, gy - y
                    d = hypot(dx, dy)
                v = speeds[i]
                if d > v:
                    set_pref(i, (dx * (v / d), dy * (v / d)))
                else:
                    set_pref(i, (dx, dy))
            sim.do_step()
            positions = [get_position(i).to_tuple() for i in agents]
        self.positions = positions
        chords = []
        for (x0, y0), (x1, y1), v_max in zip(start, positions, speeds):
            vx, vy = (x1 - x0) / duration, (y1 - y0) / duration
            v = math.hypot(vx, vy)
            if v > v_max:  # float32 positions: a hair above the agent's max speed
                vx, vy = vx * (v_max / v), vy * (v_max / v)
            chords.append((vx, vy))
        return start, chords
