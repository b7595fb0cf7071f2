"""Reactive baselines: policies that sense but do not plan, a higher bar than the blind null baselines.

They read only the sensing snapshot (``env.sensing()``): the obstacles' poses and *current* velocities,
extrapolated at constant velocity (:meth:`~footstep_gym.sensing.Snapshot.shapes_at`), never the future. Both walk
straight at the goal with one command, ``configs/baselines.yaml``'s ``walk`` stride at its period (the nominal
one), turning the new foot towards the goal within the turn limits, and step in place when the rule says wait:

* :class:`WaitUntilClear` (``wait-until-clear``): waits while any *moving* obstacle, extrapolated over the next
  ``horizon_steps`` footsteps, would come within the body radius plus ``margin`` of the stretch of the straight
  path those footsteps walk (whenever it passes: the path must be clear, not just the robot's place on it);
* :class:`StraightStop` (``straight-stop``): a constant-velocity straight walker that stops for predicted contact:
  it steps in place only when walking on would bring its body within the body radius plus ``margin`` of any
  obstacle (moving or not) at the same instant, over the next ``horizon_steps`` footsteps.

Every command is made feasible first (:func:`feasible_command`: the LIPM's check from the snapshot's CoM state), as
every planner's is. :class:`SensingBaseline` is their shared base, and the classical baselines'
(:mod:`footstep_gym.planners.classical`).
"""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache
from typing import Any, Mapping

import numpy as np

from footstep_gym import footstep, lipm
from footstep_gym.errors import ConfigError
from footstep_gym.policy import SeededPolicy
from footstep_gym.robot import Robot
from footstep_gym.sensing import Snapshot

#: The config file of the baselines (relative to configs/).
CONFIG_FILE = "baselines.yaml"
#: Fractions of the stride tried, in order, when a command is infeasible (then the same at the nominal period).
FALLBACK_STRIDES = (1.0, 0.75, 0.5, 0.25, 0.0)


@lru_cache(maxsize=1)
def baseline_config() -> dict[str, dict[str, Any]]:
    """``configs/baselines.yaml``: a section per baseline (and ``walk``), every value a finite number > 0 or a list
    of them (checked; a bad value is a :class:`ConfigError` naming it)."""
    from footstep_gym.config import read_yaml

    data = read_yaml(CONFIG_FILE)
    if not isinstance(data, dict):
        raise ConfigError(f"{CONFIG_FILE}: expected a mapping of sections")
    for section, values in data.items():
        if not isinstance(values, dict):
            raise ConfigError(f"{CONFIG_FILE}: {section} must be a mapping of keys")
        for key, value in values.items():
            items = value if isinstance(value, list) else [value]
            if not items or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                                    and v > 0 for v in items):
                raise ConfigError(f"{CONFIG_FILE}: {section}.{key} must be a finite number > 0 (or a list of "
                                  f"them), got {value!r}")
    return data


def section(name: str, keys: tuple[str, ...]) -> dict[str, Any]:
    """The ``name`` section of :func:`baseline_config`, which must hold exactly ``keys``."""
    values = baseline_config().get(name)
    if not isinstance(values, dict) or set(values) != set(keys):
        raise ConfigError(f"{CONFIG_FILE}: section {name} must have the keys {', '.join(keys)}; got "
                          f"{', '.join(values) if isinstance(values, dict) else values!r}")
    return dict(values)


WALK_KEYS = ("stride", "period", "margin")


# ---------------------------------------------------------------- commands
def goal_direction(snapshot: Snapshot) -> tuple[float, float]:
    """``(angle [rad], distance [m])`` from the robot centre to the goal."""
    cx, cy = snapshot.centre
    gx, gy = snapshot.goal
    return math.atan2(gy - cy, gx - cx), math.hypot(gx - cx, gy - cy)


def steer(snapshot: Snapshot, robot: Robot, stride: float, period: float, direction: float) -> np.ndarray:
    """The command walking ``stride`` [m] at ``period`` [s] (T_DS nominal) with the new foot turned towards
    ``direction`` [rad] as far as the turn limits allow, the nominal side stride."""
    lo, hi = footstep.turn_bounds(int(snapshot.support_side), robot)
    theta = float(np.clip(footstep.wrap_angle(direction - snapshot.heading), lo, hi))
    t_ds = robot.nominal_t_ds
    s = float(np.clip(stride, robot.stride_front[0], robot.stride_front[1]))
    t_ss = float(np.clip(period - t_ds, robot.t_ss[0], robot.t_ss[1]))
    return np.array([s, robot.nominal_side_stride, theta, t_ss, t_ds])


def feasible_command(snapshot: Snapshot, robot: Robot, command: np.ndarray) -> tuple[np.ndarray, bool]:
    """``(command, changed)``: ``command`` if the LIPM can take it from the snapshot's CoM state (ZMP and kinematic
    limits, :func:`footstep_gym.lipm.check_steps`), else the first feasible of its stride scaled by
    :data:`FALLBACK_STRIDES`, then those at the nominal period; stepping in place at the nominal period if none."""
    tries = []
    for t_ss, t_ds in ((command[3], command[4]), (robot.nominal_t_ss, robot.nominal_t_ds)):
        for f in FALLBACK_STRIDES:
            tries.append([command[0] * f, command[1], command[2], t_ss, t_ds])
    batch = np.array(tries)
    ok = lipm.check_steps(robot, snapshot.com_local, snapshot.vel_local, batch, int(snapshot.support_side)).feasible
    if ok[0]:
        return command, False
    if ok.any():
        return batch[int(np.argmax(ok))], True
    return robot.nominal_command.copy(), True


def moving_only(snapshot: Snapshot) -> Snapshot:
    """The snapshot with its static obstacles left out."""
    return dataclasses.replace(snapshot, obstacles=tuple(o for o in snapshot.obstacles if not o.static))


def min_clearance(snapshot: Snapshot, points: np.ndarray, times: np.ndarray) -> float:
    """The smallest gap [m] between ``points[k]`` ``(K, P, 2)`` and the obstacles extrapolated ``times[k]`` [s]
    ahead at constant velocity (``inf`` without obstacles)."""
    if not snapshot.obstacles:
        return math.inf
    return float(min(snapshot.shapes_at(float(t)).clearance(p).min() for t, p in zip(times, points)))


# ---------------------------------------------------------------- the policies
class SensingBaseline(SeededPolicy):
    """Shared by the reactive and classical baselines: the registry's constructor ``(robot, config, seed, name)``
    (``config``, the planners' :class:`~footstep_gym.planners.PlannerConfig`, is accepted and unused: their values
    are ``configs/baselines.yaml``'s), the ``walk`` section, and ``act`` = :meth:`_command` made feasible, with
    ``last_info`` saying what it decided."""

    description = ""
    #: The config section of the baseline's own values (None: only ``walk``), and its keys.
    config_section: str | None = None
    config_keys: tuple[str, ...] = ()

    def __init__(self, robot: Robot, config: Any = None, seed: int | None = None, name: str | None = None) -> None:
        super().__init__(robot, seed, name)
        self.walk = section("walk", WALK_KEYS)
        self.params: Mapping[str, Any] = section(self.config_section, self.config_keys) if self.config_section else {}

    def act(self, observation: Any, snapshot: Snapshot | None) -> np.ndarray:
        if snapshot is None:
            raise ValueError(f"{self.name or type(self).__name__} reads the sensing snapshot: act(observation, "
                             "env.unwrapped.sensing())")
        wanted, info = self._command(snapshot)
        command, changed = feasible_command(snapshot, self.robot, wanted)
        self.last_info = {"policy": self.name, "command": command, "made_feasible": changed, **info}
        return command

    def _command(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        raise NotImplementedError

    def walk_command(self, snapshot: Snapshot) -> np.ndarray:
        """The straight walk's command: the ``walk`` stride (no longer than the goal is far) at its period,
        turned towards the goal."""
        direction, distance = goal_direction(snapshot)
        return steer(snapshot, self.robot, min(self.walk["stride"], distance), self.walk["period"], direction)

    def wait_command(self, snapshot: Snapshot) -> np.ndarray:
        """Stepping in place at the nominal period, turned towards the goal."""
        direction, _ = goal_direction(snapshot)
        return steer(snapshot, self.robot, 0.0, self.robot.nominal_period, direction)

    def reach(self) -> float:
        """The body radius plus the ``walk`` margin [m]: closer than this is (predicted) contact."""
        return self.robot.body_radius + self.walk["margin"]


class WaitUntilClear(SensingBaseline):
    """Steps in place while a moving obstacle would cross the next ``horizon_steps`` footsteps' stretch of the
    straight path; then walks straight at the goal at the ``walk`` stride and period."""

    description = ("reactive baseline: steps in place while a sensed moving obstacle, extrapolated at constant "
                   "velocity, would cross its straight path within the next footsteps; then walks at the nominal "
                   "period")
    config_section = "wait-until-clear"
    config_keys = ("horizon_steps", "path_spacing")

    def _command(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        direction, distance = goal_direction(snapshot)
        k, period = int(self.params["horizon_steps"]), self.walk["period"]
        length = min(k * self.walk["stride"], distance)
        n = max(2, int(math.ceil(length / self.params["path_spacing"])) + 1)
        along = np.linspace(0.0, length, n)
        path = np.asarray(snapshot.centre) + along[:, None] * np.array([math.cos(direction), math.sin(direction)])
        times = np.linspace(0.0, k * period, 2 * k + 1)
        gap = min_clearance(moving_only(snapshot), np.broadcast_to(path, (len(times), *path.shape)), times)
        blocked = gap < self.reach()
        return (self.wait_command(snapshot) if blocked else self.walk_command(snapshot)), \
            {"waiting": bool(blocked), "path_clearance": gap}


class StraightStop(SensingBaseline):
    """Walks straight at the goal at constant velocity (the ``walk`` stride and period) and steps in place while
    walking on would bring the body into contact with an obstacle, extrapolated at constant velocity, at the same
    instant within the next ``horizon_steps`` footsteps."""

    description = ("reactive baseline: a constant-velocity straight walker that steps in place while walking on "
                   "would bring it into contact with a sensed obstacle (constant-velocity prediction) within the "
                   "next footsteps")
    config_section = "straight-stop"
    config_keys = ("horizon_steps",)

    def _command(self, snapshot: Snapshot) -> tuple[np.ndarray, dict[str, Any]]:
        direction, distance = goal_direction(snapshot)
        k, period, stride = int(self.params["horizon_steps"]), self.walk["period"], self.walk["stride"]
        times = np.linspace(0.0, k * period, 4 * k + 1)
        travelled = np.minimum(times / period * stride, distance)
        body = np.asarray(snapshot.centre) + travelled[:, None] * np.array([math.cos(direction), math.sin(direction)])
        gap = min_clearance(snapshot, body[:, None, :], times)
        contact = gap < self.reach()
        return (self.wait_command(snapshot) if contact else self.walk_command(snapshot)), \
            {"waiting": bool(contact), "predicted_clearance": gap}


#: The reactive baselines by name (the lower anchor of the board's normalised score).
REACTIVE_POLICIES: dict[str, type[SensingBaseline]] = {"wait-until-clear": WaitUntilClear,
                                                        "straight-stop": StraightStop}
