"""The paper's recovery modes: `rand` (random end-effector moves), `init` (back to near the start pose) and
`min_unc` (back-track to the least uncertain recent step, then follow the foresight's least uncertain
candidates), and `none` (only record the uncertainty)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction
from lerobot_ivmc.recovery.candidates import widen_candidates
from lerobot_ivmc.recovery.manoeuvres import BacktrackThenFollow, Manoeuvre, MoveToInit, RandomMoves
from lerobot_ivmc.recovery.strategies.base import RecoveryStrategy
from lerobot_ivmc.recovery.strategies.registry import register_strategy

if TYPE_CHECKING:
    from lerobot_ivmc.recovery.controller import IntrospectiveController


@register_strategy("none")
class NoRecovery(RecoveryStrategy):
    """Plain BVMC: the trigger never fires (the controller's threshold is infinite)."""

    def begin(self, ctx, row, grip, fingers) -> tuple[Manoeuvre, dict]:
        raise RuntimeError("--recovery.mode=none never starts a recovery.")


@register_strategy("rand")
class RandomRecovery(RecoveryStrategy):
    """Uniform random end-effector moves with the fingers left as they are, then a fresh memory."""

    def begin(self, ctx: IntrospectiveController, row: int, grip, fingers) -> tuple[Manoeuvre, dict]:
        s = self.settings
        return RandomMoves(s.recovery_steps, s.rand_step_scale, ctx.draws(row)[0]), {}


@register_strategy("init")
class InitRecovery(RecoveryStrategy):
    """Open the fingers and move to a random point near the episode's start grip position, then a fresh
    memory."""

    def begin(self, ctx: IntrospectiveController, row: int, grip, fingers) -> tuple[Manoeuvre, dict]:
        s = self.settings
        manoeuvre = MoveToInit(
            ctx.initial_grip[row],
            s.init_sphere_radius,
            s.recovery_steps,
            s.move_tolerance,
            ctx.draws(row)[0],
            ctx.embodiment,
        )
        return manoeuvre, {"target": manoeuvre.target.round(4).tolist()}


@register_strategy("min_unc")
class MinUncertaintyRecovery(RecoveryStrategy):
    """The paper's recovery: back-track to the FIFO's least uncertain step (its memory restored, reset or
    kept), then execute the candidate action of least foreseen uncertainty."""

    keeps_fifo = True

    def check(self, policy: BVMCPolicy, state_stats) -> None:
        policy.require_foresight()

    def begin(self, ctx: IntrospectiveController, row: int, grip, fingers) -> tuple[Manoeuvre, dict]:
        s = self.settings
        manoeuvre = BacktrackThenFollow(
            list(ctx.fifos[row]),
            s.recovery_steps,
            s.backtrack_horizon,
            s.backtrack_tolerance,
            ctx.embodiment,
            memory=s.min_unc.memory,
        )
        return manoeuvre, {"backtrack_to_step": manoeuvre.target.step}

    def policy_action(self, ctx: IntrospectiveController, prediction: MCPrediction, row: int) -> np.ndarray:
        """The candidate action of `row` (a sample, widened by `candidate_noise`) with the lowest foreseen
        uncertainty of the next step (or, as `--recovery.min_unc.choice` says, the mean or a random
        candidate)."""
        choice = self.settings.min_unc.choice
        if choice == "mean":
            return prediction.mean_action[row].cpu().numpy()
        rng, generator = ctx.draws(row)
        candidates = widen_candidates(prediction.samples[row : row + 1], ctx.candidate_noise, generator)
        if choice == "random":
            return candidates[0, int(rng.integers(candidates.shape[1]))].cpu().numpy()
        foreseen = ctx.policy.foresee(prediction.embedding[row : row + 1], candidates)
        return candidates[0, int(foreseen[0].argmin())].cpu().numpy()
