"""`lerobot-ivmc-train`: `lerobot-train` with the dataset's frames cached in memory.

Same flags, same training loop, checkpoints and logs as `lerobot-train` (it runs LeRobot's own
`lerobot_train.main`); the only change is that the dataset `lerobot-train` builds is wrapped in a
`FrameCache`, so K-frame windows of a small image dataset cost tensor gathers instead of Hugging Face
`datasets` queries. It also sets N of Bayesian VMC's concrete dropout regularisers
(`--policy.dataset_size`, when not given) to the frames actually trained on, so a `--dataset.episodes`
subset gets its own N (plain `lerobot-train` only sees the whole dataset's metadata: pass
`--policy.dataset_size` there). The policy records the render style of the frames it trains on
(`--policy.render_style`), taken from the dataset's collection record; a `--policy.render_style` that
contradicts the record is refused. A run resumed from a checkpoint saved before sequence training became the
default gets that checkpoint's training mode before its samples are built (its config is completed as
LeRobot loads it: `lerobot_ivmc.policies.legacy_configs`). Use it for image (not video)
datasets that fit in memory (a 64x64 frame takes 12 KiB: 100,000 frames take 1.2 GiB).

Example (the policies' defaults train on whole demos: 2 a batch, 10,000 steps, README):
    lerobot-ivmc-train --policy.type=bvmc --policy.device=cpu --dataset.repo_id=local/ivmc_pick_place \\
        --dataset.root=data/ivmc_pick_place --batch_size=2 --steps=10000 --num_workers=0
"""

from __future__ import annotations

from lerobot.scripts import lerobot_train

from lerobot_ivmc.cli import run_cli
from lerobot_ivmc.datasets.training_dataset import make_cached_dataset


def main() -> None:
    # `lerobot_train` imported `make_dataset` into its own namespace; point that name at the cached version
    # for this process only.
    lerobot_train.make_dataset = make_cached_dataset
    run_cli(lerobot_train.main)


if __name__ == "__main__":
    main()
