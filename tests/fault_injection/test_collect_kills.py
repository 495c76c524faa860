"""Fault injection: a collector SIGKILLed at each stage, then rerun, gives exactly the uninterrupted dataset.

Each case kills `lerobot-ivmc-collect` at one point (`kill_at.POINTS`), checks that nothing was published
half-way, reruns the same command and compares every file of the result, byte for byte, with a collection
that was never interrupted in the same root.
"""

import subprocess
import sys
from pathlib import Path

import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.collect import CollectConfig, collect_demos
from lerobot_ivmc.envs import DEMO_EPISODE_STEPS

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

KILL_AT = Path(__file__).with_name("kill_at.py")
N = 3
POINTS = ["staged", "saving_episode", "finalizing", "before_publish", "publishing", "cleaning_up"]


def _args(root: Path) -> list[str]:
    return [
        "--env.task=push", f"--dataset.num_episodes={N}", f"--dataset.root={root}", "--env.image_size=32",
        "--num_workers=0", "--seed=3", "--progress=false",
    ]  # fmt: skip


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> tuple[Path, dict[str, bytes]]:
    """The root every case collects into, and the files of an uninterrupted collection there."""
    root = tmp_path_factory.mktemp("fault_injection") / "ivmc_push"
    collect_demos(CollectConfig(task="push", num_episodes=N, root=root, image_size=32, num_workers=0, seed=3,
                                progress=False))  # fmt: skip
    files = _files(root)
    staging.remove_tree(root)
    return root, files


@pytest.mark.parametrize("point", POINTS)
def test_killed_collection_reruns_to_the_uninterrupted_dataset(reference, point):
    root, expected = reference
    try:
        killed = subprocess.run(
            [sys.executable, str(KILL_AT), point, *_args(root)], capture_output=True, text=True, timeout=300
        )
        assert killed.returncode == -9, killed.stdout + killed.stderr  # SIGKILL reached the point
        if point not in ("publishing", "cleaning_up"):
            assert not (root / "meta").exists()  # nothing half-published
        rerun = subprocess.run(
            [sys.executable, "-m", "lerobot_ivmc.scripts.lerobot_ivmc_collect", *_args(root)],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert rerun.returncode == 0, rerun.stdout + rerun.stderr
        dataset = LeRobotDataset("local/ivmc_push", root=root)
        assert dataset.num_episodes == N and len(dataset.hf_dataset) == N * DEMO_EPISODE_STEPS
        assert sorted(dataset.hf_dataset.unique("episode_index")) == list(range(N))
        files = _files(root)
        assert files.keys() == expected.keys()
        assert [name for name in files if files[name] != expected[name]] == []
    finally:
        staging.remove_tree(root)
