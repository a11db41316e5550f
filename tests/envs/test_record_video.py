"""Gymnasium's RecordVideo over Locomotion-v1 (the ``video`` extra: MoviePy), on pybullet."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

moviepy = pytest.importorskip("moviepy", reason="needs moviepy (the video extra)")

import revolve_env  # noqa: E402,F401 - registers the env ids

# 0.05 s + 0.15 s at 60 Hz: a 12-step episode, one frame per step (and one of the reset).
SHORT = {"insertion_time": 0.05, "evaluation_time": 0.15, "engine": "pybullet"}


def test_record_video_writes_one_frame_per_step_of_a_locomotion_episode(tmp_path: Path) -> None:
    env = gym.make("revolve_env/Locomotion-v1", render_mode="rgb_array", **SHORT)
    folder = tmp_path / "videos"  # a new folder (RecordVideo warns on an existing one)
    env = gym.wrappers.RecordVideo(env, str(folder), episode_trigger=lambda episode: True,
                                   name_prefix="spider", disable_logger=True)
    env.reset(seed=0)
    steps, done = 0, False
    while not done:
        _, _, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape, np.float32))
        steps, done = steps + 1, terminated or truncated
    env.close()
    assert steps == 12
    videos = sorted(folder.glob("*.mp4"))
    assert [v.name for v in videos] == ["spider-episode-0.mp4"]
    with moviepy.VideoFileClip(str(videos[0])) as clip:
        assert clip.fps == 60 and tuple(clip.size) == (480, 360)
        assert clip.duration == pytest.approx((steps + 1) / 60, abs=1.5 / 60)  # reset + steps
        first, last = clip.get_frame(0), clip.get_frame(clip.duration - 1 / 60)
    assert first.std() > 1 and not np.array_equal(first, last)  # a picture, and it moved
