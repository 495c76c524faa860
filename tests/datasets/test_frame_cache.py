"""FrameCache: the same items as LeRobotDataset, windows and padding included, from memory."""

from pathlib import Path

import pytest
import torch
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from lerobot_ivmc.datasets import ACTION_KEY, DEMO_FPS, ENV_STATE_KEY, IMAGE_KEY, STATE_KEY
from lerobot_ivmc.datasets.collect import CollectConfig, collect_demos
from lerobot_ivmc.datasets.frame_cache import FrameCache

REPO_ID = "local/ivmc_push_cache"
# Four frames of history (VMC's K = 4) on the observations; past and future actions to pad both ends.
DELTA_TIMESTAMPS = {
    key: [k / DEMO_FPS for k in range(-3, 1)] for key in (IMAGE_KEY, STATE_KEY, ENV_STATE_KEY)
} | {ACTION_KEY: [k / DEMO_FPS for k in (-1, 0, 2)]}


@pytest.fixture(scope="module")
def demo_root(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("cache") / "ivmc_push"
    collect_demos(
        CollectConfig(task="push", num_episodes=3, image_size=32, num_workers=0, root=root, progress=False)
    )
    return root


def assert_same_item(cached: dict, reference: dict) -> None:
    assert cached.keys() == reference.keys()
    for key, value in reference.items():
        if isinstance(value, torch.Tensor):
            assert cached[key].dtype == value.dtype, key
            torch.testing.assert_close(cached[key], value, rtol=0, atol=0, msg=key)
        else:
            assert cached[key] == value, key


@pytest.mark.parametrize("episodes", [None, [0, 2]], ids=["all", "subset"])
def test_every_item_equals_lerobot_dataset(demo_root: Path, episodes: list[int] | None) -> None:
    reference = LeRobotDataset(REPO_ID, root=demo_root, episodes=episodes, delta_timestamps=DELTA_TIMESTAMPS)
    cache = FrameCache(
        LeRobotDataset(REPO_ID, root=demo_root, episodes=episodes, delta_timestamps=DELTA_TIMESTAMPS)
    )
    assert len(cache) == len(reference) == (3 if episodes is None else 2) * 100
    for idx in range(len(reference)):
        assert_same_item(cache[idx], reference[idx])
    first = cache[0]
    assert first[IMAGE_KEY].shape == (4, 3, 32, 32)
    assert first[f"{STATE_KEY}_is_pad"].tolist() == [True, True, True, False]
    assert cache[len(cache) - 1][f"{ACTION_KEY}_is_pad"].tolist() == [False, False, True]


def test_forwards_what_lerobot_train_reads(demo_root: Path) -> None:
    dataset = LeRobotDataset(REPO_ID, root=demo_root, delta_timestamps=DELTA_TIMESTAMPS)
    cache = FrameCache(dataset)
    assert cache.meta is dataset.meta
    assert (cache.num_frames, cache.num_episodes) == (300, 3)
    batch = next(iter(torch.utils.data.DataLoader(cache, batch_size=8, shuffle=True)))
    assert batch[IMAGE_KEY].shape == (8, 4, 3, 32, 32)


def test_video_datasets_are_refused_with_what_to_do(tmp_path: Path) -> None:
    root = tmp_path / "ivmc_push_video"
    collect_demos(
        CollectConfig(
            task="push", num_episodes=1, image_size=32, num_workers=0, root=root, video=True, progress=False
        )
    )
    with pytest.raises(ValueError, match="video"):
        FrameCache(LeRobotDataset(REPO_ID, root=root, video_backend="pyav"))
