"""Check that a finished demonstration dataset holds what its metadata says, before calling it complete.

Counts are read from the files themselves (the data parquet's `episode_index` column, LeRobot's episode
index, `meta/info.json` and the collector's `meta/ivmc_collection.json`) and must all agree with the
number of episodes asked for; `LeRobotDataset` fails on a dataset whose data and metadata disagree.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from lerobot_ivmc.datasets.staging import COLLECTION_INFO_PATH


def _column(files: list[Path], column: str, root: Path, problems: list[str]) -> np.ndarray:
    """One integer column of parquet files, concatenated; unreadable files are added to `problems`."""
    parts = []
    for path in files:
        try:
            parts.append(pq.read_table(path, columns=[column]).column(column).to_numpy())
        except Exception as error:  # noqa: BLE001 - pyarrow raises several types for damaged files
            problems.append(f"{path.relative_to(root)} is unreadable ({type(error).__name__}: {error})")
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)


def dataset_problems(root: Path, num_episodes: int, episode_steps: int) -> list[str]:
    """What is wrong with the finished dataset in `root`; empty if it is whole.

    Args:
        root: the dataset folder.
        num_episodes: the episodes it must hold.
        episode_steps: the frames of each episode.

    Returns:
        One human-readable line per disagreement.
    """
    root = Path(root)
    frames = num_episodes * episode_steps
    problems: list[str] = []
    try:
        info = json.loads((root / "meta" / "info.json").read_text())
        collection = json.loads((root / COLLECTION_INFO_PATH).read_text())
    except (OSError, ValueError) as error:
        return [f"its metadata is unreadable ({error})"]
    for key, want in (("total_episodes", num_episodes), ("total_frames", frames)):
        if info.get(key) != want:
            problems.append(f"meta/info.json has {key}={info.get(key)}, expected {want}")
    if collection.get("num_episodes") != num_episodes or len(collection.get("episodes", [])) != num_episodes:
        problems.append(f"{COLLECTION_INFO_PATH} does not list {num_episodes} episodes")

    data_files = sorted((root / "data").glob("*/*.parquet"))
    episode_of_frame = _column(data_files, "episode_index", root, problems)
    if len(episode_of_frame) != frames:
        problems.append(f"the data parquet holds {len(episode_of_frame)} frames, expected {frames}")
    counts = np.bincount(episode_of_frame.astype(np.int64), minlength=num_episodes)
    wrong = np.flatnonzero(counts != episode_steps).tolist()
    if wrong:
        problems.append(f"episodes {wrong[:10]} do not have {episode_steps} frames each in the data parquet")

    episode_files = sorted((root / "meta" / "episodes").glob("*/*.parquet"))
    indexed = _column(episode_files, "episode_index", root, problems)
    if sorted(indexed.tolist()) != list(range(num_episodes)):
        problems.append(f"meta/episodes indexes {len(indexed)} episodes, expected 0..{num_episodes - 1}")
    lengths = _column(episode_files, "length", root, problems)
    if int(lengths.sum()) != frames:
        problems.append(f"meta/episodes gives {int(lengths.sum())} frames in all, expected {frames}")

    for key, feature in info.get("features", {}).items():
        if feature.get("dtype") == "video" and not any((root / "videos" / key).glob("*/*.mp4")):
            problems.append(f"the videos of {key} are missing")
    return problems
