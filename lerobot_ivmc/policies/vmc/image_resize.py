"""`ResizeImagesProcessorStep`: the policy's pre-processing step that brings a dataset's camera frames to the
size the network was built for (`VMCConfig.image_size`), e.g. `lerobot/metaworld_mt50`'s 480-px frames to
64 px; area interpolation, frames of any leading shape ((B, 3, H, W) steps or (B, L, 3, H, W) chunks)."""

from __future__ import annotations

from dataclasses import dataclass, field

import torch.nn.functional as F  # noqa: N812
from lerobot.configs.types import FeatureType, PipelineFeatureType, PolicyFeature
from lerobot.processor import ObservationProcessorStep, ProcessorStepRegistry
from torch import Tensor


@ProcessorStepRegistry.register("ivmc_resize_images")
@dataclass
class ResizeImagesProcessorStep(ObservationProcessorStep):
    """Resize the frames of `keys` to `size` x `size` pixels.

    Args:
        size: the side the network takes.
        keys: the camera features to resize.
    """

    size: int = 64
    keys: list[str] = field(default_factory=list)

    def observation(self, observation: dict) -> dict:
        for key in self.keys:
            if key in observation:
                observation[key] = resize_frames(observation[key], self.size)
        return observation

    def get_config(self) -> dict:
        return {"size": self.size, "keys": list(self.keys)}

    def transform_features(
        self, features: dict[PipelineFeatureType, dict[str, PolicyFeature]]
    ) -> dict[PipelineFeatureType, dict[str, PolicyFeature]]:
        observations = features.get(PipelineFeatureType.OBSERVATION, {})
        for key in self.keys:
            if key in observations and observations[key].type is FeatureType.VISUAL:
                channels = observations[key].shape[0]
                observations[key] = PolicyFeature(FeatureType.VISUAL, (channels, self.size, self.size))
        return features


def resize_frames(frames: Tensor, size: int) -> Tensor:
    """(..., C, H, W) frames -> (..., C, size, size); unchanged when already that size."""
    if tuple(frames.shape[-2:]) == (size, size):
        return frames
    lead = frames.shape[:-3]
    flat = frames.reshape(-1, *frames.shape[-3:]).float()
    return F.interpolate(flat, size=(size, size), mode="area").reshape(*lead, frames.shape[-3], size, size)
