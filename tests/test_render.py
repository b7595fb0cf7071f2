"""Rendering (footstep_gym/render.py) through the envs' ``render()``.

Checked by what a viewer sees, not by the drawing code: the frame's size comes from
configs/env.yaml, the picture is not blank, the feet show in their two colours (blue
left, red right, as the docs say), a top-down view keeps the world's +x to the right
and +y up, and drawing never changes the simulation.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
import yaml

from footstep_gym.config import config_dir

ENV_IDS = ["FootstepDoor-v0", "FootstepCrossing-v0", "FootstepCrowd-v0"]
NOMINAL = np.array([0.0, 0.08, 0.0, 0.6, 0.2])
FREE = dict(crossing_x=5.0, timing_jitter=0.0)


def render_size() -> tuple[int, int]:
    with open(config_dir() / "env.yaml", encoding="utf-8") as fh:
        width, height = yaml.safe_load(fh)["render_size"]
    return int(width), int(height)


def bluish(frame: np.ndarray) -> np.ndarray:
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    return (b > r + 60) & (b > g + 40)


def reddish(frame: np.ndarray) -> np.ndarray:
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    return (r > g + 60) & (r > b + 60)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rgb_array_frame(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    width, height = render_size()
    assert isinstance(frame, np.ndarray)
    assert frame.shape == (height, width, 3) and frame.dtype == np.uint8
    packed = (frame[..., 0].astype(np.int32) << 16) | (frame[..., 1].astype(np.int32) << 8) | frame[..., 2]
    _, counts = np.unique(packed, return_counts=True)
    assert len(counts) >= 5  # background, feet, goal, obstacles, text...
    assert bluish(frame).sum() > 50 and reddish(frame).sum() > 50  # both feet are visible
    # Most of the frame is background, but not all of it.
    assert 0.5 < counts.max() / (width * height) < 0.999
    # The frame follows the env: after a few steps the picture is different.
    for _ in range(3):
        env.step(NOMINAL)
    assert not np.array_equal(env.render(), frame)
    env.close()


def test_render_size_override():
    env = gym.make("FootstepDoor-v0", render_mode="rgb_array", render_size=[320, 240])
    env.reset(seed=0)
    assert env.render().shape == (240, 320, 3)
    env.close()


def test_frames_are_deterministic():
    frames = []
    for _ in range(2):
        env = gym.make("FootstepCrowd-v0", render_mode="rgb_array")
        env.reset(seed=4)
        env.step(NOMINAL)
        frames.append(env.render())
        env.close()
    assert np.array_equal(*frames)


def test_view_is_top_down_with_x_right_and_y_up():
    """Walking +x moves the feet right in the image; the left (blue) foot is above the right (red) one."""
    env = gym.make("FootstepCrossing-v0", render_mode="rgb_array", **FREE)
    env.reset(seed=0)
    first = env.render()
    rows_b, cols_b = np.nonzero(bluish(first))
    rows_r, cols_r = np.nonzero(reddish(first))
    assert rows_b.mean() < rows_r.mean()  # facing +x, the left foot lies at +y: higher up
    for stride in (0.03, 0.06, 0.09, 0.1, 0.1, 0.1):
        _, _, terminated, _, _ = env.step(np.array([stride, 0.08, 0.0, 0.6, 0.2]))
        assert not terminated
    later = env.render()
    # Footprints stay drawn, so the right-most foot pixels tell where the robot is now.
    assert np.nonzero(bluish(later))[1].max() > cols_b.max() + 20
    assert np.nonzero(reddish(later))[1].max() > cols_r.max() + 20
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_rendering_does_not_change_the_simulation(env_id):
    plain = gym.make(env_id)
    drawn = gym.make(env_id, render_mode="rgb_array")
    obs_a, _ = plain.reset(seed=9)
    obs_b, _ = drawn.reset(seed=9)
    assert np.array_equal(obs_a, obs_b)
    for _ in range(4):
        drawn.render()
        a, b = plain.step(NOMINAL), drawn.step(NOMINAL)
        assert np.array_equal(a[0], b[0]) and a[1:4] == b[1:4]
        if a[2] or a[3]:
            break
    plain.close()
    drawn.close()


def test_human_mode_headless():
    env = gym.make("FootstepCrowd-v0", render_mode="human")
    env.reset(seed=0)  # renders a frame in human mode
    assert env.render() is None
    _, _, _, _, info = env.step(NOMINAL)  # renders again
    assert "time" in info
    env.close()
    env.close()  # closing twice is harmless


def test_render_without_mode_warns_and_returns_none():
    env = gym.make("FootstepDoor-v0")
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.render() is None
    env.close()


def test_render_before_reset_raises():
    env = gym.make("FootstepDoor-v0", render_mode="rgb_array", disable_env_checker=True)
    with pytest.raises(gym.error.ResetNeeded):
        env.unwrapped.render()


def test_close_then_render_again():
    env = gym.make("FootstepDoor-v0", render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    env.close()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = env.render()  # a closed env may be drawn again: the renderer is rebuilt
    assert np.array_equal(first, again)


# ---------------------------------------------------------------- frames inside a step, videos
def test_rgb_array_list_hands_over_frames_evenly_spaced_in_simulated_time():
    env = gym.make("FootstepCrossing-v0", render_mode="rgb_array_list", **FREE)
    fps = env.metadata["render_fps"]
    with open(config_dir() / "env.yaml", encoding="utf-8") as fh:
        assert fps == yaml.safe_load(fh)["video_fps"]
    env.reset(seed=2)
    frames = env.render()
    assert len(frames) == 1 and frames[0].shape == (*render_size()[::-1], 3)
    assert env.render() == []  # handed over once
    total, t_end = 1, 0.0
    for command in (NOMINAL, [0.05, 0.08, 0.0, 0.3, 0.15], [0.05, 0.08, 0.0, 0.25, 0.1]):
        *_, info = env.step(np.asarray(command, dtype=np.float32))
        frames = env.render()
        # A frame at every multiple of 1/fps in (t_before, t_after]: a 0.8 s step at 20 fps gives 16.
        expected = int(np.floor(info["time"] * fps + 1e-6)) - int(np.floor(t_end * fps + 1e-6))
        assert len(frames) == expected, (command, len(frames), expected)
        total += len(frames)
        t_end = info["time"]
        assert not np.array_equal(frames[0], frames[-1])  # the robot moved inside the step
    assert total == 1 + int(np.floor(t_end * fps + 1e-6))
    env.close()


def test_in_step_frames_show_the_obstacles_where_they_were():
    """The last frame of a step is drawn at the step's end: the same obstacles as rgb_array after the step."""
    listed = gym.make("FootstepCrowd-v0", render_mode="rgb_array_list")
    single = gym.make("FootstepCrowd-v0", render_mode="rgb_array")
    listed.reset(seed=4)
    single.reset(seed=4)
    listed.render()
    first = single.render()
    listed.step(NOMINAL)
    single.step(NOMINAL)
    frames = listed.render()
    after = single.render()
    grey = lambda f: np.all(np.abs(f.astype(int) - (120, 130, 150)) < 3, axis=-1)  # noqa: E731 (obstacle colour)
    assert grey(frames[-1]).sum() > 100
    assert np.array_equal(grey(frames[-1]), grey(after))  # obstacles drawn at the step's end
    assert not np.array_equal(grey(frames[0]), grey(first))  # and 1/fps into the step, they had moved on
    listed.close()
    single.close()


def test_record_video_writes_a_real_time_video(tmp_path):
    moviepy = pytest.importorskip("moviepy")
    from footstep_gym.wrappers import RecordVideo

    env = RecordVideo(gym.make("FootstepCrossing-v0", render_mode="rgb_array_list", **FREE), str(tmp_path / "v"),
                      episode_trigger=lambda e: e == 0, disable_logger=True)
    env.reset(seed=0)
    for _ in range(5):
        *_, info = env.step(NOMINAL)
    env.close()
    videos = list((tmp_path / "v").glob("*.mp4"))
    assert len(videos) == 1
    clip = moviepy.VideoFileClip(str(videos[0]))
    try:
        assert clip.fps == pytest.approx(env.metadata["render_fps"])
        assert clip.duration == pytest.approx(info["time"], abs=0.15)  # 4 s simulated, 4 s of video
    finally:
        clip.close()
