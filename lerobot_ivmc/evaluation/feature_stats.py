"""The statistics a policy's normaliser holds for an observation feature, to read it back in its units."""

from __future__ import annotations

import torch
from lerobot.utils.constants import OBS_ENV_STATE


def env_state_stats(preprocessor) -> tuple[torch.Tensor, torch.Tensor]:
    """(mean, std) of `observation.environment_state` from the policy's normaliser step."""
    return feature_stats(preprocessor, OBS_ENV_STATE)


def feature_stats(preprocessor, key: str) -> tuple[torch.Tensor, torch.Tensor]:
    """(mean, std) of the observation feature `key` from the policy's normaliser step."""
    for step in preprocessor.steps:
        stats = getattr(step, "_tensor_stats", None) or {}
        if key in stats:
            mean = stats[key]["mean"].float().cpu()
            return mean, stats[key]["std"].float().cpu() + step.eps
    raise ValueError(
        f"The policy's preprocessor has no statistics for {key!r}: the robot's positions are read in its "
        "units. Use a checkpoint saved by lerobot-train (it stores the processors)."
    )
