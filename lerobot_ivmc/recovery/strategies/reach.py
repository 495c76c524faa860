"""`reach` (beyond the paper): a recovery that knows no task, only the robot and the policy's heads. The
failures it targets end with the policy's object belief gone astray (it closes the fingers on nothing and
then believes the object in the empty hand). When the trigger fires: look from the start pose with a fresh
memory (the object may have moved since the policy last saw it right), move above where the object head
then believes the object, descend and close on it (`grasp`), trying points around it while the fingers
close on nothing; then hand back to the policy with a fresh memory. With `carry`, a grasp that holds (or
a hand that holds the object when the trigger fires) is followed by a carry to where the policy believed
the goal on its least uncertain steps (the goal head, learned from where the object ends in the demos).
With `push` (an object the task moves without lifting it), the closed fingers push the object along the
line from it to that goal until the object head believes it there (`PushAlongBelief`).
`object` and `goal` say which head the beliefs come from: the memory's, or the frame position head's
reading of each frame alone."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from torch import Tensor

from lerobot_ivmc.envs.embodiment import Embodiment
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction
from lerobot_ivmc.recovery.anchor import BeliefAnchor, carry_to_goal, on_table
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.manoeuvres import (
    PUSH_TO_GOAL,
    REACH,
    Manoeuvre,
    MemoryChange,
    Stop,
    WaypointPath,
    above,
)
from lerobot_ivmc.recovery.strategies.base import GOAL_POSITION, OBJECT_POSITION, RecoveryStrategy
from lerobot_ivmc.recovery.strategies.registry import register_strategy

if TYPE_CHECKING:
    from lerobot_ivmc.recovery.controller import IntrospectiveController

# The directions (world x, y) of the grasps tried after the first, in turn.
SEARCH_DIRECTIONS = np.array([[1, 0], [-1, 0], [0, 1], [0, -1], [1, 1], [-1, -1], [1, -1], [-1, 1]], float)
# A push starts with the grip point this far (metres) behind the believed object's centre, on the line from
# the goal through it: clear of an object of up to about 12 cm across, whatever its size.
PUSH_BACKOFF = 0.08
# Largest grip-point move per step while pushing (metres).
PUSH_SPEED = 0.02
# A push ends once the object is believed within this distance (metres) of the goal along the push, and a
# recovery ends once it is believed this close to the goal.
PUSH_TOLERANCE = 0.01


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


class PushAlongBelief(Manoeuvre):
    """One leg of reach's push, with closed fingers: rise, move above the point `PUSH_BACKOFF` behind the
    believed object on the line from `goal` through it, descend to the push height, then move along that
    line (at most `PUSH_SPEED` a step) until the object is believed within `PUSH_TOLERANCE` of the goal along
    it, or the grip point has passed the goal; rise `hover` and hand back with a fresh memory.

    Args:
        grip: the grip point now, (3,).
        obj: the believed object, (3,); its height is the push height.
        goal: the believed goal, (3,).
        believed: the object where the policy believes it at the current step, (3,) (read every step).
        legs_left: further legs the strategy may plan after this one.
        hover: metres above the push height to travel at.
        steps: most steps of the leg.
        tolerance: metres from a waypoint that count as reached.
        embodiment: the robot (its action scale and gripper commands).
    """

    phase = PUSH_TO_GOAL

    def __init__(
        self,
        grip: np.ndarray,
        obj: np.ndarray,
        goal: np.ndarray,
        believed: Callable[[], np.ndarray],
        legs_left: int,
        hover: float,
        steps: int,
        tolerance: float,
        embodiment: Embodiment,
    ):
        self.goal = np.asarray(goal, dtype=np.float64)
        line = self.goal[:2] - obj[:2]
        self.direction = line / max(float(np.linalg.norm(line)), 1e-9)
        self.z = float(obj[2])
        start = np.array([*(obj[:2] - PUSH_BACKOFF * self.direction), self.z])
        self.believed = believed
        self.legs_left = legs_left
        self.embodiment = embodiment
        self.hover = hover
        self.tolerance = tolerance
        close = embodiment.gripper_close
        lift = np.array([0.0, 0.0, hover])
        stops = [Stop(above(grip, self.z + hover), close), Stop(start + lift, close), Stop(start, close)]
        self.path: WaypointPath | None = WaypointPath(
            stops, steps, tolerance, embodiment, PUSH_TO_GOAL, start
        )
        self.lift: WaypointPath | None = None
        self.last_grip = np.asarray(grip, dtype=np.float64).copy()
        self.left = np.inf
        self.steps_left = steps
        self.finished = False

    def left_to_push(self, grip: np.ndarray) -> float:
        """Metres the object is believed short of the goal along the push. The belief is of the frame
        before the last move, so the grip point's advance since is taken off (the object moves with it)."""
        left = float(np.dot(self.goal[:2] - self.believed()[:2], self.direction))
        return left - float(np.dot(grip[:2] - self.last_grip[:2], self.direction))

    def advance(self, grip: np.ndarray) -> MemoryChange | None:
        if self.path is not None:  # the way to the start of the push
            self.path.advance(grip)
            if self.path.finished:
                self.path = None
        elif self.lift is None:
            self.left = self.left_to_push(grip)
            passed = float(np.dot(grip[:2] - self.goal[:2], self.direction)) > 0  # the fingers past the goal
            if self.left <= PUSH_TOLERANCE or passed or self.steps_left <= 0:
                up = Stop(grip + np.array([0.0, 0.0, self.hover]), self.embodiment.gripper_close)
                self.lift = WaypointPath(
                    [up], max(self.steps_left, 1), self.tolerance, self.embodiment, PUSH_TO_GOAL, up.position
                )
        self.last_grip = grip.copy()
        if self.lift is not None:
            self.lift.advance(grip)
            if self.lift.finished:
                self.finished = True
                return MemoryChange(None)
        return None

    def act(self, grip: np.ndarray, min_unc_action: Callable[[], np.ndarray]) -> np.ndarray:
        self.steps_left -= 1
        if self.path is not None:
            return self.path.act(grip, min_unc_action)
        if self.lift is not None:
            return self.lift.act(grip, min_unc_action)
        stride = min(PUSH_SPEED, max(self.left, 0.0))  # no farther than the object is believed to need
        ahead = np.array([*(grip[:2] + stride * self.direction), self.z])
        return self.embodiment.move_towards(grip, ahead, self.embodiment.gripper_close)


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
        reach = self.settings.reach
        if (reach.carry or reach.push) and not getattr(policy.config, "goal_head", False):
            flag = "carry" if reach.carry else "push"
            raise ValueError(
                f"--recovery.reach.{flag}=true takes the object to the goal the policy believes: it needs a "
                f"policy trained with --policy.goal_head=true; drop the {flag} for this one."
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
        carry = self.settings.reach.carry or self.settings.reach.push  # both go to the anchored goal
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
        if reach.push:
            return self.push(ctx, row, grip, obj, reach.push_legs - 1), {"target": obj.round(4).tolist()}
        if reach.grasp:
            return self.grasp(ctx, 0, obj, stops), {"target": obj.round(4).tolist()}
        path = WaypointPath(stops, reach.steps, self.settings.move_tolerance, robot, REACH, obj)
        return path, {"target": obj.round(4).tolist()}

    def push(
        self, ctx: IntrospectiveController, row: int, grip: np.ndarray, obj: np.ndarray, legs_left: int
    ) -> PushAlongBelief:
        """A push leg of the object believed at `obj` toward the anchored goal, at the object's rest height
        where the task's traits give it (else the believed height)."""
        rest_height = np.nan if ctx.task_traits is None else ctx.task_traits.rest_height
        reach = self.settings.reach
        return PushAlongBelief(
            grip,
            on_table(obj, rest_height),
            self.goals[row].goal,
            lambda: self.beliefs_now[row],
            legs_left,
            reach.hover,
            reach.steps,
            self.settings.move_tolerance,
            ctx.embodiment,
        )

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
        if isinstance(finished, PushAlongBelief):  # another leg while the object is believed off the goal
            obj = self.beliefs_now[row]
            off = float(np.linalg.norm(finished.goal[:2] - obj[:2]))
            if finished.legs_left == 0 or off <= PUSH_TOLERANCE:
                return None
            return self.push(ctx, row, grip, obj, finished.legs_left - 1)
        if not isinstance(finished, Grasp):
            return None
        if robot.holds(fingers[row]):  # the grasp held: carry what it grasped at its point
            return self.carry(ctx, row, grip, finished.target) if reach.carry else None
        if finished.try_index + 1 >= reach.grasp_tries:
            return None
        rise = Stop(above(grip, finished.obj[2] + reach.hover), robot.gripper_open)
        return self.grasp(ctx, finished.try_index + 1, finished.obj, [rise])
