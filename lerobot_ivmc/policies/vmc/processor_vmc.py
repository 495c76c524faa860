"""Pre- and post-processing of VMC: normalisation lives here, never in the model."""

from __future__ import annotations

from typing import Any

import torch
from lerobot.processor import (
    AddBatchDimensionProcessorStep,
    DeviceProcessorStep,
    NormalizerProcessorStep,
    PolicyAction,
    PolicyProcessorPipeline,
    RenameObservationsProcessorStep,
    UnnormalizerProcessorStep,
)
from lerobot.processor.converters import policy_action_to_transition, transition_to_policy_action
from lerobot.utils.constants import POLICY_POSTPROCESSOR_DEFAULT_NAME, POLICY_PREPROCESSOR_DEFAULT_NAME

from lerobot_ivmc.policies.vmc.configuration_vmc import VMCConfig
from lerobot_ivmc.policies.vmc.image_resize import ResizeImagesProcessorStep


def make_vmc_pre_post_processors(
    config: VMCConfig,
    dataset_stats: dict[str, dict[str, torch.Tensor]] | None = None,
) -> tuple[
    PolicyProcessorPipeline[dict[str, Any], dict[str, Any]],
    PolicyProcessorPipeline[PolicyAction, PolicyAction],
]:
    """Pipelines around the model: rename, batch, device, normalise (and with `image_size`, resize the
    frames) in; unnormalise, to CPU out.

    With the default `normalization_mapping`, images stay in [0, 1], state and the auxiliary targets
    (`observation.environment_state`) are standardised, and the action passes through untouched (its
    gripper dimension is a class label).

    Args:
        config: the policy config (features, normalisation mapping, device).
        dataset_stats: per-feature statistics from the dataset.

    Returns:
        The pre-processor and the post-processor.
    """
    features = {**config.input_features, **config.output_features}
    input_steps = [
        RenameObservationsProcessorStep(rename_map={}),
        AddBatchDimensionProcessorStep(),
        DeviceProcessorStep(device=config.device),
        NormalizerProcessorStep(
            features=features,
            norm_map=config.normalization_mapping,
            stats=dataset_stats,
            device=config.device,
        ),
    ]
    if config.image_size is not None:
        input_steps.append(ResizeImagesProcessorStep(size=config.image_size, keys=[config.image_feature_key]))
    output_steps = [
        UnnormalizerProcessorStep(
            features=config.output_features, norm_map=config.normalization_mapping, stats=dataset_stats
        ),
        DeviceProcessorStep(device="cpu"),
    ]
    return (
        PolicyProcessorPipeline[dict[str, Any], dict[str, Any]](
            steps=input_steps, name=POLICY_PREPROCESSOR_DEFAULT_NAME
        ),
        PolicyProcessorPipeline[PolicyAction, PolicyAction](
            steps=output_steps,
            name=POLICY_POSTPROCESSOR_DEFAULT_NAME,
            to_transition=policy_action_to_transition,
            to_output=transition_to_policy_action,
        ),
    )
