"""Pre- and post-processing of Bayesian VMC: the same pipelines as VMC."""

from __future__ import annotations

from typing import Any

import torch
from lerobot.processor import PolicyAction, PolicyProcessorPipeline

from lerobot_ivmc.policies.bvmc.configuration_bvmc import BVMCConfig
from lerobot_ivmc.policies.vmc.processor_vmc import make_vmc_pre_post_processors


def make_bvmc_pre_post_processors(
    config: BVMCConfig,
    dataset_stats: dict[str, dict[str, torch.Tensor]] | None = None,
) -> tuple[
    PolicyProcessorPipeline[dict[str, Any], dict[str, Any]],
    PolicyProcessorPipeline[PolicyAction, PolicyAction],
]:
    """See `make_vmc_pre_post_processors`."""
    return make_vmc_pre_post_processors(config, dataset_stats=dataset_stats)
