"""Videos of episodes in which a recovery happened, the uncertainty trace drawn under the frames.

The frames are the camera images the policy acted on, kept by a `RecoveryVideoStore` that the controller
shows every step's observation batch: nothing is rendered for the videos, and the store lives in the
evaluating process, so it works the same with async vector envs. It keeps the frames of up to
`max_videos` episodes with a recovery; each is written as an mp4 with, under the enlarged camera image,
the sliding-window sum, the threshold, the recovery phases and a cursor at the current step: why the robot
stopped and what it did.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
from lerobot.utils.io_utils import write_video

from lerobot_ivmc.recovery.controller import BatchTrace
from lerobot_ivmc.recovery.manoeuvres import NORMAL, PHASE_NAMES

PHASE_COLOURS = {
    1: "tab:orange",
    2: "tab:green",
    3: "tab:purple",
    4: "tab:brown",
    5: "tab:cyan",
    6: "tab:olive",
    7: "tab:pink",
}
# The camera images are enlarged by a whole factor (nearest pixel) to at least this side in the videos.
VIDEO_MIN_SIDE = 256


class RecoveryVideoStore:
    """Keeps the camera frames of up to `max_videos` episodes in which the controller started a recovery.

    Args:
        max_videos: episodes kept at most (the first ones, in batch order).
        image_key: the camera in the policy's observation batch, (B, 3, H, W) floats in [0, 1].
    """

    def __init__(self, max_videos: int, image_key: str):
        self.max_videos = max_videos
        self.image_key = image_key
        self.kept: dict[tuple[int, int], np.ndarray] = {}  # (row, batch) -> (T, H, W, 3) uint8
        self._batch_frames: list[np.ndarray] = []  # per step, (B, H, W, 3) uint8

    @property
    def wants_frames(self) -> bool:
        return len(self.kept) < self.max_videos

    def observe(self, batch: dict[str, torch.Tensor]) -> None:
        """Keep this step's camera images while more videos are wanted."""
        if self.wants_frames:
            images = (batch[self.image_key].float().clamp(0, 1) * 255).round().to(torch.uint8)
            self._batch_frames.append(images.permute(0, 2, 3, 1).cpu().numpy())

    def end_batch(self, batch_index: int, trace: BatchTrace) -> None:
        """Keep the frames of the batch's episodes with a recovery (up to the limit); drop the rest."""
        if self._batch_frames:
            frames = np.stack(self._batch_frames, axis=1)  # (B, T, H, W, 3)
            for row, events in enumerate(trace.events):
                if events and self.wants_frames:
                    self.kept[(row, batch_index)] = frames[row]
        self._batch_frames = []


def enlarge(frames: np.ndarray, min_side: int = VIDEO_MIN_SIDE) -> np.ndarray:
    """(T, H, W, 3) frames enlarged by the smallest whole factor that makes them at least `min_side` wide."""
    factor = max(1, -(-min_side // frames.shape[2]))
    return frames.repeat(factor, axis=1).repeat(factor, axis=2)


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
    # Headroom above the higher of the trace and the threshold (the trace ends near it when recovery fires),
    # so that the threshold line is not drawn on the frame's edge under the legend.
    finite = np.asarray(episode["window_sum"], dtype=float)
    finite = finite[np.isfinite(finite)]
    top = max(float(finite.max()) if finite.size else 0.0, threshold if np.isfinite(threshold) else 0.0)
    ax.set_ylim(0, 1.5 * top if top > 0 else 1.0)
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


def write_recovery_video(path: Path, frames: np.ndarray, episode: dict, threshold: float, fps: int) -> Path:
    """An mp4 of the (T, H, W, 3) camera frames, enlarged, above the episode's trace; frame t is the image
    the policy acted on at step t, the cursor at that step."""
    frames = enlarge(frames)
    width = frames.shape[2]
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
    return {name: int((episode["phase"] == p).sum()) for p, name in enumerate(PHASE_NAMES) if p != NORMAL}
