"""Loading a trained vmc / bvmc checkpoint for inspection (shared by the policy diagnostics scripts)."""

import numpy as np
from lerobot.configs.policies import PreTrainedConfig
from lerobot.policies.factory import get_policy_class, make_pre_post_processors
from lerobot.processor import NormalizerProcessorStep, PolicyProcessorPipeline
from lerobot.utils.constants import OBS_ENV_STATE
from torch import Tensor

import lerobot_ivmc  # noqa: F401  (registers the policy types)
from lerobot_ivmc.policies import VMCPolicy


class InspectedPolicy:
    """A checkpoint in its deterministic mode (dropout off for bvmc), with its preprocessor.

    Args:
        path: the checkpoint's `pretrained_model` folder.
    """

    def __init__(self, path: str):
        config = PreTrainedConfig.from_pretrained(path)
        self.policy: VMCPolicy = get_policy_class(config.type).from_pretrained(path)
        self.policy.mc_sampling = False
        self.policy.eval()
        self.preprocessor: PolicyProcessorPipeline
        self.preprocessor, _ = make_pre_post_processors(self.policy.config, pretrained_path=path)
        normalizer = next(s for s in self.preprocessor.steps if isinstance(s, NormalizerProcessorStep))
        stats = normalizer.stats[OBS_ENV_STATE]
        self._aux_mean, self._aux_std = np.asarray(stats["mean"]), np.asarray(stats["std"])

    def auxiliary_positions(self, ee: Tensor, obj: Tensor) -> np.ndarray:
        """The decoded EE and object positions of the first rollout, back in metres: (6,)."""
        normalised = np.concatenate([ee[0].numpy(), obj[0].numpy()])
        return normalised * self._aux_std + self._aux_mean
