"""The dataset `lerobot-ivmc-train` (`scripts/lerobot_ivmc_train.py`) hands LeRobot's training loop: LeRobot's
own `make_dataset`, its frames cached in memory (`FrameCache`), with the policy fields a training takes from
its dataset filled in (concrete dropout's N, the render style, the training task, where the auxiliary
targets sit in the environment state) and checked."""

from __future__ import annotations

from pathlib import Path

from lerobot.datasets import factory

from lerobot_ivmc.datasets.collection_record import collection_spec, spec_render_style
from lerobot_ivmc.datasets.demo_suites import EDITED_STATE, suite_of
from lerobot_ivmc.datasets.frame_cache import FrameCache
from lerobot_ivmc.policies.legacy_configs import command_line_policy_fields, complete_legacy_config


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
    # are those it was trained with. Its config was completed as LeRobot named the checkpoint (VMCConfig's
    # `__setattr__`); checked again here, before the dataset is built from it, whatever set the path.
    pretrained = getattr(cfg.policy, "pretrained_path", None)
    if pretrained is not None and hasattr(cfg.policy, "training_mode"):
        complete_legacy_config(cfg.policy, pretrained)
    # Sequence training makes lerobot-train sample with its EpisodeAwareSampler, which yields absolute frame
    # indices (`drop_n_last_frames` on the policy config).
    dataset = FrameCache(
        factory.make_dataset(cfg), absolute_indices=hasattr(cfg.policy, "drop_n_last_frames")
    )
    if hasattr(cfg.policy, "dataset_size") and cfg.policy.dataset_size is None:
        cfg.policy.dataset_size = dataset.num_frames
    spec = collection_spec(dataset.root)  # None: a dataset lerobot-ivmc-collect did not make
    if hasattr(cfg.policy, "render_style"):
        record_render_style(cfg.policy, None if spec is None else spec_render_style(spec))
    check_environment_state(cfg.policy, spec, dataset.root)
    task = None if spec is None else spec["task"]
    if hasattr(cfg.policy, "trained_task"):
        cfg.policy.trained_task = task
    if getattr(cfg.policy, "aux_state_indices", 0) is None and task is not None:
        indices = suite_of(task).aux_state_indices  # where the suite's state keeps the EE and the object
        cfg.policy.aux_state_indices = None if indices is None else list(indices)
    return dataset


def check_environment_state(policy_cfg, spec: dict | None, root: Path) -> None:
    """Refuse training the auxiliary heads (vmc, bvmc) on the demos in `root` (collection spec `spec`) whose
    environment state MetaWorld's scripted policy edited while they were recorded: the heads would learn its
    shifted object position."""
    if spec is None or not hasattr(policy_cfg, "aux_state_indices"):
        return
    if suite_of(spec["task"]).recorded_with_edited_state(spec):
        raise ValueError(
            f"{root} holds {EDITED_STATE}; the auxiliary heads would learn that shift. Collect the demos "
            "again with this version of lerobot-ivmc-collect, into a new --dataset.root."
        )


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
