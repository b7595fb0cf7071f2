"""``EnvConfig``: the settings the envs share (``configs/env.yaml``), below the env and the tiers that read them."""

from __future__ import annotations

import math
from dataclasses import dataclass

from footstep_gym import config
from footstep_gym.config import nonnegative, plain, positive
from footstep_gym.errors import ConfigError


@dataclass(frozen=True)
class EnvConfig:
    """Settings shared by the scene envs (``configs/env.yaml``, which documents each key)."""

    n_obstacles_observed: int = positive()
    sensing_range: float = positive()  # [m]
    observation_position_scale: float = positive()  # [m]
    observation_velocity_scale: float = positive()  # [m/s]
    observation_com_scale: float = positive()  # [m]
    collision_slop: float = positive()  # [m]
    max_check_interval: float = positive()  # [s]
    collision_motion_fraction: float = positive()
    compiled_sweep: bool = plain()  # the sweep's checks compiled (numba) or asked of pymunk one by one; same answers
    fixed_period: bool = plain()  # the action is [S, L, theta]; T_SS and T_DS are held at the robot's nominal ones
    max_sweep_checks: int = positive()  # collision checks per footstep at most (bounds a step's cost)
    reward_progress: float = plain()  # per m
    reward_time: float = plain()  # per s
    reward_step: float = plain()  # per footstep
    reward_goal: float = plain()
    reward_collision: float = plain()
    reward_fall: float = plain()
    render_pixels_per_metre: float = positive()
    render_size: tuple[float, float] = config.pair()  # [px] width, height
    video_fps: float = positive()  # [frames per simulated second] of render_mode="rgb_array_list"
    # What the robot senses of the moving obstacles (all off by default; docs/model.md, "What the robot senses").
    sensing_noise_position: float = nonnegative()  # [m] std of the noise on each axis of a moving body's position
    sensing_noise_velocity: float = nonnegative()  # [m/s] std of the noise on each axis of its velocity
    sensing_noise_angle: float = nonnegative()  # [rad] std of the noise on a moving rod's angle
    sensing_noise_angular_velocity: float = nonnegative()  # [rad/s] std of the noise on a moving rod's turn rate
    sensing_max_range: float = positive(allow_inf=True)  # [m] moving obstacles farther than this are not sensed
    sensing_fov: float = plain()  # [deg] full field of view centred on the support foot's yaw; 360: all around

    def validate(self) -> None:
        if not all(v >= 1 and float(v).is_integer() for v in self.render_size):
            raise ConfigError(f"env.yaml.render_size must be two whole numbers of pixels >= 1, got {self.render_size}")
        if not 0.0 < self.sensing_fov <= 360.0:
            raise ConfigError(f"env.yaml.sensing_fov must be in (0, 360] [deg] (360: all around), "
                              f"got {self.sensing_fov!r}")

    @property
    def sensing_noise(self) -> bool:
        """Whether any of the sensing noises is on."""
        return (self.sensing_noise_position > 0.0 or self.sensing_noise_velocity > 0.0
                or self.sensing_noise_angle > 0.0 or self.sensing_noise_angular_velocity > 0.0)

    @property
    def sensing_limited(self) -> bool:
        """Whether the robot senses anything other than the truth (noise, a range or a field of view)."""
        return self.sensing_noise or self.sensing_max_range < math.inf or self.sensing_fov < 360.0
