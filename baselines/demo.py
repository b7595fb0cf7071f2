"""Render one frame of each scenario after a short episode, as the README's pictures.

Usage (the README's command; ``--out`` defaults to the folder its pictures live in)::

    SDL_VIDEODRIVER=dummy .venv/bin/python baselines/demo.py --out baselines/results/frames --steps 14

The robot is driven by the period-aware planner when ``footstep_gym.planners`` is
available, otherwise it walks straight ahead at the nominal period.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import footstep_gym  # noqa: E402,F401

#: Where the README's pictures live: the default --out.
FRAMES = Path(__file__).resolve().parent / "results" / "frames"


def run(env_id: str, seed: int, steps: int, out: Path) -> Path:
    env = gym.make(env_id, render_mode="rgb_array")
    obs, _ = env.reset(seed=seed)
    try:
        from footstep_gym import make_policy

        policy = make_policy("period-aware", env.unwrapped.robot, seed=seed)
        policy.reset(seed=seed)
        act = lambda o: policy.act(o, env.unwrapped.sensing())  # noqa: E731
    except ImportError:
        forward = env.unwrapped.robot.nominal_command.copy()
        forward[0] = env.unwrapped.robot.stride_front[1]
        act = lambda o: forward  # noqa: E731
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(act(obs))
        if terminated or truncated:
            break
    frame = env.render()
    env.close()
    import pygame

    path = out / f"{env_id.split('-')[0].removeprefix('Footstep').lower()}.png"
    pygame.image.save(pygame.surfarray.make_surface(np.ascontiguousarray(frame.transpose(1, 0, 2))), str(path))
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=FRAMES,
                        help="folder for <scene>.png (default baselines/results/frames, the README's pictures)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, default=200, help="footsteps at most per episode")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for env_id in footstep_gym.ENV_IDS.values():
        print(run(env_id, args.seed, args.steps, args.out))


if __name__ == "__main__":
    main()
