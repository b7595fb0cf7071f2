"""The site's episode videos: a few methods side by side on each cell, one validation seed, H.264 MP4.

``render_videos(root)`` plays one episode per cell of ``configs/benchmark.yaml`` and method of :data:`METHODS`
(2D renders, ``render_mode="rgb_array_list"``), each on the same validation seed, and writes one MP4 per cell
(the methods' panels left to right, each labelled with its name and, once over, its outcome) and
``videos.json`` (the command, the seed, the methods, each video's outcomes) into ``baselines/results/site/``.
The site copies them in and renders nothing itself.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Sequence

import numpy as np

__all__ = ["METHODS", "render_videos", "episode_frames", "video_seed"]

#: The methods filmed on every cell: the multi-step planner, the paper's planner, the PPO agent (its first run).
METHODS = ("lookahead", "period-aware", "ppo")
#: The validation split's first seed (configs/eval.yaml): the same episode for every method.
VIDEO_SEED_OFFSET = 0
#: Every n-th frame of the env's ``video_fps`` is kept, the video plays at ``video_fps / n`` (real time).
FRAME_STRIDE = 2
#: An episode is shown for at most this many simulated seconds.
MAX_SECONDS = 40.0
PANEL = (400, 300)  # [px] each method's panel (the env's 800 x 600 frames halved)
LABEL_H = 24  # [px] the label bar above each panel
COMMAND = "python baselines/make_site.py --videos"


def video_seed() -> int:
    """The seed every method is filmed on: the validation split's first (configs/eval.yaml)."""
    from footstep_gym.evaluation.splits import split_seeds

    return split_seeds("validation", 1, VIDEO_SEED_OFFSET)[0]


def episode_frames(env_id: str, tier: str, cell: str, policy: str, seed: int, root: Path
                   ) -> tuple[list[np.ndarray], str, float]:
    """One episode's frames (RGB uint8, the env's ``video_fps``), its outcome and its simulated length [s]."""
    import gymnasium as gym

    from footstep_gym import registry
    from footstep_gym.evaluation.runner import bind_truth
    from footstep_gym.rl.registry import AGENTS, agent_runs

    env = gym.make(env_id, render_mode="rgb_array_list", tier=tier, tier_cell=cell)
    try:
        run = None
        if policy in AGENTS:
            runs = agent_runs(policy, env_id, root / "baselines/agents")
            if not runs:
                raise FileNotFoundError(f"agent {policy}: no shipped run for {env_id} under baselines/agents/")
            run = runs[0]
        pol = registry.make_policy(policy, env.unwrapped.robot, seed=seed, run=run)
        bind_truth(pol, env)
        obs, _ = env.reset(seed=seed)
        pol.reset(seed=seed)
        frames = list(env.render())
        fps = float(env.metadata["render_fps"])
        outcome = "timeout"
        while True:
            obs, _, terminated, truncated, info = env.step(pol.act(obs, env.unwrapped.sensing()))
            frames += env.render()
            if terminated or truncated:
                outcome = str(info.get("termination") or "timeout") if terminated else "timeout"
                break
            if len(frames) / fps > MAX_SECONDS:
                outcome = "still walking, video cut"
                break
        return frames, outcome, float(env.unwrapped.time)
    finally:
        env.close()


def _panel(frame: np.ndarray, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw, ImageFont

    im = Image.fromarray(frame).resize(PANEL, Image.BILINEAR)
    canvas = Image.new("RGB", (PANEL[0], PANEL[1] + LABEL_H), (23, 38, 63))
    canvas.paste(im, (0, LABEL_H))
    try:
        font = ImageFont.load_default(size=15)
    except TypeError:  # Pillow < 10.1: the bitmap font
        font = ImageFont.load_default()
    ImageDraw.Draw(canvas).text((6, 3), text, fill=(255, 255, 255), font=font)
    return np.asarray(canvas)


def _compose(episodes: Sequence[tuple[str, list[np.ndarray], str, float]]) -> list[np.ndarray]:
    """The side-by-side frames: every ``FRAME_STRIDE``-th frame; an episode over holds its last frame."""
    n = max(len(f) for _, f, _, _ in episodes)
    out = []
    for k in range(0, n, FRAME_STRIDE):
        panels = []
        for name, frames, outcome, length in episodes:
            done = k >= len(frames) - 1
            text = f"{name}: {outcome} at {length:.1f} s" if done else name
            panels.append(_panel(frames[min(k, len(frames) - 1)], text))
        out.append(np.concatenate(panels, axis=1))
    return out


def _write_mp4(path: Path, frames: Sequence[np.ndarray], fps: float) -> None:
    import imageio_ffmpeg

    h, w = frames[0].shape[:2]
    writer = imageio_ffmpeg.write_frames(str(path), (w, h), fps=fps, codec="libx264", pix_fmt_out="yuv420p",
                                         macro_block_size=4, quality=None,
                                         output_params=["-crf", "30", "-preset", "slow", "-movflags", "+faststart",
                                                        "-tune", "animation"])
    writer.send(None)
    for f in frames:
        writer.send(np.ascontiguousarray(f))
    writer.close()


def render_videos(root: Path, cells: Sequence[str] | None = None, methods: Sequence[str] = METHODS) -> list[Path]:
    """Film ``methods`` on each cell (``TIER/SCENE/CELL``; default every cell of configs/benchmark.yaml) and rewrite
    ``baselines/results/site/`` (videos of other cells already there are kept). Returns the MP4s written."""
    from footstep_gym import ENV_IDS, tiers
    from footstep_gym.evaluation.site import VIDEOS_DIR, slug

    seed = video_seed()
    folder = root / VIDEOS_DIR
    (folder / "videos").mkdir(parents=True, exist_ok=True)
    manifest_path = folder / "videos.json"
    manifest: dict[str, Any] = json.loads(manifest_path.read_text()) if manifest_path.is_file() else {}
    known = [f"{t.name}/{scene}/{c}" for t in tiers.load_tiers().values() for scene, cs in t.scenes.items() for c in cs]
    wanted = list(cells) if cells else known
    bad = [c for c in wanted if c not in known]
    if bad:
        raise ValueError(f"unknown cells {bad}; the benchmark's are TIER/SCENE/CELL, e.g. {known[0]}")
    if manifest.get("seed") not in (None, seed) or manifest.get("methods") not in (None, list(methods)):
        manifest["videos"] = {}  # another seed or other methods: the old videos are not of this set
    videos = manifest.get("videos") or {}
    fps = _video_fps() / FRAME_STRIDE
    made = []
    for key in wanted:
        tier, scene, cell = key.split("/")
        env_id = ENV_IDS[scene]
        episodes = []
        for policy in methods:
            frames, outcome, length = episode_frames(env_id, tier, cell, policy, seed, root)
            episodes.append((policy, frames, outcome, length))
            print(f"  {key} {policy}: {outcome} at {length:.1f} s ({len(frames)} frames)", flush=True)
        name = f"videos/{slug(tier)}-{slug(scene)}-{slug(cell)}.mp4"
        composed = _compose(episodes)
        _write_mp4(folder / name, composed, fps)
        videos[key] = {"file": name, "width": composed[0].shape[1], "height": composed[0].shape[0],
                       "outcomes": {p: f"{o} at {t:.1f} s" for p, _, o, t in episodes},
                       "bytes": (folder / name).stat().st_size}
        made.append(folder / name)
    manifest.update({"command": COMMAND, "seed": seed, "split": "validation", "methods": list(methods), "fps": fps,
                     "videos": dict(sorted(videos.items()))})
    manifest_path.write_text(json.dumps(manifest, indent=1) + "\n", encoding="utf-8")
    return made


def _video_fps() -> float:
    import gymnasium as gym

    env = gym.make("FootstepDoor-v0", render_mode="rgb_array_list")
    try:
        return float(env.metadata["render_fps"])
    finally:
        env.close()
