"""Base class of the policies that drive a trained Bayesian VMC inside LeRobot's `rollout`."""

from __future__ import annotations

import torch
from lerobot.policies.pretrained import PreTrainedPolicy
from torch import Tensor

from lerobot_ivmc.policies.bvmc.configuration_bvmc import BVMCConfig
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy


class BVMCRolloutWrapper(PreTrainedPolicy):
    """A LeRobot policy around a trained `BVMCPolicy` (LeRobot's `eval_policy` requires a
    `PreTrainedPolicy`): it decides what the wrapped policy's samples are used for, and trains nothing.

    Args:
        policy: the Bayesian VMC.
    """

    config_class = BVMCConfig
    name = "bvmc_rollout"

    def __init__(self, policy: BVMCPolicy):
        super().__init__(policy.config)
        self.policy = policy

    def get_optim_params(self) -> list[dict]:
        raise NotImplementedError(
            f"{type(self).__name__} runs a trained policy; train the BVMCPolicy itself."
        )

    def forward(self, batch: dict[str, Tensor]) -> tuple[Tensor, dict]:
        raise NotImplementedError(
            f"{type(self).__name__} runs a trained policy; train the BVMCPolicy itself."
        )

    def reset(self) -> None:
        """Start a batch of episodes (LeRobot's `rollout` calls this once per batch)."""
        self.policy.reset()

    @torch.no_grad()
    def predict_action_chunk(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        return self.select_action(batch)[:, None]
