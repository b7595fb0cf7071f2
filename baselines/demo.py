"""Render one frame of each scenario after a short episode of the period-aware planner.

Usage::

    python baselines/demo.py                      # runs/frames/<scene>.png
    SDL_VIDEODRIVER=dummy .venv/bin/python baselines/demo.py --out baselines/results/frames --steps 14

The second line is the README's command: it redraws the README's pictures, which ``tests/test_demo.py`` keeps equal
to what it draws. Without ``--out`` nothing tracked is touched.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import footstep_gym  # noqa: E402
from footstep_gym import make_policy  # noqa: E402

#: Where the pictures go unless --out says otherwise (the README's live in baselines/results/frames).
DEFAULT_OUT = Path("runs") / "frames"
POLICY = "period-aware"


def frame(env_id: str, seed: int, steps: int) -> np.ndarray:
    """The env's ``rgb_array`` frame (height, width, 3) after at most ``steps`` footsteps of the period-aware
    planner, env and planner seeded with ``seed``."""
    env = gym.make(env_id, render_mode="rgb_array")
    try:
        obs, _ = env.reset(seed=seed)
        policy = make_policy(POLICY, env.unwrapped.robot, seed=seed)
        policy.reset(seed=seed)
        for _ in range(steps):
            obs, _, terminated, truncated, _ = env.step(policy.act(obs, env.unwrapped.sensing()))
            if terminated or truncated:
                break
        return np.asarray(env.render())
    finally:
        env.close()


def picture_name(scene: str) -> str:
    return f"{scene}.png"


def save(image: np.ndarray, path: Path) -> Path:
    import pygame

    pygame.image.save(pygame.surfarray.make_surface(np.ascontiguousarray(image.transpose(1, 0, 2))), str(path))
    return path


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help=f"folder for <scene>.png (default {DEFAULT_OUT}; the README's pictures: "
                             "baselines/results/frames)")
    parser.add_argument("--seed", type=int, default=0, help="seed of every env and planner (default 0)")
    parser.add_argument("--steps", type=int, default=200, help="footsteps at most per episode (default 200)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error(f"--steps must be at least 1, got {args.steps}")
    if args.out.exists() and not args.out.is_dir():
        parser.error(f"--out {args.out} is a file, not a folder")
    args.out.mkdir(parents=True, exist_ok=True)
    for scene, env_id in footstep_gym.ENV_IDS.items():
        print(save(frame(env_id, args.seed, args.steps), args.out / picture_name(scene)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
