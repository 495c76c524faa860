"""`anchor` (beyond the paper): a planner for the Fetch tasks driven by the policy's beliefs from its least
uncertain steps (`recovery/anchor.py` has its manoeuvres and the reasons). This module decides which
manoeuvre a rollout makes, from what the robot feels and the policy believes, and what follows it."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from torch import Tensor

from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction
from lerobot_ivmc.recovery.anchor import (
    PUSH_LEGS,
    BeliefAnchor,
    LookFromStart,
    carry_to_goal,
    on_goal,
    push_to_goal,
    regrasp,
)
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.manoeuvres import Manoeuvre
from lerobot_ivmc.recovery.strategies.base import GOAL_POSITION, OBJECT_POSITION, RecoveryStrategy
from lerobot_ivmc.recovery.strategies.registry import register_strategy

if TYPE_CHECKING:
    from lerobot_ivmc.recovery.controller import IntrospectiveController


@register_strategy("anchor")
class AnchorRecovery(RecoveryStrategy):
    """Carry a held object to the anchored goal; re-grasp one not held where the policy believes it (after a
    look from the start pose where the task says), or push it there."""

    reads_fingers = True

    def __init__(self, settings: RecoveryConfig):
        if unresolved := settings.anchor.unresolved():
            flags = ", ".join(f"--recovery.anchor.{name}" for name in unresolved)
            raise ValueError(
                f"anchor takes {flags} from the task: resolve the settings for it "
                "(RecoveryConfig.for_task_traits, as lerobot-ivmc-eval does on a Fetch task) or set them."
            )
        super().__init__(settings)
        self.anchors: list[BeliefAnchor] = []
        self.object_beliefs = np.zeros((0, 3))

    def check(self, policy: BVMCPolicy, state_stats: tuple[Tensor, Tensor] | None) -> None:
        if not getattr(policy.config, "goal_head", False):
            raise ValueError(
                "--recovery.mode=anchor reads the goal the policy believes: it needs a policy trained with "
                "--policy.goal_head=true (the lite preset's); use another --recovery.mode for this one."
            )
        self.check_frame_readings(policy, "anchor", self.settings.anchor)
        if state_stats is None:
            raise ValueError(
                "--recovery.mode=anchor needs the statistics of observation.state (state_stats)."
            )

    def start_batch(self, batch_size: int) -> None:
        self.anchors = [BeliefAnchor(self.settings.anchor.goal_steps) for _ in range(batch_size)]
        self.object_beliefs = np.zeros((batch_size, 3))  # the last step's believed object positions

    def observe(
        self,
        ctx: IntrospectiveController,
        prediction: MCPrediction,
        uncertainty: np.ndarray,
        normal: np.ndarray,
    ) -> None:
        """Read the believed object and goal positions (the net's deterministic heads, or the frame position
        head's reading of this frame, metres); add the goals of rollouts in normal operation to their
        anchors."""
        outputs = ctx.policy.net.decode(prediction.embedding, stochastic=False, with_goal=True)
        believed = outputs[3]
        if self.settings.anchor.object == "frame":  # this frame's reading, without the memory
            believed = ctx.policy.frame_positions[:, OBJECT_POSITION]
        self.object_beliefs = ctx.object_positions(believed)
        goals = outputs[4]
        if self.settings.anchor.goal == "frame":  # each frame's reading, averaged by the anchor
            goals = ctx.policy.frame_positions[:, GOAL_POSITION]
        goals = ctx.object_positions(goals)
        for row in np.flatnonzero(normal):
            self.anchors[row].update(float(uncertainty[row]), goals[row])

    def begin(
        self, ctx: IntrospectiveController, row: int, grip: np.ndarray, fingers: np.ndarray
    ) -> tuple[Manoeuvre, dict]:
        s, a = self.settings, self.settings.anchor
        if a.look_steps > 0 and not self.holding(ctx, row, fingers):
            look = LookFromStart(
                grip,
                ctx.initial_grip[row],
                float(ctx.last_gripper[row]),
                a.look_steps,
                a.steps,
                s.move_tolerance,
                ctx.embodiment,
            )
            return look, {"look_steps": a.look_steps}
        return self.act_on_beliefs(ctx, row, grip, fingers)

    def act_on_beliefs(
        self, ctx: IntrospectiveController, row: int, grip: np.ndarray, fingers: np.ndarray
    ) -> tuple[Manoeuvre, dict]:
        """Anchor's manoeuvre for rollout `row` from what it feels and believes now, and what the recovery
        event reports of it."""
        s, a = self.settings, self.settings.anchor
        holding = self.holding(ctx, row, fingers)
        if holding:
            manoeuvre = self.carry(ctx, row, grip)
        elif a.grasp:
            manoeuvre = regrasp(
                grip,
                self.object_beliefs[row],
                a.steps,
                s.move_tolerance,
                a.rest_height,
                a.grasp_offset,
                embodiment=ctx.embodiment,
            )
        else:
            manoeuvre = self.push(ctx, row, grip, PUSH_LEGS)
        return manoeuvre, {"holding": holding, "target": manoeuvre.target.round(4).tolist()}

    def follow(
        self,
        ctx: IntrospectiveController,
        row: int,
        finished: Manoeuvre,
        grip: np.ndarray,
        fingers: np.ndarray,
    ) -> Manoeuvre | None:
        if isinstance(finished, LookFromStart):  # the look is over: anchor on what it showed
            manoeuvre, event_extra = self.act_on_beliefs(ctx, row, grip, fingers)
            ctx.traces[-1].events[row][-1].update(event_extra)
            return manoeuvre
        if finished.then_carry and self.holding(ctx, row, fingers):  # a re-grasp that held
            return self.carry(ctx, row, grip, finished.held_offset)
        if finished.then_push and not on_goal(self.object_beliefs[row], self.anchors[row].goal):
            return self.push(ctx, row, grip, finished.then_push)
        return None

    def carry(
        self,
        ctx: IntrospectiveController,
        row: int,
        grip: np.ndarray,
        grasped_offset: np.ndarray | None = None,
    ) -> Manoeuvre:
        """Carry the held object to the anchored goal; `grasped_offset`: where anchor's own re-grasp put the
        object's centre from the grip point, used instead of the believed offset where
        `--recovery.anchor.held_offset` is "grasped"."""
        s, a = self.settings, self.settings.anchor
        held_offset = self.object_beliefs[row] - grip
        if grasped_offset is not None and a.held_offset == "grasped":
            held_offset = grasped_offset
        return carry_to_goal(
            grip,
            self.anchors[row].goal,
            held_offset,
            a.steps,
            s.move_tolerance,
            a.release,
            a.max_held_offset,
            a.carry_memory == "reset",
            embodiment=ctx.embodiment,
        )

    def push(self, ctx: IntrospectiveController, row: int, grip: np.ndarray, legs: int) -> Manoeuvre:
        """Push the object toward the anchored goal, as the task's push geometry says."""
        s, a = self.settings, self.settings.anchor
        traits = ctx.task_traits
        if traits is None or traits.push_contact is None:
            raise ValueError(
                "--recovery.anchor.grasp=false pushes the object: it needs a task whose env defines how "
                "the fingers push it (push_contact); pass --recovery.anchor.grasp=true or another mode."
            )
        return push_to_goal(
            grip,
            self.object_beliefs[row],
            self.anchors[row].goal,
            a.steps,
            s.move_tolerance,
            legs,
            a.rest_height,
            embodiment=ctx.embodiment,
            push=traits.push_contact,
        )
