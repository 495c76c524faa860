"""Videos of episodes in which a recovery happened, the uncertainty trace drawn under the frames.

`FrameRecorder` wraps a sub-env and renders the frames of its seeded episodes; when one ends it offers
them to a `RecoveryVideoStore`, which keeps those of episodes with a recovery (up to a limit) and writes
each as an mp4 with, under the camera, the sliding-window sum, the threshold, the recovery phases and a
cursor at the current step: why the robot stopped and what it did.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from lerobot.utils.io_utils import write_video

from lerobot_ivmc.recovery.manoeuvres import NORMAL, PHASE_NAMES

PHASE_COLOURS = {1: "tab:orange", 2: "tab:green", 3: "tab:purple", 4: "tab:brown"}


class RecoveryVideoStore:
    """Keeps the frames of up to `max_videos` episodes that `had_recovery(env_index, episode_index)`."""

    def __init__(self, max_videos: int):
        self.max_videos = max_videos
        self.had_recovery: Callable[[int, int], bool] = lambda env_index, episode_index: False
        self.kept: dict[tuple[int, int], list[np.ndarray]] = {}

    @property
    def wants_frames(self) -> bool:
        return len(self.kept) < self.max_videos

    def offer(self, env_index: int, episode_index: int, frames: list[np.ndarray]) -> None:
        if self.wants_frames and self.had_recovery(env_index, episode_index):
            self.kept[(env_index, episode_index)] = frames


class FrameRecorder(gym.Wrapper):
    """Renders every step of this sub-env's seeded episodes while the store wants frames."""

    def __init__(self, env: gym.Env, env_index: int, store: RecoveryVideoStore):
        super().__init__(env)
        self.env_index = env_index
        self.store = store
        self.seeded_episodes = 0
        self._frames: list[np.ndarray] | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        observation, info = self.env.reset(seed=seed, options=options)
        self._frames = None
        if seed is not None:
            self.seeded_episodes += 1
            if self.store.wants_frames:
                self._frames = [self.env.render()]
        return observation, info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        if self._frames is not None:
            self._frames.append(self.env.render())
            if terminated or truncated:
                self.store.offer(self.env_index, self.seeded_episodes - 1, self._frames)
                self._frames = None
        return observation, reward, terminated, truncated, info


def trace_panel(episode: dict, threshold: float, width: int, height: int) -> tuple[np.ndarray, Callable]:
    """The trace plot as an (height, width, 3) image, and a function step -> cursor x pixel."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dpi = 100
    fig, ax = plt.subplots(figsize=(width / dpi, height / dpi), dpi=dpi)
    steps = np.arange(len(episode["window_sum"]))
    for phase, colour in PHASE_COLOURS.items():
        inside = episode["phase"] == phase
        if inside.any():
            ax.fill_between(
                steps,
                0,
                1,
                where=inside,
                color=colour,
                alpha=0.3,
                step="mid",
                transform=ax.get_xaxis_transform(),
                label=PHASE_NAMES[phase],
            )
    ax.plot(steps, episode["window_sum"], color="black", lw=1, label="window sum")
    if np.isfinite(threshold):
        ax.axhline(threshold, color="tab:red", ls="--", lw=1, label="threshold")
    ax.set_xlim(0, max(len(steps), 1))
    ax.set_xlabel("step", fontsize=6)
    ax.tick_params(labelsize=6)
    ax.legend(fontsize=5, loc="upper left", ncol=3)
    with warnings.catch_warnings():  # tiny frames (tests) leave no room for the margins; the plot is fine
        warnings.simplefilter("ignore", UserWarning)
        fig.tight_layout(pad=0.3)
    fig.canvas.draw()
    image = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    to_pixel = ax.transData.transform
    x_of_step = {int(s): int(round(to_pixel((s, 0))[0])) for s in range(len(steps) + 1)}
    plt.close(fig)
    return image, lambda step: x_of_step[min(step, len(steps))]


def write_recovery_video(
    path: Path, frames: list[np.ndarray], episode: dict, threshold: float, fps: int
) -> Path:
    """An mp4 of `frames` above the episode's trace, a cursor at each frame's step."""
    width = frames[0].shape[1]
    panel, x_of_step = trace_panel(episode, threshold, width, max(width // 2, 96))
    stacked = []
    for step, frame in enumerate(frames):
        below = panel.copy()
        x = x_of_step(step)
        below[:, max(x - 1, 0) : x + 1] = (220, 0, 0)
        stacked.append(np.concatenate([frame, below], axis=0))
    path.parent.mkdir(parents=True, exist_ok=True)
    write_video(str(path), np.stack(stacked), fps=fps)
    return path


def recovery_phase_summary(episode: dict) -> dict[str, int]:
    """Steps spent in each phase other than normal operation."""
    return {PHASE_NAMES[p]: int((episode["phase"] == p).sum()) for p in PHASE_COLOURS if p != NORMAL}
