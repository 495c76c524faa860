"""Durable on-disk state of a collection in progress, so that a killed collection resumes exactly.

LeRobot's v3.0 writer is not crash-safe: it keeps one `pyarrow.ParquetWriter` open per data and episode
file and only `finalize()` writes their footers (a killed writer leaves unreadable parquet files), while
`meta/info.json` is rewritten after every episode and the episode index is buffered 10 episodes at a time,
so after a SIGKILL the three disagree. Rather than repairing those files, the collector keeps the truth in
a staging folder inside the dataset root and treats the LeRobot dataset as a deterministic product of it::

    <root>/.ivmc_collect/spec.json                     what is being collected (task, split, seed, features)
    <root>/.ivmc_collect/episodes/attempt_0000042.npz  one successful expert episode, written atomically
    <root>/.ivmc_collect/episodes/attempt_0000043.failed   an attempt the expert failed (skipped for good)
    <root>/.ivmc_collect/build/                        the LeRobotDataset being assembled (disposable)
    <root>/.ivmc_collect/publish.json                  the build is final; these folders move into <root>

Every staging file is written to a temporary name, fsynced and renamed, so it is either complete or absent.
On restart the build folder is discarded and reassembled from the staged episodes; when all N episodes are
assembled, finalized and verified, `publish.json` names the dataset's folders, they are moved into `<root>`
and the staging folder is removed. A publish cut short is finished by the next run from `publish.json`, so
a folder of `<root>` is only ever replaced or deleted when the collector itself put it there.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import zipfile
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_ivmc.atomic_files import atomic_write

WORK_DIR = ".ivmc_collect"
# The staging folder is renamed to this once the dataset is published, then deleted.
TRASH_DIR = ".ivmc_collect.trash"
SPEC_FILE = "spec.json"
EPISODES_DIR = "episodes"
BUILD_DIR = "build"
# Written once the build is final: the dataset folders it moves into the root (see `publish`).
PUBLISH_FILE = "publish.json"
# Written into the finished dataset's meta/ folder (and pushed with it): task, split, seeds, attempts.
COLLECTION_INFO_PATH = "meta/ivmc_collection.json"
# Folders of a LeRobot dataset root (`images/` holds LeRobot's temporary PNGs).
DATASET_DIRS = ("data", "videos", "meta")
_ATTEMPT_RE = re.compile(r"^attempt_(\d{7})\.(npz|failed)$")


class CollectionError(RuntimeError):
    """A collection root the collector cannot use as it is; the message says what to do."""


@dataclass
class StagedEpisode:
    """One successful expert episode of T steps, as recorded.

    Args:
        attempt: the attempt index it came from (its scene seed is a function of the base seed and this).
        scene_seed: the seed passed to `env.reset(seed=...)`.
        object_cell: object spawn cell of the scene.
        target_cell: target spawn cell of the scene.
        images: (T, H, W, 3) uint8 front camera frames.
        state: (T, 9) float32 joint positions.
        environment_state: (T, 6) float32 end-effector and object positions.
        action: (T, 4) float32 expert actions, action t chosen from observation t.
    """

    attempt: int
    scene_seed: int
    object_cell: int
    target_cell: int
    images: np.ndarray
    state: np.ndarray
    environment_state: np.ndarray
    action: np.ndarray

    @property
    def num_frames(self) -> int:
        return len(self.action)

    @classmethod
    def from_steps(
        cls,
        attempt: int,
        scene_seed: int,
        steps: tuple[list, list, list, list],
        object_cell: int = -1,
        target_cell: int = -1,
    ) -> StagedEpisode:
        """An episode from its per-step (images, states, environment states, actions) lists; scenes without
        spawn cells (MetaWorld's) keep -1."""
        images, states, env_states, actions = steps
        return cls(
            attempt=attempt,
            scene_seed=scene_seed,
            object_cell=object_cell,
            target_cell=target_cell,
            images=np.stack(images).astype(np.uint8),
            state=np.stack(states).astype(np.float32),
            environment_state=np.stack(env_states).astype(np.float32),
            action=np.stack(actions).astype(np.float32),
        )


def attempt_path(episodes_dir: Path, attempt: int, suffix: str) -> Path:
    return episodes_dir / f"attempt_{attempt:07d}.{suffix}"


def write_episode(episodes_dir: Path, episode: StagedEpisode) -> Path:
    """Stage a successful episode atomically; returns its path."""
    path = attempt_path(episodes_dir, episode.attempt, "npz")
    arrays = {f.name: np.asarray(getattr(episode, f.name)) for f in fields(episode)}
    atomic_write(path, lambda file: np.savez_compressed(file, **arrays))
    return path


def write_failure(episodes_dir: Path, attempt: int) -> None:
    """Mark an attempt the expert failed, so a resumed collection skips it as the first run did."""
    atomic_write(attempt_path(episodes_dir, attempt, "failed"), lambda file: None)


def read_episode(path: Path) -> StagedEpisode:
    """Load a staged episode.

    Raises:
        CollectionError: the file is damaged (staged files are written atomically, so only a failing disk
            or another program can damage one); the message names it and how to drop it.
    """
    try:
        with np.load(path) as data:
            values = {f.name: data[f.name] for f in fields(StagedEpisode)}
        for name in ("attempt", "scene_seed", "object_cell", "target_cell"):
            values[name] = int(values[name])
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as error:
        raise CollectionError(
            f"The staged episode {path} is damaged ({type(error).__name__}: {error}). Delete it "
            f"(rm '{path}') and rerun the same command: its attempt is recorded again."
        ) from error
    return StagedEpisode(**values)


def scan_attempts(episodes_dir: Path) -> tuple[dict[int, Path], set[int]]:
    """Staged attempts: ({attempt: episode path} of successes, {attempts} of failures).

    Temporary files left by a killed writer are deleted; they are the only incomplete files there can be.
    """
    successes: dict[int, Path] = {}
    failures: set[int] = set()
    for path in episodes_dir.iterdir():
        match = _ATTEMPT_RE.match(path.name)
        if match is None:
            if path.name.endswith(".tmp"):
                path.unlink()
            continue
        attempt = int(match.group(1))
        if match.group(2) == "npz":
            successes[attempt] = path
        else:
            failures.add(attempt)
    return successes, failures


def write_json(path: Path, obj: Any) -> None:
    """Write JSON atomically."""
    atomic_write(path, lambda file: file.write(json.dumps(obj, indent=2, sort_keys=True).encode()))


def read_json(path: Path) -> Any:
    return json.loads(path.read_text())


def normalise(obj: Any) -> Any:
    """A JSON round trip (tuples become lists), so specs compare equal to what was read back from disk."""
    return json.loads(json.dumps(obj))


def spec_differences(saved: dict, wanted: dict) -> list[str]:
    """Human-readable differences between a stored collection spec and the one asked for."""
    saved, wanted = normalise(saved), normalise(wanted)
    diffs = []
    for key in sorted(set(saved) | set(wanted)):
        if key == "features" and key in saved and key in wanted:
            for name in sorted(set(saved[key]) | set(wanted[key])):
                stored, asked = saved[key].get(name), wanted[key].get(name)
                if stored != asked:
                    diffs.append(f"feature {name!r}: stored {stored}, asked {asked}")
        elif saved.get(key) != wanted.get(key):
            diffs.append(f"{key}: stored {saved.get(key)!r}, asked {wanted.get(key)!r}")
    return diffs


def remove_tree(path: Path) -> None:
    """Delete a folder (or file) if it exists."""
    if path.is_dir():
        shutil.rmtree(path)
    elif path.exists():
        path.unlink()


def publish(work_dir: Path, root: Path) -> None:
    """Move the finalized, verified build into `root` and drop the staging folder.

    `publish.json` records the folders to move before the first one moves, so a run killed during the moves
    is finished by `finish_publish` on the next run instead of rebuilt: no folder of `root` that the
    collector did not move there is ever replaced.
    """
    build = work_dir / BUILD_DIR
    write_json(work_dir / PUBLISH_FILE, [name for name in DATASET_DIRS if (build / name).exists()])
    finish_publish(work_dir, root)


def publish_blockers(work_dir: Path, root: Path) -> list[Path]:
    """Folders of `root` that a publish would have to replace: not moved there by the collector."""
    build = work_dir / BUILD_DIR
    names = read_json(work_dir / PUBLISH_FILE)
    return [root / name for name in names if (build / name).exists() and (root / name).exists()]


def finish_publish(work_dir: Path, root: Path) -> None:
    """Move the folders `publish.json` names that are still in the build (meta/ last: its info.json marks
    a dataset), then drop the staging folder. Each step can be repeated after a kill."""
    blockers = publish_blockers(work_dir, root)
    if blockers:
        raise CollectionError(f"Cannot publish into {root}: {', '.join(map(str, blockers))} already exist.")
    build = work_dir / BUILD_DIR
    for name in read_json(work_dir / PUBLISH_FILE):
        if (build / name).exists():
            os.replace(build / name, root / name)
    trash = root / TRASH_DIR
    os.replace(work_dir, trash)
    shutil.rmtree(trash)
