"""Wrappers for the footstep envs.

:class:`RecordVideo` is Gymnasium's recorder, taught to keep every frame an env hands over
from inside a step. One footstep simulates a whole walking period (0.2-0.9 s), so one frame
per ``step`` makes a video that jumps; with ``render_mode="rgb_array_list"`` the env draws
frames at ``video_fps`` per simulated second inside each step, and this recorder writes them
all at that rate, so the video plays in real time.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium.wrappers import RecordVideo as _GymRecordVideo

__all__ = ["RecordVideo"]


class RecordVideo(_GymRecordVideo):
    """Gymnasium's :class:`~gymnasium.wrappers.RecordVideo` that records every frame of a list.

    Gymnasium's recorder keeps only the last frame of what ``render()`` returns in
    ``"rgb_array_list"`` mode; this one keeps them all (the env's ``render_fps`` is then the
    frame rate of simulated time). Needs ``moviepy`` (``pip install "footstep_gym[eval]"``).

    Example::

        env = gym.make("FootstepDoor-v0", render_mode="rgb_array_list")
        env = RecordVideo(env, "videos", episode_trigger=lambda e: e == 0)
    """

    def __init__(self, env: gym.Env, video_folder: str, **kwargs) -> None:
        try:
            import moviepy  # noqa: F401
        except ImportError as exc:
            raise gym.error.DependencyNotInstalled(
                'recording videos needs moviepy: pip install "footstep_gym[eval]" (or pip install moviepy)'
            ) from exc
        super().__init__(env, video_folder, **kwargs)

    def _capture_frame(self) -> None:
        assert self.recording, "Cannot capture a frame, recording wasn't started."
        frames = self.env.render()
        if not isinstance(frames, list):
            frames = [frames]
        for frame in frames:
            if not isinstance(frame, np.ndarray):
                self.stop_recording()
                raise gym.error.Error(f"expected render() to return numpy frames, got {type(frame).__name__}")
            self.recorded_frames.append(frame)
        self.render_history += frames
