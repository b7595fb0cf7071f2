"""Classical crowd-navigation baselines, made to walk: an ORCA-driven robot and a dynamic-window planner.

Both read only the sensing snapshot (``env.sensing()``: poses and current velocities), never the future, and send
commands made feasible by the LIPM's check (:func:`~footstep_gym.planners.reactive.feasible_command`). Their values
are ``configs/baselines.yaml``'s (``orca-robot``, ``dwa``, and ``walk``'s margin).

* :class:`OrcaRobot` (``orca-robot``): the robot is an RVO2 agent (``pyrvo``, the library the crowd's ORCA
  pedestrians use) among the sensed obstacles: a circle is an agent at its sensed velocity, a moving rod a chain of
  discs at the rod's velocity at each disc, a static rod an RVO2 obstacle (its rectangle). Each footstep, one ORCA
  step of the walking period from the robot centre at its CoM velocity, the preferred velocity pointing at the goal
  at ``max_speed``, gives the robot's new velocity ``v``; it becomes a footstep: the direction of ``v`` is where
  the new foot turns (within the turn limits), the **period rule** is
  ``T = clip(stride_max / |v|, min_period, T_nominal)`` (the longest period up to the nominal one at which the
  stride stays within the box; never below the quickest constant walk), and the stride ``|v| T cos(angle off the
  heading)`` (a backward step when ORCA says back off).
* :class:`DynamicWindow` (``dwa``): Fox, Burgard and Thrun's dynamic window approach over the footstep command
  box: commands sampled on a grid (strides x turns x periods, the nominal side stride and double support), the
  window being the ones the LIPM can take from the present CoM state; each admissible one (its body, moving
  from the present centre to the new one during the step and then standing there for a nominal period, keeps
  clear of the constant-velocity obstacles) is scored one footstep ahead by ``heading x (1 - |angle to goal| /
  pi) + clearance x min(gap, cap) / cap + progress x (goal distance gained per second / the largest walk
  speed)``, and the best is taken (the largest gap when none is admissible).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.planners.reactive import SensingBaseline, goal_direction, steer
from footstep_gym.sensing import ObstacleView, Snapshot


def _world(view: ObstacleView, local: tuple[float, float]) -> np.ndarray:
    c, s = math.cos(view.angle), math.sin(view.angle)
    return np.array([view.position[0] + c * local[0] - s * local[1], view.position[1] + s * local[0] + c * local[1]])


def _velocity_at(view: ObstacleView, point: np.ndarray) -> tuple[float, float]:
    """The velocity [m/s] of the body's point ``point`` (its velocity plus omega x r)."""
    rx, ry = point[0] - view.position[0], point[1] - view.position[1]
    w = view.angular_velocity
    return (view.velocity[0] - w * ry, view.velocity[1] + w * rx)


def rod_discs(view: ObstacleView, spacing: float) -> list[tuple[np.ndarray, float, tuple[float, float]]]:
    """A rod as ``(centre, radius, velocity)`` discs: its centre line cut every ``spacing`` [m] at most, each disc
    as thick as the rod and reaching half a spacing beyond it (so the chain leaves no gap)."""
    a, b = _world(view, view.a), _world(view, view.b)
    n = max(2, int(math.ceil(np.linalg.norm(b - a) / spacing)) + 1)
    return [(p, view.radius + 0.5 * spacing, _velocity_at(view, p)) for p in np.linspace(a, b, n)]


def rod_polygon(view: ObstacleView) -> list[tuple[float, float]]:
    """A static rod's rectangle (its centre line grown by its half thickness), counter-clockwise, as RVO2 takes
    an obstacle."""
    a, b = _world(view, view.a), _world(view, view.b)
    d = b - a
    length = float(np.linalg.norm(d))
    u = d / length if length > 0 else np.array([1.0, 0.0])
    n = np.array([-u[1], u[0]]) * view.radius
    a, b = a - u * view.radius, b + u * view.radius
    return [tuple(a - n), tuple(b - n), tuple(b + n), tuple(a + n)]


class OrcaRobot(SensingBaseline):
    """The robot as an RVO2 agent among the sensed obstacles, its new velocity turned into a footstep (the module's
    docstring has the period rule)."""

    description = ("classical baseline: the robot as an ORCA (RVO2) agent among the sensed obstacles, its velocity "
                   "turned into a footstep, the period from its speed")
    config_section = "orca-robot"
    config_keys = ("max_speed", "min_period", "neighbor_dist", "max_neighbors", "time_horizon", "time_horizon_obst",
                   "safety_space", "disc_spacing")

    def orca_velocity(self, snapshot: Snapshot, period: float) -> tuple[float, float]:
        """The robot agent's velocity [m/s] after one ORCA step of ``period`` [s]."""
        from footstep_gym.scenarios.orca import require_pyrvo

        p = self.params
        sim = require_pyrvo().RVOSimulator(period, p["neighbor_dist"], int(p["max_neighbors"]), p["time_horizon"],
                                           p["time_horizon_obst"], self.robot.body_radius, p["max_speed"])
        centre = tuple(float(v) for v in snapshot.centre)
        sim.add_agent(centre, p["neighbor_dist"], int(p["max_neighbors"]), p["time_horizon"], p["time_horizon_obst"],
                      self.robot.body_radius + p["safety_space"], p["max_speed"],
                      tuple(float(v) for v in snapshot.com_vel))
        others = []
        for view in snapshot.obstacles:
            if view.kind == "circle":
                others.append((_world(view, view.a), view.radius, _velocity_at(view, _world(view, view.a))))
            elif view.static:
                sim.add_obstacle(rod_polygon(view))
            else:
                others += rod_discs(view, p["disc_spacing"])
        for centre_xy, radius, velocity in others:  # they see no one: their velocity is set, never computed
            k = sim.add_agent(tuple(float(v) for v in centre_xy), 0.0, 0, p["time_horizon"], p["time_horizon_obst"],
                              float(radius), 1.0e3, tuple(float(v) for v in velocity))
            sim.set_agent_pref_velocity(k, tuple(float(v) for v in velocity))
        sim.process_obstacles()
        direction, distance = goal_direction(snapshot)
        speed = min(p["max_speed"], distance / period)
        sim.set_agent_pref_velocity(0, (speed * math.cos(direction), speed * math.sin(direction)))
        sim.do_step()
        return sim.get_agent_velocity(0).to_tuple()

    def period_for(self, speed: float) -> float:
        """The period rule: ``clip(stride_max / speed, min_period, T_nominal)`` [s] (T_nominal at rest)."""
        t_nominal = self.robot.nominal_period
        if speed <= 1e-9:
            return t_nominal
        return float(np.clip(self.robot.stride_front[1] / speed, self.params["min_period"], t_nominal))

    def _command(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        vx, vy = self.orca_velocity(snapshot, self.robot.nominal_period)
        speed = math.hypot(vx, vy)
        period = self.period_for(speed)
        if speed <= 1e-9:
            return self.wait_command(snapshot), {"orca_velocity": (vx, vy), "period": period}
        direction = math.atan2(vy, vx)
        off = footstep.wrap_angle(direction - snapshot.heading)
        stride = speed * period * math.cos(off)
        return steer(snapshot, self.robot, stride, period, direction), {"orca_velocity": (vx, vy), "period": period}


class DynamicWindow(SensingBaseline):
    """Fox et al.'s dynamic window over the footstep command box, one footstep ahead (the module's docstring)."""

    description = ("classical baseline: a dynamic-window planner over the footstep command box (sampled commands "
                   "the LIPM can take, scored by heading, clearance and progress one footstep ahead, as Fox et "
                   "al.'s DWA)")
    config_section = "dwa"
    config_keys = ("strides", "turns", "periods", "samples", "clearance_cap", "heading_weight", "clearance_weight",
                   "progress_weight")

    def candidates(self, snapshot: Snapshot) -> np.ndarray:
        """The sampled commands ``(N, 5)``: strides x turns x periods, the nominal side stride and double support."""
        robot, p = self.robot, self.params
        lo, hi = footstep.turn_bounds(int(snapshot.support_side), robot)
        strides = np.linspace(robot.stride_front[0], robot.stride_front[1], int(p["strides"]))
        turns = np.linspace(lo, hi, int(p["turns"]))
        t_ds = robot.nominal_t_ds
        periods = [t for t in p["periods"] if robot.t_ss[0] <= t - t_ds <= robot.t_ss[1]]
        s, th, t = np.meshgrid(strides, turns, periods, indexing="ij")
        n = s.size
        return np.stack([s.ravel(), np.full(n, robot.nominal_side_stride), th.ravel(), t.ravel() - t_ds,
                         np.full(n, t_ds)], axis=1)

    def scores(self, snapshot: Snapshot, commands: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(score, gap)`` per command ``(N, 5)``: the weighted sum of the module's docstring and the smallest gap
        [m] between the body and the constant-velocity obstacles over the step and a nominal period after it."""
        robot, p = self.robot, self.params
        side = int(snapshot.support_side)
        x, y, yaw = footstep.place_foot(np.asarray(snapshot.support_foot, dtype=float), side, commands[:, 0],
                                        commands[:, 1], commands[:, 2])
        start = np.asarray(snapshot.centre, dtype=float)
        end = 0.5 * (np.stack([x, y], axis=1) + np.asarray(snapshot.support_foot[:2], dtype=float))
        period = commands[:, 3] + commands[:, 4]
        k = int(p["samples"])
        fractions = np.linspace(0.0, 1.0, k)
        gap = np.full(len(commands), np.inf)
        if snapshot.obstacles:
            # during the step (each command at its own instants), then standing at the new centre a nominal period
            for f in fractions:
                body = start + f * (end - start)
                for t in np.unique(f * period):
                    rows = np.isclose(f * period, t)
                    gap[rows] = np.minimum(gap[rows], snapshot.shapes_at(float(t)).clearance(body[rows]))
            for f in fractions[1:]:
                for t in np.unique(period + f * robot.nominal_period):
                    rows = np.isclose(period + f * robot.nominal_period, t)
                    gap[rows] = np.minimum(gap[rows], snapshot.shapes_at(float(t)).clearance(end[rows]))
        gap = gap - robot.body_radius
        gx, gy = snapshot.goal
        to_goal = np.arctan2(gy - end[:, 1], gx - end[:, 0])
        heading = 1.0 - np.abs(footstep.wrap_angle(to_goal - yaw)) / math.pi
        clearance = np.minimum(gap, p["clearance_cap"]) / p["clearance_cap"]
        d0 = math.hypot(gx - start[0], gy - start[1])
        d1 = np.hypot(gx - end[:, 0], gy - end[:, 1])
        v_max = robot.stride_front[1] / min(self.params["periods"])
        progress = (d0 - d1) / period / v_max
        score = (p["heading_weight"] * heading + p["clearance_weight"] * clearance + p["progress_weight"] * progress)
        return score, gap

    def _command(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        commands = self.candidates(snapshot)
        window = lipm.check_steps(self.robot, snapshot.com_local, snapshot.vel_local, commands,
                                  int(snapshot.support_side)).feasible
        commands = commands[window] if window.any() else commands
        score, gap = self.scores(snapshot, commands)
        admissible = gap > self.walk["margin"]
        if admissible.any():
            best = int(np.argmax(np.where(admissible, score, -np.inf)))
        else:
            best = int(np.argmax(gap))
        return commands[best].copy(), {"window": int(window.sum()), "admissible": int(admissible.sum()),
                                       "score": float(score[best]), "gap": float(gap[best])}


#: The classical baselines by name.
CLASSICAL_POLICIES: dict[str, type[SensingBaseline]] = {"orca-robot": OrcaRobot, "dwa": DynamicWindow}
