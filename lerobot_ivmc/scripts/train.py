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
default gets that checkpoint's training mode before its samples are built (plain `lerobot-train` builds
them from today's defaults: resume such runs with `lerobot-ivmc-train`). Use it for image (not video)
datasets that fit in memory (a 64x64 frame takes 12 KiB: 100,000 frames take 1.2 GiB).

Example (the policies' defaults train on whole demos: 2 a batch, 10,000 steps, README):
    lerobot-ivmc-train --policy.type=bvmc --policy.device=cpu --dataset.repo_id=local/ivmc_pick_place \\
        --dataset.root=data/ivmc_pick_place --batch_size=2 --steps=10000 --num_workers=0
"""

from __future__ import annotations

import logging
from pathlib import Path

from lerobot.datasets import factory
from lerobot.scripts import lerobot_train

from lerobot_ivmc.datasets.collection_record import dataset_render_style, dataset_task
from lerobot_ivmc.datasets.frame_cache import FrameCache
from lerobot_ivmc.policies.legacy_configs import command_line_policy_fields, complete_legacy_config
from lerobot_ivmc.scripts.errors import run_cli

logger = logging.getLogger(__name__)


def make_cached_dataset(cfg) -> FrameCache:
    """LeRobot's `make_dataset(cfg)`, its frames decoded into memory; fills N from the frames trained on."""
    if cfg.dataset.streaming:
        raise ValueError("lerobot-ivmc-train caches a local dataset; drop --dataset.streaming=true.")
    if cfg.dataset.root is not None and not (Path(cfg.dataset.root) / "meta" / "info.json").is_file():
        raise FileNotFoundError(
            f"--dataset.root={cfg.dataset.root} holds no LeRobot dataset (no meta/info.json): pass the "
            "folder lerobot-ivmc-collect wrote."
        )
    if cfg.steps <= 0:
        raise ValueError(f"--steps must be positive, got {cfg.steps}.")
    # Resuming (or fine-tuning) a checkpoint saved before sequence training became the default: its samples
    # are those it was trained with, so its config is completed before the dataset is built from it.
    pretrained = getattr(cfg.policy, "pretrained_path", None)
    if pretrained is not None and hasattr(cfg.policy, "training_mode"):
        changed = complete_legacy_config(cfg.policy, pretrained)
        if changed:
            values = ", ".join(f"{name}={getattr(cfg.policy, name)}" for name in changed)
            logger.warning(
                "%s predates sequence training as the default: training on with %s", pretrained, values
            )
    # Sequence training makes lerobot-train sample with its EpisodeAwareSampler, which yields absolute frame
    # indices (`drop_n_last_frames` on the policy config).
    dataset = FrameCache(
        factory.make_dataset(cfg), absolute_indices=hasattr(cfg.policy, "drop_n_last_frames")
    )
    if hasattr(cfg.policy, "dataset_size") and cfg.policy.dataset_size is None:
        cfg.policy.dataset_size = dataset.num_frames
    if hasattr(cfg.policy, "render_style"):
        record_render_style(cfg.policy, dataset_render_style(dataset.root))
    if hasattr(cfg.policy, "trained_task"):
        cfg.policy.trained_task = dataset_task(dataset.root)
    return dataset


def record_render_style(policy_cfg, data_style: str | None) -> None:
    """Set the policy's `render_style` to the dataset's; refuse a chosen or resumed one that differs."""
    if data_style is None or policy_cfg.render_style == data_style:
        return
    chosen = "render_style" in command_line_policy_fields()
    if chosen or getattr(policy_cfg, "pretrained_path", None) is not None:
        how = "--policy.render_style" if chosen else f"the checkpoint {policy_cfg.pretrained_path}"
        raise ValueError(
            f"The dataset's frames are drawn in the {data_style!r} render style, but {how} says "
            f"{policy_cfg.render_style!r}: train on a dataset collected with --env.render_style="
            f"{policy_cfg.render_style}, or drop --policy.render_style."
        )
    policy_cfg.render_style = data_style


def main() -> None:
    # `lerobot_train` imported `make_dataset` into its own namespace; point that name at the cached version
    # for this process only.
    lerobot_train.make_dataset = make_cached_dataset
    run_cli(lerobot_train.main)


if __name__ == "__main__":
    main()
