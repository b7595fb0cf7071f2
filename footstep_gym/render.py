"""Drawing an env with pygame-ce (imported lazily: the maths and planners never need it)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from footstep_gym.env import FootstepEnv

# Colours (RGB).
BACKGROUND = (250, 250, 247)
WALL = (70, 70, 70)
OBSTACLE = (120, 130, 150)
GOAL = (60, 170, 90)
LEFT_FOOT = (50, 110, 220)
RIGHT_FOOT = (220, 70, 60)
COM_PATH = (20, 20, 20)
ZMP = (245, 150, 20)
BODY = (90, 90, 90)
TEXT = (30, 30, 30)


class Renderer:
    """Draws obstacles, goal, both feet's footprints (blue left, red right), CoM path and ZMP points."""

    def __init__(self, env: "FootstepEnv", mode: str) -> None:
        try:
            import pygame
        except ImportError as exc:
            from gymnasium.error import DependencyNotInstalled

            raise DependencyNotInstalled(
                'rendering needs pygame-ce: pip install "footstep_gym[render]" (or pip install pygame-ce)') from exc

        self.pygame = pygame
        self.env = env
        self.mode = mode
        self.width, self.height = (int(v) for v in env.config.render_size)
        cfg = env.scenario_config
        self.centre = (0.5 * (cfg.start[0] + cfg.goal[0]), 0.5 * (cfg.start[1] + cfg.goal[1]))
        span = math.hypot(cfg.goal[0] - cfg.start[0], cfg.goal[1] - cfg.start[1]) + 0.8
        self.scale = min(env.config.render_pixels_per_metre, 0.9 * self.width / span)
        pygame.font.init()
        self.font = pygame.font.Font(None, 20)
        if mode == "human":
            pygame.display.init()
            pygame.display.set_caption(f"footstep_gym: {env.scenario_name}")
            self.screen = pygame.display.set_mode((self.width, self.height))
            self.clock = pygame.time.Clock()
        self.surface = pygame.Surface((self.width, self.height))

    def to_px(self, x: float, y: float) -> tuple[int, int]:
        return (int(round(self.width / 2 + (x - self.centre[0]) * self.scale)),
                int(round(self.height / 2 - (y - self.centre[1]) * self.scale)))

    def _rect(self, pose: tuple[float, float, float], length: float, width: float) -> list[tuple[int, int]]:
        x, y, yaw = pose
        c, s = math.cos(yaw), math.sin(yaw)
        pts = []
        for dx, dy in ((0.5, 0.5), (-0.5, 0.5), (-0.5, -0.5), (0.5, -0.5)):
            lx, ly = dx * length, dy * width
            pts.append(self.to_px(x + c * lx - s * ly, y + s * lx + c * ly))
        return pts

    def draw(self, com: complex | None = None, back: float = 0.0, time: float | None = None) -> np.ndarray | None:
        """Draw the env now, or inside the step under way: the robot's CoM at ``com`` (world),
        every moving obstacle ``back`` [s] before its present pose (obstacles keep one velocity
        through a step), the clock at ``time`` [s]."""
        pg, env, surf = self.pygame, self.env, self.surface
        surf.fill(BACKGROUND)
        goal = env.episode_config.goal
        pg.draw.circle(surf, GOAL, self.to_px(*goal), max(2, int(env.episode_config.goal_tolerance * self.scale)), 2)
        pg.draw.circle(surf, GOAL, self.to_px(*goal), 4)
        for o in env.world.obstacles:
            body = o.body
            colour = WALL if o.static else OBSTACLE
            (px, py), angle = body.position, body.angle
            if back and not o.static:
                px, py = px - back * body.velocity.x, py - back * body.velocity.y
                angle -= back * body.angular_velocity
            c, s = math.cos(angle), math.sin(angle)

            def to_world(q: tuple[float, float]) -> tuple[float, float]:
                return (px + c * q[0] - s * q[1], py + s * q[0] + c * q[1])

            if o.kind == "circle":
                pg.draw.circle(surf, colour, self.to_px(*to_world(o.local_a)), max(1, int(o.radius * self.scale)))
            else:
                a, b = to_world(o.local_a), to_world(o.local_b)
                w = max(2, int(2 * o.radius * self.scale))
                pa, pb = self.to_px(*a), self.to_px(*b)
                pg.draw.line(surf, colour, pa, pb, w)
                for p in (pa, pb):
                    pg.draw.circle(surf, colour, p, w // 2)
        robot = env.robot
        for pose, side in env.history["footprints"]:
            pg.draw.polygon(surf, LEFT_FOOT if side > 0 else RIGHT_FOOT,
                            self._rect(pose, robot.foot_length, robot.foot_width), 2)
        for side, pose in env.feet.items():
            pg.draw.polygon(surf, LEFT_FOOT if side > 0 else RIGHT_FOOT,
                            self._rect(pose, robot.foot_length, robot.foot_width))
        com_path = env.history["com"]
        if len(com_path) > 1:
            pg.draw.lines(surf, COM_PATH, False, [self.to_px(*p) for p in com_path], 2)
        for z in env.history["zmp"]:
            pg.draw.circle(surf, ZMP, self.to_px(*z), 3)
        if com is None:
            com = env.com
        pg.draw.circle(surf, BODY, self.to_px(com.real, com.imag), max(2, int(robot.body_radius * self.scale)), 1)
        label = (f"{env.scenario_name}  t={env.time if time is None else time:5.2f} s  steps={env.steps}  "
                 f"T={float(env.previous_command[3] + env.previous_command[4]):.2f} s")
        surf.blit(self.font.render(label, True, TEXT), (8, 8))
        if self.mode == "human":
            self.screen.blit(surf, (0, 0))
            pg.event.pump()
            pg.display.flip()
            self.clock.tick(env.metadata["render_fps"])
            return None
        return np.transpose(np.array(pg.surfarray.pixels3d(surf)), axes=(1, 0, 2)).copy()

    def close(self) -> None:
        if self.mode == "human":
            self.pygame.display.quit()
