"""An in-memory frame cache over a LeRobotDataset, for fast K-frame windows on small image datasets.

`LeRobotDataset.__getitem__` queries its Hugging Face dataset once per delta-timestamp key, and because
LeRobot formats rows with a custom transform, every query fetches and decodes *all* columns of the rows it
asks for: a 4-frame window with three windowed keys decodes 13 PNG images to use 4, and spends the rest in
`datasets` bookkeeping. `FrameCache` decodes every column once (LeRobot's own `hf_dataset` slices, so the
values are LeRobot's bit for bit), keeps images as uint8, and answers `__getitem__` with tensor gathers.
Everything else (metadata, stats, episodes, delta indices, padding, image transforms) is the wrapped
dataset's.
"""

from __future__ import annotations

import logging
from typing import Any

import torch
from lerobot.datasets.lerobot_dataset import LeRobotDataset
from torch import Tensor

# Rows decoded per slice of the Hugging Face dataset while filling the cache.
FILL_CHUNK = 2_000


class FrameCache(torch.utils.data.Dataset):
    """A LeRobotDataset with every frame decoded into memory; items are identical to the dataset's.

    Attribute access falls through to the wrapped dataset, so it drops into `lerobot-train` (which reads
    `meta`, `num_frames`, `num_episodes`, `episodes`) in the dataset's place.

    Args:
        dataset: an image-based (not video) LeRobotDataset, with its delta timestamps already set.
        absolute_indices: items are asked for by the dataset's absolute frame index, as LeRobot's
            `EpisodeAwareSampler` yields them, instead of by position (the two differ on an episode subset,
            where `LeRobotDataset` itself would read the wrong rows).
    """

    def __init__(self, dataset: LeRobotDataset, absolute_indices: bool = False):
        if dataset.meta.video_keys:
            raise ValueError(
                f"FrameCache holds decoded image frames; {dataset.repo_id} stores {dataset.meta.video_keys} "
                "as video. Train on it with plain `lerobot-train`, or re-collect it without `--video`."
            )
        self.dataset = dataset
        self.absolute_indices = absolute_indices
        self.image_keys = set(dataset.meta.image_keys)
        self.columns = self._decode_all_columns()

    def _decode_all_columns(self) -> dict[str, Tensor | list]:
        self.dataset._ensure_hf_dataset_loaded()
        hf_dataset = self.dataset.hf_dataset
        n = len(hf_dataset)
        parts: dict[str, list] = {}
        for start in range(0, n, FILL_CHUNK):
            rows = hf_dataset[start : min(start + FILL_CHUNK, n)]
            for key, values in rows.items():
                if key in self.image_keys:
                    # ToTensor gave v / 255 in float32; multiplying back by 255 is exact for v in 0..255.
                    values = [torch.round(v * 255).to(torch.uint8) for v in values]
                parts.setdefault(key, []).extend(values)
        columns = {
            key: torch.stack(values) if isinstance(values[0], Tensor) else values
            for key, values in parts.items()
        }
        image_bytes = sum(columns[key].numel() for key in self.image_keys)
        logging.info(f"FrameCache: {n} frames decoded into memory ({image_bytes / 2**30:.2f} GiB of images).")
        return columns

    def _column(self, key: str, rows: int | list[int]) -> Any:
        values = self.columns[key]
        if not isinstance(values, Tensor):
            return values[rows] if isinstance(rows, int) else [values[r] for r in rows]
        picked = values[rows]
        return picked.float() / 255 if key in self.image_keys else picked

    def __len__(self) -> int:
        return len(self.dataset)

    def __getattr__(self, name: str) -> Any:
        if name == "dataset":  # not yet set (unpickling): avoid recursing into __getattr__
            raise AttributeError(name)
        return getattr(self.dataset, name)

    def __getitem__(self, idx: int) -> dict:
        """The item `LeRobotDataset.__getitem__(idx)` returns (image datasets), from memory."""
        ds = self.dataset
        if self.absolute_indices and ds._absolute_to_relative_idx is not None:
            idx = ds._absolute_to_relative_idx[idx]
        item = {key: self._column(key, idx) for key in self.columns}
        if ds.delta_indices is not None:
            query_indices, padding = ds._get_query_indices(item["index"].item(), item["episode_index"].item())
            to_relative = ds._absolute_to_relative_idx
            for key, absolute in query_indices.items():
                rows = absolute if to_relative is None else [to_relative[i] for i in absolute]
                item[key] = self._column(key, rows)
            item.update(padding)
        if ds.image_transforms is not None:
            for cam in ds.meta.camera_keys:
                item[cam] = ds.image_transforms(item[cam])
        item["task"] = ds.meta.tasks.iloc[item["task_index"].item()].name
        if "subtask_index" in ds.features and ds.meta.subtasks is not None:
            item["subtask"] = ds.meta.subtasks.iloc[item["subtask_index"].item()].name
        return item
