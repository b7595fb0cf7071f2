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

    n_obstacles_observed: int = positive(6)
    sensing_range: float = positive(3.0)  # [m]
    observation_position_scale: float = positive(2.0)  # [m]
    observation_velocity_scale: float = positive(0.5)  # [m/s]
    observation_com_scale: float = positive(0.1)  # [m]
    collision_slop: float = positive(0.001)  # [m]
    max_check_interval: float = positive(0.02)  # [s]
    collision_motion_fraction: float = positive(0.25)
    compiled_sweep: bool = plain(True)  # the sweep's checks compiled (numba) or asked of pymunk one by one; same answers
    fixed_period: bool = plain(False)  # the action is [S, L, theta]; T_SS and T_DS are held at the robot's nominal ones
    max_sweep_checks: int = positive(2000)  # collision checks per footstep at most (bounds a step's cost)
    reward_progress: float = plain(10.0)  # per m
    reward_time: float = plain(-0.1)  # per s
    reward_step: float = plain(-0.05)  # per footstep
    reward_goal: float = plain(10.0)
    reward_collision: float = plain(-10.0)
    reward_fall: float = plain(-10.0)
    render_pixels_per_metre: float = positive(200.0)
    render_size: tuple[float, float] = config.pair((800.0, 600.0))  # [px] width, height
    video_fps: float = positive(20.0)  # [frames per simulated second] of render_mode="rgb_array_list"
    # What the robot senses of the moving obstacles (all off by default; docs/model.md, "What the robot senses").
    sensing_noise_position: float = nonnegative(0.0)  # [m] std of the noise on each axis of a moving body's position
    sensing_noise_velocity: float = nonnegative(0.0)  # [m/s] std of the noise on each axis of its velocity
    sensing_noise_angle: float = nonnegative(0.0)  # [rad] std of the noise on a moving rod's angle
    sensing_noise_angular_velocity: float = nonnegative(0.0)  # [rad/s] std of the noise on a moving rod's turn rate
    sensing_max_range: float = positive(math.inf, allow_inf=True)  # [m] moving obstacles farther than this are not sensed
    sensing_fov: float = plain(360.0)  # [deg] full field of view centred on the support foot's yaw; 360: all around

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
