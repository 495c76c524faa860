"""Anchored recovery (beyond the paper): act on what the policy believed when it was most certain.

The studies' failures are beliefs that drift while the uncertainty rises (docs/RESULTS.md): in pick_place
the goal the network believes slides toward the carried cube, and the cube is put down short of the target;
a retry of the same policy from nearby repeats the slide (memory restored: nothing rescued; memory reset:
a quarter). The network's goal head knew the target when its uncertainty was low, and its object head
knows where the object is when the trigger fires (median error about 1 cm on pick_place's failures).
`anchor` keeps, for every rollout, the goal believed over its least uncertain steps and, when the trigger
fires, moves by the policy's beliefs, choosing by what the robot feels:

- holding the object (the last gripper command was "close" and the fingers rest apart, on something):
  carry it so that the object, where the policy believes it sits in the hand, comes over the anchored goal,
  lower it and, where the task ends with the object let go (`release`), open the gripper and rise;
- not holding it, with `grasp`: open, rise above the object where the policy believes it now (at the
  task's rest height: an object not held lies on the table), descend, close, lift and, if the fingers now
  hold it, carry it to the anchored goal as above;
- not holding it, without `grasp` (a task whose object is pushed, never lifted): push the object, where
  the policy believes it now, onto the anchored goal with the closed fingers, in straight legs as the
  scripted demos push (along x to the goal's row, then along y onto it), each leg planned from where the
  policy believes the object after the last.

Then the policy takes over again, with a fresh memory (with the object still held and no release, with its
memory as it is). Only the robot's own senses and the policy's heads are read: the grip point's position
(forward kinematics), the finger joints, the gripper commands it sent, and the network's auxiliary object
and goal estimates (its deterministic pass).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lerobot_ivmc.envs.embodiment import Embodiment
from lerobot_ivmc.envs.task_traits import PushContact
from lerobot_ivmc.recovery.manoeuvres import (
    CARRY_TO_GOAL,
    LOOK,
    PUSH_TO_GOAL,
    REGRASP,
    Manoeuvre,
    MemoryChange,
    above,
)
from lerobot_ivmc.recovery.strategy_settings import ANCHOR_GOAL_STEPS, MAX_HELD_OFFSET

# Carry at least this high above the believed goal (metres), so the object clears the table on the way.
CARRY_CLEARANCE = 0.05
# An object that is let go at its goal is lowered to this height above the believed goal (metres) first. One
# that stays held is brought to the goal itself: the goal head learns where the object is at the demo's end,
# with the task done (docs/recovery.md, anchor).
PLACE_CLEARANCE = 0.02
# After a release, the gripper rises this far (metres) with open fingers.
RELEASE_LIFT = 0.05
# A re-grasp starts this high above the believed object (metres): the start pose's height.
APPROACH_HEIGHT = 0.1
# The grip point closes this high above the believed object's centre (metres), as the scripted demos do.
GRASP_HEIGHT = 0.01
# Steps the gripper is commanded to close (or open) in place: the fingers settle in about five.
FINGER_STEPS = 6
# Largest grip-point move per step while anchored (metres): the scripted demos' speed.
ANCHOR_SPEED = 0.03
# The object counts as pushed onto the goal when believed this close to it along x and along y (metres):
# half the targets' 3 cm radius, above the object head's typical error so that noise is not pushed after.
PUSH_LEG_MIN = 0.015
# At most this many push legs in one recovery: the demos' two, and one to correct the drift of the second.
PUSH_LEGS = 3


class BeliefAnchor:
    """One rollout's record of the goal the policy believed at each normal step, with its uncertainty; the
    anchored goal is the mean over its `goal_steps` least uncertain steps."""

    def __init__(self, goal_steps: int = ANCHOR_GOAL_STEPS):
        self.goal_steps = goal_steps
        self.uncertainties: list[float] = []
        self.goals: list[np.ndarray] = []

    def update(self, uncertainty: float, goal_belief: np.ndarray) -> None:
        """Add one normal step's uncertainty and believed goal, (3,)."""
        self.uncertainties.append(uncertainty)
        self.goals.append(goal_belief.copy())

    @property
    def goal(self) -> np.ndarray:
        """(3,) the mean of the goals believed at the `goal_steps` least uncertain steps so far."""
        if not self.goals:
            raise ValueError("No belief recorded yet: the trigger cannot fire before a normal step.")
        least = np.argsort(self.uncertainties, kind="stable")[: self.goal_steps]
        return np.mean([self.goals[i] for i in least], axis=0)


# A waypoint's gripper: open or closed fingers (the robot's own commands, `Embodiment`).
OPEN, CLOSE = "open", "close"


@dataclass
class Waypoint:
    """A grip-point position to move to with the fingers `OPEN` or `CLOSE`d, at most `speed` metres a step,
    held `hold` steps once reached."""

    position: np.ndarray
    gripper: str | float
    hold: int = 0
    speed: float = ANCHOR_SPEED


def gripper_command(embodiment: Embodiment, gripper: str | float) -> float:
    """The robot's command for `OPEN` or `CLOSE` (a number: that command itself)."""
    if gripper == OPEN:
        return embodiment.gripper_open
    return embodiment.gripper_close if gripper == CLOSE else float(gripper)


class WaypointMoves(Manoeuvre):
    """Moves the grip point through waypoints at `ANCHOR_SPEED`, then hands back to the policy.

    Args:
        waypoints: in order.
        embodiment: the robot (its action scale and gripper commands).
        steps: most steps of the manoeuvre.
        tolerance: metres from a waypoint that count as reached.
        phase: the phase recorded in the traces.
        target: the point the recovery event reports (where the object is placed, grasped or pushed to),
            (3,).
        reset_memory: hand back with a fresh memory (else with the memory as it is).
        then_carry: once over, anchor carries the object to the anchored goal if it holds it (a re-grasp,
            whose `held_offset` is where it grasped the object's centre from the grip point, (3,)).
        then_push: once over, anchor may push the object this many legs more.
    """

    def __init__(
        self,
        waypoints: list[Waypoint],
        embodiment: Embodiment,
        steps: int,
        tolerance: float,
        phase: int,
        target: np.ndarray,
        reset_memory: bool,
        then_carry: bool = False,
        then_push: int = 0,
    ):
        self.waypoints = list(waypoints)
        self.embodiment = embodiment
        self.target = target
        self.steps_left = steps
        self.tolerance = tolerance
        self.phase = phase
        self.reset_memory = reset_memory
        self.then_carry = then_carry
        self.then_push = then_push
        self.held_offset: np.ndarray | None = None
        self.held = 0
        self.finished = False

    def advance(self, grip: np.ndarray) -> MemoryChange | None:
        while self.waypoints and np.linalg.norm(grip - self.waypoints[0].position) <= self.tolerance:
            if self.held < self.waypoints[0].hold:
                break
            self.waypoints.pop(0)
            self.held = 0
        if not self.waypoints or self.steps_left == 0:
            self.finished = True
            return MemoryChange(None) if self.reset_memory else None
        return None

    def act(self, grip: np.ndarray, min_unc_action: Callable[[], np.ndarray]) -> np.ndarray:
        self.steps_left -= 1
        waypoint = self.waypoints[0]
        if np.linalg.norm(grip - waypoint.position) <= self.tolerance:
            self.held += 1
        offset = waypoint.position - grip
        distance = float(np.linalg.norm(offset))
        speed = waypoint.speed
        target = waypoint.position if distance <= speed else grip + offset * (speed / distance)
        return self.embodiment.move_towards(grip, target, gripper_command(self.embodiment, waypoint.gripper))


def carry_to_goal(
    grip: np.ndarray,
    goal: np.ndarray,
    held_offset: np.ndarray,
    steps: int,
    tolerance: float,
    release: bool,
    max_held_offset: float = MAX_HELD_OFFSET,
    reset_memory: bool | None = None,
    *,
    embodiment: Embodiment,
) -> WaypointMoves:
    """Holding the object: rise to a carrying height, bring the object (at `held_offset` from the grip
    point, clipped to `max_held_offset`) over `goal` and down to it with the gripper closed; with `release`,
    to `PLACE_CLEARANCE` above it, open there and rise by `RELEASE_LIFT`. The policy then goes on with a
    fresh memory (`reset_memory`; None: after a release only)."""
    offset = np.asarray(held_offset, dtype=np.float64)
    norm = float(np.linalg.norm(offset))
    if norm > max_held_offset:
        offset = offset * (max_held_offset / norm)
    clearance = PLACE_CLEARANCE if release else 0.0
    place = np.asarray(goal, dtype=np.float64) - offset + np.array([0.0, 0.0, clearance])
    height = max(float(grip[2]), float(place[2]) + CARRY_CLEARANCE)
    waypoints = [
        Waypoint(np.array([place[0], place[1], height]), CLOSE),
        Waypoint(place, CLOSE),
    ]
    if release:
        waypoints[-1].hold = 1
        waypoints.append(Waypoint(place, OPEN, hold=FINGER_STEPS))
        waypoints.append(Waypoint(place + np.array([0.0, 0.0, RELEASE_LIFT]), OPEN))
    reset_memory = release if reset_memory is None else reset_memory
    return WaypointMoves(
        waypoints, embodiment, steps, tolerance, CARRY_TO_GOAL, place, reset_memory=reset_memory
    )


class LookFromStart(Manoeuvre):
    """Locate the object afresh where a fresh memory learned to: rise, return to the grip position the
    episode started from (every demo's first frames), reset the memory on arrival and hold still `steps`
    steps, the gripper as last commanded; then anchor's manoeuvre follows, acting on what the object head
    believes from those frames (docs/archive/RESULTS_studies.md, "push: the frame head").

    Args:
        grip: the grip point now, (3,).
        start: the grip point at the start of the episode, (3,).
        gripper: the gripper command to keep.
        steps: steps to hold still at the start pose with the fresh memory.
        travel_steps: most steps of the way there.
        tolerance: metres from the start pose that count as arrived.
        embodiment: the robot (its action scale).
    """

    phase = LOOK

    def __init__(
        self,
        grip: np.ndarray,
        start: np.ndarray,
        gripper: float,
        steps: int,
        travel_steps: int,
        tolerance: float,
        embodiment: Embodiment,
    ):
        start = np.asarray(start, dtype=np.float64).copy()
        self.target = start
        self.gripper = gripper
        self.embodiment = embodiment
        waypoints = [Waypoint(above(grip, start[2]), gripper), Waypoint(start, gripper)]
        self.travel = WaypointMoves(
            waypoints, embodiment, travel_steps, tolerance, LOOK, start, reset_memory=True
        )
        self.steps_left = steps

    def advance(self, grip: np.ndarray) -> MemoryChange | None:
        if not self.travel.finished:
            return self.travel.advance(grip)  # the memory reset, on arrival
        if self.steps_left == 0:
            self.finished = True
        return None

    def act(self, grip: np.ndarray, min_unc_action: Callable[[], np.ndarray]) -> np.ndarray:
        if not self.travel.finished:
            return self.travel.act(grip, min_unc_action)
        self.steps_left -= 1
        return self.embodiment.move_towards(grip, self.target, self.gripper)


def on_table(obj: np.ndarray, rest_height: float) -> np.ndarray:
    """The believed object (3,) moved to `rest_height`, where an object the robot does not hold lies on the
    table (the believed height itself where `rest_height` is NaN)."""
    obj = np.asarray(obj, dtype=np.float64).copy()
    if np.isfinite(rest_height):
        obj[2] = rest_height
    return obj


def regrasp(
    grip: np.ndarray,
    obj: np.ndarray,
    steps: int,
    tolerance: float,
    rest_height: float = np.nan,
    grasp_offset: np.ndarray | tuple[float, float, float] = (0.0, 0.0, 0.0),
    *,
    embodiment: Embodiment,
) -> WaypointMoves:
    """Not holding: open, rise above the grasp point (`grasp_offset` from the believed object's centre, at
    `rest_height`, `on_table`), descend to `GRASP_HEIGHT` above it, close, lift back up; then the controller
    carries it on if the fingers hold it. The manoeuvre's `held_offset` is where the object's centre then
    sits from the grip point, (3,)."""
    obj = on_table(obj, rest_height)
    grasp = obj + np.asarray(grasp_offset, dtype=np.float64) + np.array([0.0, 0.0, GRASP_HEIGHT])
    over = grasp + np.array([0.0, 0.0, APPROACH_HEIGHT])
    waypoints = [
        Waypoint(above(grip, over[2]), OPEN),
        Waypoint(over, OPEN),
        Waypoint(grasp, OPEN),
        Waypoint(grasp, CLOSE, hold=FINGER_STEPS),
        Waypoint(over, CLOSE),
    ]
    moves = WaypointMoves(
        waypoints, embodiment, steps, tolerance, REGRASP, grasp, reset_memory=True, then_carry=True
    )
    moves.held_offset = obj - grasp
    return moves


def push_to_goal(
    grip: np.ndarray,
    obj: np.ndarray,
    goal: np.ndarray,
    steps: int,
    tolerance: float,
    legs: int = PUSH_LEGS,
    rest_height: float = np.nan,
    *,
    embodiment: Embodiment,
    push: PushContact,
) -> WaypointMoves:
    """Not holding, without grasping: one straight push of the believed object toward `goal` with closed
    fingers, as the scripted demos push (the task's `push` contact geometry): rise, move above the point
    behind the object,
    descend, push it until it is level with the goal along the leg's axis, lift. The leg runs along the
    axis (x or y) on which the object is believed farther from the goal; it may take the steps its path
    needs at its speeds and `steps` more. With `legs` > 1 the controller, once the leg is over, plans the
    next one from where the policy then believes the object (`then_push`), until it believes the object
    on the goal (`on_goal`); then it hands back with a fresh memory. The object is pushed at its centre's
    height, `rest_height` where given (`on_table`)."""
    obj, goal = on_table(obj, rest_height), np.asarray(goal, dtype=np.float64)
    hover = np.array([0.0, 0.0, push.hover])
    if on_goal(obj, goal):  # nothing to push as far as the policy believes: clear the object, hand back
        clear = Waypoint(above(grip, obj[2] + push.hover), CLOSE)
        return WaypointMoves(
            [clear], embodiment, steps, tolerance, PUSH_TO_GOAL, obj.copy(), reset_memory=True
        )
    axis = int(np.argmax(np.abs(goal[:2] - obj[:2])))  # the farther axis first
    contact = push.contact[axis]
    side = 1.0 if goal[axis] >= obj[axis] else -1.0
    z = float(obj[2])  # the pushing height: the object's centre, as the demos push
    start, end = np.array([obj[0], obj[1], z]), np.array([obj[0], obj[1], z])
    start[axis] -= side * (contact + push.approach_gap)
    end[axis] = goal[axis] - side * contact
    waypoints = [
        Waypoint(above(grip, start[2] + push.hover), CLOSE),
        Waypoint(start + hover, CLOSE),
        Waypoint(start, CLOSE),
        Waypoint(end, CLOSE, speed=push.speed),
        Waypoint(end + hover, CLOSE),
    ]
    pushed_to = np.array([goal[0], goal[1], z])  # where the object should end, after the last leg
    needed = sum(
        int(np.ceil(np.linalg.norm(b.position - a.position) / b.speed))
        for a, b in zip(waypoints, waypoints[1:], strict=False)
    )
    needed += int(np.ceil(np.linalg.norm(waypoints[0].position - grip) / ANCHOR_SPEED))
    return WaypointMoves(
        waypoints,
        embodiment,
        needed + steps,
        tolerance,
        PUSH_TO_GOAL,
        pushed_to,
        reset_memory=True,
        then_push=legs - 1,
    )


def on_goal(obj: np.ndarray, goal: np.ndarray) -> bool:
    """Whether the object (3,) is believed within `PUSH_LEG_MIN` of the goal along x and along y."""
    return bool(np.all(np.abs(np.asarray(goal)[:2] - np.asarray(obj)[:2]) < PUSH_LEG_MIN))
