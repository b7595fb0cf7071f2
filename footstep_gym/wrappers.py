"""Wrappers for the footstep envs.

:class:`TrackedObservation` gives an agent what the ``period-aware`` planner is given with
``additions.tracking``: the observation's obstacle slots built from the tracker's estimates of what is
sensed (:mod:`footstep_gym.planners.tracking`) rather than from each footstep's raw, possibly noisy, readings.

:class:`RecordVideo` is Gymnasium's recorder, taught to keep every frame an env hands over
from inside a step. One footstep simulates a whole walking period (0.2-0.9 s), so one frame
per ``step`` makes a video that jumps; with ``render_mode="rgb_array_list"`` the env draws
frames at ``video_fps`` per simulated second inside each step, and this recorder writes them
all at that rate, so the video plays in real time.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.wrappers import RecordVideo as _GymRecordVideo

from footstep_gym.observation import HEAD, PREVIOUS, ObservationScales, observation
from footstep_gym.planners.params import TrackingParams, load_planner_config
from footstep_gym.planners.tracking import Tracker
from footstep_gym.sensing import Snapshot, nearest_views

__all__ = ["RecordVideo", "TrackedObservation"]

def obstacle_slots(snapshot: Snapshot, n_obstacles: int, sensing_range: float, scales: ObservationScales
                   ) -> np.ndarray:
    """The observation's obstacle slots (float32, ``SLOT * n_obstacles``) from the views of ``snapshot``: the
    ``n_obstacles`` shapes nearest the CoM within ``sensing_range`` [m] (:func:`~footstep_gym.sensing.nearest_views`),
    laid out by the env's own :func:`~footstep_gym.observation.observation`."""
    near = nearest_views(snapshot.obstacles, snapshot.com, n_obstacles, sensing_range)
    full = observation(snapshot.support_foot, snapshot.support_side, complex(*snapshot.com), complex(*snapshot.com_vel),
                       snapshot.goal, (0.0,) * (HEAD - PREVIOUS.start), near, n_obstacles, scales)
    return full[HEAD:]


class TrackedObservation(gym.ObservationWrapper):
    """The observation with its obstacle slots read from a :class:`~footstep_gym.planners.tracking.Tracker`.

    At ``reset`` the tracker forgets; after ``reset`` and every ``step`` it folds in ``env.unwrapped.sensing()``
    (what the robot senses, noise included: nothing else of the env is read but the observation's settings)
    and the slots are rebuilt from its estimates with the env's own arithmetic; the other slots are the env's.
    Where the readings are exact the tracker hands them on unchanged and the observation is the env's, bit for
    bit. ``params``: the tracker's settings (default: ``configs/planner.yaml``'s ``tracking`` section, the
    planner's). The space is the env's.

    Example::

        env = TrackedObservation(gym.make("FootstepDoor-v0", tier="noise", tier_cell="train"))
    """

    def __init__(self, env: gym.Env, params: TrackingParams | None = None) -> None:
        super().__init__(env)
        self.tracker = Tracker(params if params is not None else load_planner_config().tracking)

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        self.tracker.reset()
        return super().reset(**kwargs)

    def observation(self, observation: np.ndarray) -> np.ndarray:
        base = self.env.unwrapped
        cfg = base.config
        snapshot = self.tracker.update(base.sensing())
        out = np.array(observation, dtype=np.float32, copy=True)
        out[HEAD:] = obstacle_slots(snapshot, cfg.n_obstacles_observed, cfg.sensing_range, ObservationScales.of(cfg))
        return out


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
