"""The recovery motions: min_unc's back-track and minimum-uncertainty steps, rand's random moves, init's move
(anchor's are in `anchor.py`).

Each is a small state machine for one rollout of a batch. At the start of every step the controller calls
`advance` with the grip point's position (it may end the manoeuvre and ask for a memory change); after the
policy's Monte Carlo pass it calls `act` for the action. Positions are world coordinates in metres.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from torch import Tensor

from lerobot_ivmc.envs.embodiment import HOLD, Embodiment

# Phases recorded per step in the traces (CARRY_TO_GOAL to LOOK: `anchor.py`'s manoeuvres; RETRY: retry's;
# REACH: reach's).
(
    NORMAL,
    BACKTRACK,
    FOLLOW_MIN_UNC,
    RANDOM_MOVES,
    MOVE_TO_INIT,
    CARRY_TO_GOAL,
    PUSH_TO_GOAL,
    REGRASP,
    LOOK,
    RETRY,
    REACH,
) = range(11)
PHASE_NAMES = (
    "normal",
    "backtrack",
    "follow_min_unc",
    "rand",
    "init",
    "carry_to_goal",
    "push_to_goal",
    "regrasp",
    "look",
    "retry",
    "reach",
)


@dataclass
class FifoEntry:
    """One normal step in min_unc's back-track FIFO.

    Attributes:
        uncertainty: the step's uncertainty.
        memory: the rollout's policy memory before the step (its row of each memory tensor).
        grip: the grip point's position at the step, (3,).
        step: the step's index in the episode.
    """

    uncertainty: float
    memory: tuple[Tensor, ...]
    grip: np.ndarray
    step: int


@dataclass
class MemoryChange:
    """What a manoeuvre asks of the policy memory: restore `memory` (a row), or reset it when None."""

    memory: tuple[Tensor, ...] | None


class Manoeuvre:
    """Base class: `phase` for the traces, `finished` once over. What follows a manoeuvre is its strategy's
    choice (`RecoveryStrategy.follow`)."""

    phase: int = NORMAL
    finished: bool = False

    def advance(self, grip: np.ndarray) -> MemoryChange | None:
        raise NotImplementedError

    def act(self, grip: np.ndarray, min_unc_action: Callable[[], np.ndarray]) -> np.ndarray:
        raise NotImplementedError


class BacktrackThenFollow(Manoeuvre):
    """min_unc: move back to the FIFO's point of minimum uncertainty, restore the memory saved there (or
    reset it, or keep it), then for `steps` steps execute the sampled action of lowest foreseen uncertainty.

    Args:
        fifo: the last normal steps, oldest first.
        steps: steps of following the minimum foreseen uncertainty.
        horizon: most steps the back-track may take.
        tolerance: the back-track ends this close (metres) to the target.
        memory: after the back-track, "restore" the memory saved at the target, "reset" it, or "keep" the
            memory as it is.
    """

    def __init__(
        self,
        fifo: list[FifoEntry],
        steps: int,
        horizon: int,
        tolerance: float,
        embodiment: Embodiment,
        memory: str = "restore",
    ):
        if not fifo:
            raise ValueError("Back-tracking needs at least one step in the FIFO.")
        self.target = min(fifo, key=lambda entry: entry.uncertainty)
        self.phase = BACKTRACK
        self.steps_left = steps
        self.backtrack_steps_left = horizon
        self.tolerance = tolerance
        self.memory = memory
        self.embodiment = embodiment
        self.finished = False

    def advance(self, grip: np.ndarray) -> MemoryChange | None:
        if self.phase == BACKTRACK and (
            np.linalg.norm(grip - self.target.grip) <= self.tolerance or self.backtrack_steps_left == 0
        ):
            self.phase = FOLLOW_MIN_UNC
            if self.memory == "keep":
                return None
            return MemoryChange(None if self.memory == "reset" else self.target.memory)
        if self.phase == FOLLOW_MIN_UNC and self.steps_left == 0:
            self.finished = True
        return None

    def act(self, grip: np.ndarray, min_unc_action: Callable[[], np.ndarray]) -> np.ndarray:
        if self.phase == BACKTRACK:
            self.backtrack_steps_left -= 1
            return self.embodiment.move_towards(grip, self.target.grip)
        self.steps_left -= 1
        return min_unc_action()


class RandomMoves(Manoeuvre):
    """rand: `steps` uniform random end-effector moves with the gripper left as it is, then a memory reset."""

    phase = RANDOM_MOVES

    def __init__(self, steps: int, scale: float, rng: np.random.Generator):
        self.moves = rng.uniform(-scale, scale, size=(steps, 3))
        self.done_steps = 0
        self.finished = False

    def advance(self, grip: np.ndarray) -> MemoryChange | None:
        if self.done_steps == len(self.moves):
            self.finished = True
            return MemoryChange(None)
        return None

    def act(self, grip: np.ndarray, min_unc_action: Callable[[], np.ndarray]) -> np.ndarray:
        move = self.moves[self.done_steps]
        self.done_steps += 1
        return np.array([*move, HOLD], dtype=np.float32)


class MoveToInit(Manoeuvre):
    """init: open the gripper and move the grip point to a random point of a ball around the episode's
    initial grip position (at most `steps` steps), then a memory reset."""

    phase = MOVE_TO_INIT

    def __init__(
        self,
        centre: np.ndarray,
        radius: float,
        steps: int,
        tolerance: float,
        rng: np.random.Generator,
        embodiment: Embodiment,
    ):
        self.embodiment = embodiment
        self.target = point_in_ball(centre, radius, rng)
        self.steps_left = steps
        self.tolerance = tolerance
        self.finished = False

    def advance(self, grip: np.ndarray) -> MemoryChange | None:
        if self.steps_left == 0 or np.linalg.norm(grip - self.target) <= self.tolerance:
            self.finished = True
            return MemoryChange(None)
        return None

    def act(self, grip: np.ndarray, min_unc_action: Callable[[], np.ndarray]) -> np.ndarray:
        self.steps_left -= 1
        return self.embodiment.move_towards(grip, self.target, self.embodiment.gripper_open)


# A `WaypointPath` stop counts as reached once the grip point has come no closer than STALL_PROGRESS
# (metres) for STALL_STEPS steps.
STALL_PROGRESS, STALL_STEPS = 0.002, 5


@dataclass
class Stop:
    """A grip-point position a `WaypointPath` moves to with a gripper command (`HOLD`: as it is), staying
    `hold` steps once there."""

    position: np.ndarray
    gripper: float
    hold: int = 0


class WaypointPath(Manoeuvre):
    """Moves the grip point through `stops` as fast as the robot's action allows, then hands back to the
    policy with a fresh memory (at most `steps` steps). A stop the grip point cannot reach (the table or
    the object blocks it) counts as reached once the grip point has come no closer for `STALL_STEPS` steps.

    Args:
        stops: in order.
        steps: most steps of the path.
        tolerance: metres from a stop that count as reached.
        embodiment: the robot (its action scale and gripper commands).
        phase: the phase recorded in the traces.
        target: the point the recovery event reports, (3,).
    """

    def __init__(
        self,
        stops: list[Stop],
        steps: int,
        tolerance: float,
        embodiment: Embodiment,
        phase: int,
        target: np.ndarray,
    ):
        self.stops = list(stops)
        self.steps_left = steps
        self.tolerance = tolerance
        self.embodiment = embodiment
        self.phase = phase
        self.target = np.asarray(target, dtype=np.float64)
        self.held = 0
        self.closest, self.stalled = np.inf, 0  # the stop's closest distance so far, steps since
        self.finished = False

    def reached(self, grip: np.ndarray) -> bool:
        """Whether the grip point is at the current stop, or has stalled on its way there."""
        distance = float(np.linalg.norm(grip - self.stops[0].position))
        if distance < self.closest - STALL_PROGRESS:
            self.closest, self.stalled = distance, 0
        return distance <= self.tolerance or self.stalled >= STALL_STEPS

    def advance(self, grip: np.ndarray) -> MemoryChange | None:
        while self.stops and self.reached(grip):
            if self.held < self.stops[0].hold:
                break
            self.stops.pop(0)
            self.held = 0
            self.closest, self.stalled = np.inf, 0
        if not self.stops or self.steps_left == 0:
            self.finished = True
            return MemoryChange(None)
        return None

    def act(self, grip: np.ndarray, min_unc_action: Callable[[], np.ndarray]) -> np.ndarray:
        self.steps_left -= 1
        stop = self.stops[0]
        if self.reached(grip):
            self.held += 1
        else:
            self.stalled += 1
        return self.embodiment.move_towards(grip, stop.position, stop.gripper)


def point_in_ball(centre: np.ndarray, radius: float, rng: np.random.Generator) -> np.ndarray:
    """A point drawn uniformly in the ball of `radius` around `centre`, (3,) (two draws of `rng` even where
    the radius is 0)."""
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    return np.asarray(centre, dtype=np.float64) + direction * radius * rng.uniform() ** (1.0 / 3.0)


def above(point: np.ndarray, height: float) -> np.ndarray:
    """`point` raised (never lowered) to `height`, (3,): the way straight up from the grip point, with no
    sweep low over the table."""
    return np.array([point[0], point[1], max(float(point[2]), float(height))], dtype=np.float64)


class ReturnToStart(WaypointPath):
    """retry: open the fingers, rise to the start height, return to the episode's start grip position and
    hand back to the policy with a fresh memory (at most `steps` steps), as a new episode from the scene as
    it now is.

    Args:
        grip: the grip point now, (3,).
        start: the grip point at the episode's start, (3,).
        steps: most steps of the way.
        tolerance: metres from a waypoint that count as reached.
        embodiment: the robot (its action scale and gripper command).
    """

    def __init__(
        self, grip: np.ndarray, start: np.ndarray, steps: int, tolerance: float, embodiment: Embodiment
    ):
        start = np.asarray(start, dtype=np.float64).copy()
        open_ = embodiment.gripper_open
        stops = [Stop(above(grip, float(start[2])), open_), Stop(start, open_)]
        super().__init__(stops, steps, tolerance, embodiment, RETRY, start)
