"""`lerobot-ivmc-train`: `lerobot-train` with the dataset's frames cached in memory.

Same flags, same training loop, checkpoints and logs as `lerobot-train` (it runs LeRobot's own
`lerobot_train.main`); the only change is that the dataset `lerobot-train` builds is wrapped in a
`FrameCache`, so K-frame windows of a small image dataset cost tensor gathers instead of Hugging Face
`datasets` queries. Use it for image (not video) datasets that fit in memory (a 64x64 frame takes 12 KiB:
100,000 frames take 1.2 GiB).

Example:
    lerobot-ivmc-train --policy.type=bvmc --policy.device=cpu --dataset.repo_id=local/ivmc_pick_place \\
        --dataset.root=data/ivmc_pick_place --batch_size=32 --steps=40000 --num_workers=0
"""

from __future__ import annotations

from lerobot.datasets import factory
from lerobot.scripts import lerobot_train

from lerobot_ivmc.datasets.frame_cache import FrameCache


def make_cached_dataset(cfg) -> FrameCache:
    """LeRobot's `make_dataset(cfg)`, its frames decoded into memory."""
    if cfg.dataset.streaming:
        raise ValueError("lerobot-ivmc-train caches a local dataset; drop --dataset.streaming=true.")
    return FrameCache(factory.make_dataset(cfg))


def main() -> None:
    # `lerobot_train` imported `make_dataset` into its own namespace; point that name at the cached version
    # for this process only.
    lerobot_train.make_dataset = make_cached_dataset
    lerobot_train.main()


if __name__ == "__main__":
    main()
