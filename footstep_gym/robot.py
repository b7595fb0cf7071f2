"""The robot's parameters (``configs/robot.yaml``) and the quantities derived from them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Mapping

import numpy as np

from footstep_gym import config
from footstep_gym.config import fraction, interval, nonnegative, positive
from footstep_gym.errors import ConfigError

#: Largest exponent whose exp is a finite float64 (with margin: ln(1.8e308) = 709.8).
_MAX_EXPONENT = 700.0

#: Order of the footstep command's fields (paper eq. 5).
COMMAND_FIELDS = ("S", "L", "theta", "t_ss", "t_ds")


@dataclass(frozen=True)
class Robot:
    """A DARwIn-OP-sized humanoid; every length in m, time in s, angle in rad.

    ``configs/robot.yaml`` holds the defaults; a *profile* (``configs/robots/<name>.yaml``, e.g.
    ``darwin-op``: the limits the paper's own footstep commands need) holds only the keys that
    differ from it (:func:`load_robot`, ``gym.make(..., robot="darwin-op")``).
    """

    #: Where the profiles are (``configs/robots/<name>.yaml``); not a field.
    PROFILE_FOLDER = "robots"

    gravity: float = positive(9.81)  # [m/s^2]
    com_height: float = positive(0.23)  # [m]
    foot_length: float = positive(0.104)  # [m]
    foot_width: float = positive(0.066)  # [m]
    zmp_region_scale: float = fraction(0.5)  # stable region / foot
    foot_clearance: float = nonnegative(0.002)  # [m]
    body_radius: float = positive(0.1)  # [m]
    stride_front: tuple[float, float] = interval((-0.04, 0.1))  # S [m]
    stride_side: tuple[float, float] = interval((0.07, 0.12))  # L [m]
    turn_inner: float = nonnegative(0.2)  # [rad]
    turn_outer: float = nonnegative(0.4)  # [rad]
    t_ss: tuple[float, float] = interval((0.1, 0.6))  # [s]
    t_ds: tuple[float, float] = interval((0.1, 0.3))  # [s]
    nominal_t_ss: float = positive(0.6)  # [s]
    nominal_t_ds: float = positive(0.2)  # [s]
    nominal_side_stride: float = positive(0.08)  # [m]
    generator_weight_position: float = positive(10.0)
    generator_weight_velocity: float = positive(1.0)
    swing_speed: float = positive(math.inf, allow_inf=True)  # [m/s] the swing foot's peak speed (.inf: no limit)
    swing_acceleration: float = positive(math.inf, allow_inf=True)  # [m/s^2] its peak acceleration (.inf: none)

    def validate(self) -> None:
        if self.stride_side[0] <= 0:
            raise ConfigError(f"robot.stride_side must be > 0 (feet never cross), got {self.stride_side}")
        if self.t_ss[0] <= 0 or self.t_ds[0] <= 0:
            raise ConfigError(f"robot.t_ss and robot.t_ds must be > 0, got {self.t_ss}, {self.t_ds}")
        for name, lo_hi, value in (
            ("nominal_t_ss", self.t_ss, self.nominal_t_ss),
            ("nominal_t_ds", self.t_ds, self.nominal_t_ds),
            ("nominal_side_stride", self.stride_side, self.nominal_side_stride),
        ):
            if not lo_hi[0] <= value <= lo_hi[1]:
                raise ConfigError(f"robot.{name}={value} lies outside its range {lo_hi}")
        # The LIPM's closed forms take e^{2 omega T} over the longest step: it must stay a finite float.
        longest = self.t_ss[1] + self.t_ds[1]
        if 2.0 * self.omega * longest > _MAX_EXPONENT:
            lowest = self.gravity * (2.0 * longest / _MAX_EXPONENT) ** 2
            raise ConfigError(f"robot.com_height={self.com_height} m is too low for the LIPM over the longest step "
                              f"(T_SS + T_DS = {longest:.3g} s): e^(2 omega T) overflows; it must be >= {lowest:.3g} m "
                              f"with gravity {self.gravity} m/s^2")

    @cached_property  # derived from frozen fields: computed once (the env reads these every step)
    def omega(self) -> float:
        """LIPM natural frequency sqrt(g / z_c) [1/s]."""
        return math.sqrt(self.gravity / self.com_height)

    @property
    def nominal_period(self) -> float:
        """T_n = nominal T_SS + T_DS [s]."""
        return self.nominal_t_ss + self.nominal_t_ds

    @cached_property
    def zmp_half_extent(self) -> tuple[float, float]:
        """Half sizes (x, y) of the stable ZMP rectangle around the foot centre [m]."""
        s = 0.5 * self.zmp_region_scale
        return (s * self.foot_length, s * self.foot_width)

    @cached_property
    def turn_limit(self) -> float:
        """Largest |theta| either foot may turn [rad] (the action box's bound)."""
        return max(self.turn_inner, self.turn_outer)

    @property
    def swing_limited(self) -> bool:
        """Whether ``swing_speed`` or ``swing_acceleration`` bounds T_SS from below by the stride
        (:func:`footstep_gym.footstep.swing_time_floor`)."""
        return math.isfinite(self.swing_speed) or math.isfinite(self.swing_acceleration)

    @property
    def command_low(self) -> np.ndarray:
        """Lower bounds of ``[S, L, theta, T_SS, T_DS]`` (the action box)."""
        return np.array(
            [self.stride_front[0], self.stride_side[0], -self.turn_limit, self.t_ss[0], self.t_ds[0]]
        )

    @property
    def command_high(self) -> np.ndarray:
        """Upper bounds of ``[S, L, theta, T_SS, T_DS]`` (the action box)."""
        return np.array(
            [self.stride_front[1], self.stride_side[1], self.turn_limit, self.t_ss[1], self.t_ds[1]]
        )

    @property
    def nominal_command(self) -> np.ndarray:
        """Stepping in place at the nominal period."""
        return np.array([0.0, self.nominal_side_stride, 0.0, self.nominal_t_ss, self.nominal_t_ds])


def load_robot(overrides: Mapping[str, Any] | str | None = None) -> Robot:
    """The robot of ``configs/robot.yaml`` with ``overrides`` applied.

    ``overrides``: keys of ``configs/robot.yaml``; or a profile's name (``"darwin-op"``); or
    both, ``{"profile": "darwin-op", "com_height": 0.25}`` (the profile over the base file, the
    other keys over the profile). Unknown profiles raise ``ConfigError`` naming the known ones.
    """
    return config.load(Robot, "robot.yaml", overrides)


def robot_profiles() -> list[str]:
    """The names of the robot profiles (``configs/robots/*.yaml``)."""
    return config.profile_names(Robot.PROFILE_FOLDER)
