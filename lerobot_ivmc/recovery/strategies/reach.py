"""`reach` (beyond the paper): a recovery that knows no task, only the robot and the policy's heads. The
failures it targets end with the policy's object belief gone astray (it closes the fingers on nothing and
then believes the object in the empty hand). When the trigger fires: look from the start pose with a fresh
memory (the object may have moved since the policy last saw it right), move above where the object head
then believes the object, descend and close on it (`grasp`), trying points around it while the fingers
close on nothing; then hand back to the policy with a fresh memory. With `carry`, a grasp that holds (or
a hand that holds the object when the trigger fires) is followed by a carry to where the policy believed
the goal on its least uncertain steps (the goal head, learned from where the object ends in the demos).
`object` and `goal` say which head the beliefs come from: the memory's, or the frame position head's
reading of each frame alone."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from torch import Tensor

from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction
from lerobot_ivmc.recovery.anchor import BeliefAnchor, carry_to_goal
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.manoeuvres import REACH, Manoeuvre, Stop, WaypointPath, above
from lerobot_ivmc.recovery.strategies.base import GOAL_POSITION, OBJECT_POSITION, RecoveryStrategy
from lerobot_ivmc.recovery.strategies.registry import register_strategy

if TYPE_CHECKING:
    from lerobot_ivmc.recovery.controller import IntrospectiveController

# The directions (world x, y) of the grasps tried after the first, in turn.
SEARCH_DIRECTIONS = np.array([[1, 0], [-1, 0], [0, 1], [0, -1], [1, 1], [-1, -1], [1, -1], [-1, 1]], float)


class ToStart(WaypointPath):
    """`reach`'s way to the start pose before a look (open fingers, up, across), ending in a fresh memory."""


class Look(WaypointPath):
    """`reach`'s look: still at the start pose, with a fresh memory, while the object beliefs are read."""


class Grasp(WaypointPath):
    """One grasp of `reach`: its try number and the believed object it searches around."""

    def __init__(self, try_index: int, obj: np.ndarray, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.try_index = try_index
        self.obj = obj


@register_strategy("reach")
class ReachRecovery(RecoveryStrategy):
    """Move above the object where the policy believed it (open fingers, at the start height), optionally
    grasp it there (and around it), then the policy again with a fresh memory."""

    reads_fingers = True

    def __init__(self, settings: RecoveryConfig):
        super().__init__(settings)
        self.belief_sums = np.zeros((0, 3))  # per rollout, the sum of its start (or look) beliefs so far
        self.belief_counts = np.zeros(0)
        self.beliefs_now = np.zeros((0, 3))
        self.looking = np.zeros(0, dtype=bool)  # per rollout, whether its look's beliefs are being read
        self.goals: list[BeliefAnchor] = []  # with `carry`, per rollout, its goal beliefs

    def check(self, policy: BVMCPolicy, state_stats: tuple[Tensor, Tensor] | None) -> None:
        if policy.config.aux_indices is None:
            raise ValueError(
                "--recovery.mode=reach reads the policy's object head: it needs a policy trained on a "
                "dataset with observation.environment_state (auxiliary heads); use --recovery.mode=retry."
            )
        self.check_frame_readings(policy, "reach", self.settings.reach)
        if self.settings.reach.carry and not getattr(policy.config, "goal_head", False):
            raise ValueError(
                "--recovery.reach.carry=true carries the object to the goal the policy believes: it needs a "
                "policy trained with --policy.goal_head=true; drop the carry for this one."
            )
        if state_stats is None:
            raise ValueError("--recovery.mode=reach needs the statistics of observation.state (state_stats).")

    def start_batch(self, batch_size: int) -> None:
        self.belief_sums = np.zeros((batch_size, 3))
        self.belief_counts = np.zeros(batch_size)
        self.beliefs_now = np.zeros((batch_size, 3))
        self.looking = np.zeros(batch_size, dtype=bool)
        self.goals = [BeliefAnchor(self.settings.reach.goal_steps) for _ in range(batch_size)]

    def observe(
        self,
        ctx: IntrospectiveController,
        prediction: MCPrediction,
        uncertainty: np.ndarray,
        normal: np.ndarray,
    ) -> None:
        """Read where the object head believes the object (metres); add up the beliefs of the episode's
        first steps ("start") or of the steps still at the start pose after a look's memory reset; with
        `carry`, record each normal step's believed goal with its uncertainty."""
        carry = self.settings.reach.carry
        outputs = ctx.policy.net.decode(prediction.embedding, stochastic=False, with_goal=carry)
        believed = outputs[3]
        if self.settings.reach.object == "frame":  # this frame's reading, without the memory
            believed = ctx.policy.frame_positions[:, OBJECT_POSITION]
        self.beliefs_now = ctx.object_positions(believed)
        if carry:
            goals = outputs[4]
            if self.settings.reach.goal == "frame":  # each frame's reading, averaged by the anchor
                goals = ctx.policy.frame_positions[:, GOAL_POSITION]
            goals = ctx.object_positions(goals)
            for row in np.flatnonzero(normal):
                self.goals[row].update(float(uncertainty[row]), goals[row])
        reading = self.looking.copy()
        if self.settings.reach.belief == "start" and ctx.step < self.settings.reach.belief_steps:
            reading |= normal
        self.belief_sums[reading] += self.beliefs_now[reading]
        self.belief_counts[reading] += 1

    def believed_object(self, row: int) -> np.ndarray:
        """(3,) where rollout `row`'s object is, as the `belief` setting says."""
        if self.settings.reach.belief == "now" or self.belief_counts[row] == 0:
            return self.beliefs_now[row].copy()
        return self.belief_sums[row] / self.belief_counts[row]

    def carry(self, ctx: IntrospectiveController, row: int, grip: np.ndarray, held: np.ndarray) -> Manoeuvre:
        """Bring the object held at `held` (its believed centre, (3,)) over the anchored goal and down to
        it, the fingers closed (with `release`, set it down there and open them); the policy then goes on
        with a fresh memory."""
        reach = self.settings.reach
        goal = self.goals[row].goal
        return carry_to_goal(
            grip,
            goal,
            held - grip,
            reach.steps,
            self.settings.move_tolerance,
            release=reach.release,
            max_held_offset=reach.max_held_offset,
            reset_memory=True,
            embodiment=ctx.embodiment,
        )

    def begin(self, ctx: IntrospectiveController, row: int, grip, fingers) -> tuple[Manoeuvre, dict]:
        reach, robot = self.settings.reach, ctx.embodiment
        if reach.carry and self.holding(ctx, row, fingers):
            carry = self.carry(ctx, row, grip, self.beliefs_now[row])
            return carry, {"holding": True, "target": carry.target.round(4).tolist()}
        if reach.belief == "look":
            start = ctx.initial_grip[row]
            stops = [Stop(above(grip, start[2]), robot.gripper_open), Stop(start, robot.gripper_open)]
            way = ToStart(stops, reach.steps, self.settings.move_tolerance, robot, REACH, start)
            return way, {"look_steps": reach.belief_steps}
        return self.reach(ctx, row, grip)

    def reach(self, ctx: IntrospectiveController, row: int, grip: np.ndarray) -> tuple[Manoeuvre, dict]:
        """From `grip`, above the believed object (and a grasp of it), and what the event reports."""
        reach, robot = self.settings.reach, ctx.embodiment
        obj = self.believed_object(row)
        over = above(obj, float(ctx.initial_grip[row][2]))
        stops = [Stop(above(grip, over[2]), robot.gripper_open), Stop(over, robot.gripper_open)]
        if reach.grasp:
            return self.grasp(ctx, 0, obj, stops), {"target": obj.round(4).tolist()}
        path = WaypointPath(stops, reach.steps, self.settings.move_tolerance, robot, REACH, obj)
        return path, {"target": obj.round(4).tolist()}

    def grasp(
        self, ctx: IntrospectiveController, try_index: int, obj: np.ndarray, stops: list[Stop]
    ) -> Grasp:
        """Grasp number `try_index` around the believed object `obj`, after `stops`."""
        reach, robot = self.settings.reach, ctx.embodiment
        point = obj.copy()
        if try_index > 0:
            direction = SEARCH_DIRECTIONS[(try_index - 1) % len(SEARCH_DIRECTIONS)]
            point[:2] += reach.search_radius * direction / np.linalg.norm(direction)
        stops = [
            *stops,
            Stop(above(point, obj[2] + reach.hover), robot.gripper_open),
            Stop(point, robot.gripper_open),
            Stop(point, robot.gripper_close, hold=reach.settle_steps),
        ]
        return Grasp(try_index, obj, stops, reach.steps, self.settings.move_tolerance, robot, REACH, point)

    def follow(self, ctx: IntrospectiveController, row: int, finished, grip, fingers) -> Manoeuvre | None:
        """After the way to the start pose, the look (its memory now fresh); after the look, the reach;
        after a grasp that closed on nothing, the next one (open, rise to `hover`) while tries are left."""
        reach, robot = self.settings.reach, ctx.embodiment
        if isinstance(finished, ToStart):  # hold still there while the beliefs are read
            self.belief_sums[row], self.belief_counts[row] = 0.0, 0
            self.looking[row] = True
            still = Stop(grip.copy(), robot.gripper_open, hold=reach.belief_steps)
            return Look([still], reach.belief_steps + 1, np.inf, robot, REACH, grip)
        if isinstance(finished, Look):
            self.looking[row] = False
            manoeuvre, event_extra = self.reach(ctx, row, grip)
            ctx.traces[-1].events[row][-1].update(event_extra)
            return manoeuvre
        if not isinstance(finished, Grasp):
            return None
        if robot.holds(fingers[row]):  # the grasp held: carry what it grasped at its point
            return self.carry(ctx, row, grip, finished.target) if reach.carry else None
        if finished.try_index + 1 >= reach.grasp_tries:
            return None
        rise = Stop(above(grip, finished.obj[2] + reach.hover), robot.gripper_open)
        return self.grasp(ctx, finished.try_index + 1, finished.obj, [rise])
