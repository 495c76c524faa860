"""Run `lerobot-ivmc-collect` in this process and SIGKILL it at a named point (a fault-injection helper).

    python tests/fault_injection/kill_at.py <point> <lerobot-ivmc-collect arguments>

SIGKILL is what an out-of-memory killer or a pulled plug does: no handler, no cleanup, no flush. Record
with ``--num_workers=0`` so every point is reached in this process.
"""

from __future__ import annotations

import os
import shutil
import signal
import sys

from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata

from lerobot_ivmc.datasets import expert_attempts, staging
from lerobot_ivmc.scripts import lerobot_ivmc_collect


def _die() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def _after(owner: object, name: str, when=lambda *args, **kwargs: True) -> None:
    """Kill the process right after `owner.name(...)` returns, the first time `when(...)` holds."""
    original = getattr(owner, name)

    def wrapper(*args, **kwargs):
        result = original(*args, **kwargs)
        if when(*args, **kwargs):
            _die()
        return result

    setattr(owner, name, wrapper)


def _before(owner: object, name: str, when=lambda *args, **kwargs: True) -> None:
    """Kill the process as `owner.name(...)` is called, the first time `when(...)` holds."""
    original = getattr(owner, name)

    def wrapper(*args, **kwargs):
        if when(*args, **kwargs):
            _die()
        return original(*args, **kwargs)

    setattr(owner, name, wrapper)


POINTS = {
    # Attempt 1 staged, not assembled yet.
    "staged": lambda: _after(expert_attempts.Recorder, "record", lambda self, attempt: attempt == 1),
    # Episode 0 written to the build's data parquet, whose writer (and footer) is still open.
    "saving_episode": lambda: _before(
        LeRobotDataset, "save_episode", lambda self: self.meta.total_episodes == 1
    ),
    # Inside LeRobot's finalize: data parquet closed, episode index not.
    "finalizing": lambda: _before(LeRobotDatasetMetadata, "_close_writer"),
    # Build finalized and checked, nothing published.
    "before_publish": lambda: _before(staging, "publish"),
    # data/ moved into the root, meta/ still in the build.
    "publishing": lambda: _after(os, "replace", lambda src, dst, **kw: os.path.basename(dst) == "data"),
    # Everything moved, the staging folder renamed to the trash, not deleted.
    "cleaning_up": lambda: _before(
        shutil, "rmtree", lambda path, *a, **kw: str(path).endswith(staging.TRASH_DIR)
    ),
}


if __name__ == "__main__":
    point, *argv = sys.argv[1:]
    POINTS[point]()
    sys.exit(lerobot_ivmc_collect.main(argv))
