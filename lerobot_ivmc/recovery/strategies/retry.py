"""`retry` (beyond the paper): a recovery that knows no task, only the robot. The studies found that a fresh
memory rescues where the paper's back-track and foresight do not, and that the policy acts well from the
start pose its demos began at: when the trigger fires, open the fingers, rise, return to the episode's start
grip position (or, with `--recovery.retry.start_radius`, a random point near it) and let the policy begin
again from the scene as it now is."""

from __future__ import annotations

from typing import TYPE_CHECKING

from lerobot_ivmc.recovery.manoeuvres import Manoeuvre, ReturnToStart, point_in_ball
from lerobot_ivmc.recovery.strategies.base import RecoveryStrategy
from lerobot_ivmc.recovery.strategies.registry import register_strategy

if TYPE_CHECKING:
    from lerobot_ivmc.recovery.controller import IntrospectiveController


@register_strategy("retry")
class RetryRecovery(RecoveryStrategy):
    """Return to the start pose (or near it) with open fingers and a fresh memory, then the policy again."""

    def begin(self, ctx: IntrospectiveController, row: int, grip, fingers) -> tuple[Manoeuvre, dict]:
        s = self.settings
        start = ctx.initial_grip[row]
        if s.retry.start_radius > 0:
            start = point_in_ball(start, s.retry.start_radius, ctx.draws(row)[0])
        manoeuvre = ReturnToStart(grip, start, s.retry.steps, s.move_tolerance, ctx.embodiment)
        return manoeuvre, {"target": manoeuvre.target.round(4).tolist()}
