"""`retry` (beyond the paper): a recovery that knows no task, only the robot. The studies found that a fresh
memory rescues where the paper's back-track and foresight do not, and that the policy acts well from the
start pose its demos began at: when the trigger fires, open the fingers, rise, return to the episode's start
grip position (or, with `--recovery.retry.start_radius`, a random point near it) and let the policy begin
again from the scene as it now is. With `--recovery.retry.commit_sample` the new attempt acts with one
posterior sample of the network (one set of dropout masks) instead of the Monte Carlo mean."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch
from torch import Tensor

from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction, mean_action
from lerobot_ivmc.recovery.manoeuvres import Manoeuvre, ReturnToStart, point_in_ball
from lerobot_ivmc.recovery.strategies.base import RecoveryStrategy
from lerobot_ivmc.recovery.strategies.registry import register_strategy

if TYPE_CHECKING:
    from lerobot_ivmc.recovery.controller import IntrospectiveController


@register_strategy("retry")
class RetryRecovery(RecoveryStrategy):
    """Return to the start pose (or near it) with open fingers and a fresh memory, then the policy again."""

    def check(self, policy: BVMCPolicy, state_stats: tuple[Tensor, Tensor] | None) -> None:
        if self.settings.retry.commit_sample and not policy.mc_sampling:
            raise ValueError(
                "--recovery.retry.commit_sample acts with one of the policy's dropout samples, and this "
                "policy draws none (--policy.mc_sampling=false): drop one of the two."
            )

    def start_batch(self, batch_size: int) -> None:
        # Per rollout, the uniform noise fixing the committed dropout masks (one (1, 1, K_l) per layer).
        self.committed: list[list[Tensor] | None] = [None] * batch_size

    def begin(self, ctx: IntrospectiveController, row: int, grip, fingers) -> tuple[Manoeuvre, dict]:
        s = self.settings
        start = ctx.initial_grip[row]
        if s.retry.start_radius > 0:
            start = point_in_ball(start, s.retry.start_radius, ctx.draws(row)[0])
        if s.retry.commit_sample:
            self.committed[row] = ctx.policy.draw_noise(1, 1, [ctx.draws(row)[1]])
        manoeuvre = ReturnToStart(grip, start, s.retry.steps, s.move_tolerance, ctx.embodiment)
        return manoeuvre, {"target": manoeuvre.target.round(4).tolist()}

    def normal_actions(
        self, ctx: IntrospectiveController, prediction: MCPrediction, actions: Tensor, normal: np.ndarray
    ) -> None:
        """Rollouts back from a retry with `commit_sample` act with their committed masks."""
        rows = [int(row) for row in np.flatnonzero(normal) if self.committed[row] is not None]
        if not rows:
            return
        noise = [torch.cat(layer) for layer in zip(*(self.committed[row] for row in rows), strict=True)]
        delta_ee, gripper_values = ctx.policy.sample_head(prediction.embedding[rows], 1, noise)
        committed = mean_action(delta_ee, gripper_values, ctx.policy.config.gripper)
        actions[rows] = committed.to(actions.device, actions.dtype)
