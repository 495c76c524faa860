"""What a recovery strategy is: the manoeuvre a rollout makes once Algorithm 1's trigger fires, and what
follows it. `IntrospectiveController` keeps Algorithm 1 (window, trigger, FIFO, traces) and asks its
strategy, found by `--recovery.mode` in the registry (`registry.py`), for the manoeuvres."""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar

import numpy as np
from torch import Tensor

from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.manoeuvres import Manoeuvre

if TYPE_CHECKING:
    from lerobot_ivmc.recovery.controller import IntrospectiveController

# The object's and the goal's parts of the frame position head's outputs (`policy.frame_positions`: EE 0:3,
# object 3:6, goal 6:9), read from one frame's CNN map without the memory.
OBJECT_POSITION, GOAL_POSITION = slice(3, 6), slice(6, 9)


class RecoveryStrategy:
    """A recovery mode. Subclasses set `name` and implement `begin`; the other hooks do nothing here.

    Attributes:
        keeps_fifo: the controller keeps each rollout's FIFO of normal steps (min_unc's back-track).
        reads_fingers: `begin` and `follow` are given the finger positions (else None).
    """

    name: ClassVar[str]
    keeps_fifo: ClassVar[bool] = False
    reads_fingers: ClassVar[bool] = False

    def __init__(self, settings: RecoveryConfig):
        self.settings = settings

    def check(self, policy: BVMCPolicy, state_stats: tuple[Tensor, Tensor] | None) -> None:
        """Refuse a policy (or missing statistics) the strategy cannot act with, in one line."""

    def start_batch(self, batch_size: int) -> None:
        """A new batch of `batch_size` rollouts begins."""

    def observe(
        self,
        ctx: IntrospectiveController,
        prediction: MCPrediction,
        uncertainty: np.ndarray,
        normal: np.ndarray,
    ) -> None:
        """Every step's Monte Carlo pass, (B,) uncertainty and (B,) rollouts in normal operation."""

    def begin(
        self, ctx: IntrospectiveController, row: int, grip: np.ndarray, fingers: np.ndarray | None
    ) -> tuple[Manoeuvre, dict]:
        """The manoeuvre rollout `row` starts when its trigger fires, and what its recovery event reports."""
        raise NotImplementedError

    def follow(
        self,
        ctx: IntrospectiveController,
        row: int,
        finished: Manoeuvre,
        grip: np.ndarray,
        fingers: np.ndarray | None,
    ) -> Manoeuvre | None:
        """What rollout `row` does after `finished` ends: another manoeuvre, or None (the policy)."""
        return None

    @staticmethod
    def check_frame_readings(policy: BVMCPolicy, mode: str, settings: object) -> None:
        """Refuse `--recovery.<mode>.object=frame` / `goal=frame` (the fields of `settings`) for a policy
        trained without the frame position head, in one line."""
        on_frame = [n for n in ("object", "goal") if getattr(settings, n, None) == "frame"]
        if on_frame and not getattr(policy.config, "frame_position_head", False):
            flags = " and ".join(f"--recovery.{mode}.{name}=frame" for name in on_frame)
            fix = " ".join(f"--recovery.{mode}.{name}=memory" for name in on_frame)
            raise ValueError(
                f"{flags} {'read' if len(on_frame) > 1 else 'reads'} the policy's frame position head: it "
                "needs a policy trained with "
                f"--policy.frame_position_head=true (the lite preset's); pass {fix} for this one."
            )

    @staticmethod
    def holding(ctx: IntrospectiveController, row: int, fingers: np.ndarray) -> bool:
        """Whether rollout `row` holds the object: it last commanded "close" and the fingers rest apart
        (`fingers`: (B, F), a strategy that `reads_fingers`)."""
        embodiment = ctx.embodiment
        return embodiment.closes(float(ctx.last_gripper[row])) and embodiment.holds(fingers[row])

    def normal_actions(
        self, ctx: IntrospectiveController, prediction: MCPrediction, actions: Tensor, normal: np.ndarray
    ) -> None:
        """Set, in place, the (B, 4) `actions` of the rollouts in normal operation ((B,) `normal`); they
        hold the Monte Carlo mean, which this base class leaves."""

    def policy_action(self, ctx: IntrospectiveController, prediction: MCPrediction, row: int) -> np.ndarray:
        """The action a manoeuvre takes from the policy (`Manoeuvre.act`'s callable): the Monte Carlo mean."""
        return prediction.mean_action[row].cpu().numpy()
