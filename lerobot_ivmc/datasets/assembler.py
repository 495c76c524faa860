"""LeRobot's writer behind the collector: staged episodes appended, in order, to a LeRobotDataset built in
the staging folder, its statistics file written with sorted keys, `datasets`' progress bars silenced, and
its image bytes embedded a batch of rows at a time."""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator
from pathlib import Path

import datasets
import lerobot.datasets.lerobot_dataset as lerobot_dataset_module
import numpy as np
from datasets.table import embed_table_storage
from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot.datasets.utils import STATS_PATH, write_json

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.collect_config import CollectConfig
from lerobot_ivmc.datasets.features import (
    ACTION_KEY,
    ENV_STATE_KEY,
    SCENE_OBJECT_CELL_KEY,
    SCENE_SEED_KEY,
    SCENE_TARGET_CELL_KEY,
    STATE_KEY,
)

# Rows whose image bytes are embedded in one call (an episode is 100 to 200 frames).
EMBED_BATCH_ROWS = 1000


class EpisodeAssembler:
    """Appends staged episodes, in order, to a LeRobotDataset built in the staging folder."""

    def __init__(self, cfg: CollectConfig, build_root: Path):
        self.suite = cfg.suite
        self.task_description = self.suite.task_description(cfg.task)
        features = self.suite.features(cfg.image_size, cfg.video)
        self.image_key = next(key for key, f in features.items() if f["dtype"] in ("image", "video"))
        self.dataset = LeRobotDataset.create(
            repo_id=cfg.repo_id,
            fps=self.suite.fps,
            features=features,
            root=build_root,
            robot_type=self.suite.robot_type,
            use_videos=cfg.video,
        )
        self.episodes: list[dict] = []

    def append(self, episode: staging.StagedEpisode) -> None:
        scene = {SCENE_SEED_KEY: np.array([episode.scene_seed], dtype=np.int64)}
        if self.suite.scene_cells:
            scene[SCENE_OBJECT_CELL_KEY] = np.array([episode.object_cell], dtype=np.int64)
            scene[SCENE_TARGET_CELL_KEY] = np.array([episode.target_cell], dtype=np.int64)
        for t in range(episode.num_frames):
            self.dataset.add_frame(
                {
                    self.image_key: episode.images[t],
                    STATE_KEY: episode.state[t],
                    ENV_STATE_KEY: episode.environment_state[t],
                    ACTION_KEY: episode.action[t],
                    **scene,
                    "task": self.task_description,
                }
            )
        with warnings.catch_warnings():
            # `datasets` warns when it casts LeRobot's shape-(1,) arrays to scalar columns; harmless.
            warnings.filterwarnings("ignore", "Conversion of an array with ndim > 0", DeprecationWarning)
            self.dataset.save_episode()
        self.episodes.append(
            {
                "episode_index": len(self.episodes),
                "attempt": episode.attempt,
                "scene_seed": episode.scene_seed,
                "object_cell": episode.object_cell,
                "target_cell": episode.target_cell,
            }
        )


def sort_stats(build_root: Path) -> None:
    """Rewrite LeRobot's `meta/stats.json` with sorted keys (it lists features in hash-seed order)."""

    def sort(obj):
        return {key: sort(obj[key]) for key in sorted(obj)} if isinstance(obj, dict) else obj

    path = build_root / STATS_PATH
    write_json(sort(staging.read_json(path)), path)


@contextlib.contextmanager
def quiet_datasets() -> Iterator[None]:
    """Silence the `datasets` progress bars LeRobot triggers on every `save_episode`."""
    was_enabled = datasets.is_progress_bar_enabled()
    datasets.disable_progress_bars()
    try:
        yield
    finally:
        if was_enabled:
            datasets.enable_progress_bars()


def embed_images_in_batches(dataset: datasets.Dataset) -> datasets.Dataset:
    """LeRobot's `embed_images` (`lerobot.datasets.utils`), the same table, with `datasets`'
    `embed_table_storage` run on `EMBED_BATCH_ROWS` rows at a time instead of row by row: LeRobot's per-row
    map took 2.4 ms a frame, more than half of `save_episode`."""
    format = dataset.format
    dataset = dataset.with_format("arrow")
    dataset = dataset.map(embed_table_storage, batched=True, batch_size=EMBED_BATCH_ROWS)
    return dataset.with_format(**format)


@contextlib.contextmanager
def batched_image_embedding() -> Iterator[None]:
    """`LeRobotDataset.save_episode` in this process embeds image bytes with `embed_images_in_batches` while
    the context lasts (LeRobot's own function is restored after; other processes are untouched)."""
    original = lerobot_dataset_module.embed_images
    lerobot_dataset_module.embed_images = embed_images_in_batches
    try:
        yield
    finally:
        lerobot_dataset_module.embed_images = original
