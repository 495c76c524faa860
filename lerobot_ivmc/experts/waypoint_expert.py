"""A scripted expert that follows waypoints of the grip point with a proportional controller.

The paper generates expert trajectories "by placing pre-defined waypoints and solving the inverse
kinematics"; here the mocap weld solves the inverse kinematics, so the expert only emits end-effector
deltas toward the active waypoint plus the discrete gripper command.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lerobot_ivmc.envs import DEMO_EPISODE_STEPS
from lerobot_ivmc.envs.fetch_env import GRIPPER_NOOP, POSITION_SCALE, IvmcFetchEnv

PositionFn = Callable[[IvmcFetchEnv], np.ndarray]


@dataclass(frozen=True)
class Waypoint:
    """A grip-point goal, computed from the env state when the waypoint becomes active.

    Args:
        position: env -> (3,) world position the grip point should reach.
        gripper: command sent while this waypoint is active (-1 close, 0 no-op, +1 open).
        tolerance: distance in metres at which the waypoint counts as reached.
        hold_steps: steps to stay after reaching it.
        settle_fingers: after reaching it, also stay until the fingers have stopped moving (a grasp or a
            release is complete). The hand-off is then observable: a learned policy sees the fingers come to
            rest and moves on, instead of having to count stationary frames.
        speed: largest grip-point displacement per step, in metres.
    """

    position: PositionFn
    gripper: int
    tolerance: float = 0.01
    hold_steps: int = 0
    settle_fingers: bool = False
    speed: float = 0.03


class WaypointExpert:
    """Drives an env through a task-specific list of waypoints; subclasses implement `plan`."""

    # Proportional gain on the position error; below 1 to avoid overshooting through the mocap weld.
    gain = 0.9
    # Steps allowed per waypoint before moving on anyway, so a blocked motion cannot stall the demo.
    max_steps_per_waypoint = 40
    # Fingers count as at rest once both moved less than this (metres) over the last step.
    finger_settle_tolerance = 1.5e-3

    def __init__(self, env: IvmcFetchEnv):
        self.env = env
        self._waypoints: list[Waypoint] = []
        self._goal: np.ndarray | None = None

    def plan(self) -> list[Waypoint]:
        raise NotImplementedError

    def reset(self) -> None:
        """Plan for the env's current scene; call after `env.reset()`."""
        self._waypoints = self.plan()
        self._index = 0
        self._goal = None
        self._steps_on_waypoint = 0
        self._held = 0
        self._last_fingers = self.env.finger_positions.copy()

    @property
    def done(self) -> bool:
        """All waypoints have been reached (the expert then holds the last one's position)."""
        return self._index >= len(self._waypoints)

    def act(self) -> np.ndarray:
        """The next action [dx, dy, dz, gripper] (float32, dx..dz in action units of 5 cm).

        Once done, the expert holds its last waypoint: still while the grip point stays within that
        waypoint's tolerance, back toward it when pushed further (by injected action noise), so the demo's
        last frames show how to hold the final pose instead of a random walk labelled "stay still".
        """
        if self.done:
            return self._hold()
        waypoint = self._waypoints[self._index]
        if self._goal is None:
            low, high = self.env.grip_workspace
            self._goal = np.clip(waypoint.position(self.env), low, high)
        error = self._goal - self.env.grip_position
        fingers = self.env.finger_positions.copy()
        fingers_at_rest = np.abs(fingers - self._last_fingers).max() < self.finger_settle_tolerance
        self._last_fingers = fingers
        reached = np.linalg.norm(error) < waypoint.tolerance
        if reached:
            self._held += 1
        self._steps_on_waypoint += 1
        settled = not waypoint.settle_fingers or (self._held > 1 and fingers_at_rest)
        if (reached and self._held > waypoint.hold_steps and settled) or (
            self._steps_on_waypoint >= self.max_steps_per_waypoint
        ):
            # Act for the next waypoint right away, so that the label switches on the very frame whose
            # state completed the waypoint (no frame of the old waypoint's command after it is done).
            self._advance()
            return self.act()
        return self._toward(error, waypoint.speed, waypoint.gripper)

    def _toward(self, error: np.ndarray, speed: float, gripper: float) -> np.ndarray:
        """The proportional step along `error` (metres), at most `speed` long, with a gripper command."""
        step = self.gain * error
        norm = np.linalg.norm(step)
        if norm > speed:
            step *= speed / norm
        return np.array([*(step / POSITION_SCALE), gripper], dtype=np.float32)

    def _hold(self) -> np.ndarray:
        """After the last waypoint: no motion within its tolerance, back toward it beyond."""
        still = np.array([0.0, 0.0, 0.0, GRIPPER_NOOP], dtype=np.float32)
        if self._goal is None:  # nothing to hold: an empty plan
            return still
        last = self._waypoints[-1]
        error = self._goal - self.env.grip_position
        if np.linalg.norm(error) <= last.tolerance:
            return still
        return self._toward(error, last.speed, GRIPPER_NOOP)

    def _advance(self) -> None:
        self._index += 1
        if not self.done:
            self._goal = None
        elif np.linalg.norm(self._goal - self.env.grip_position) >= self._waypoints[-1].tolerance:
            # The last waypoint, left on a timeout, not reached: hold where the expert finished, not a goal it
            # cannot reach. (Reached, its goal stays: `_hold` keeps the grip point there.)
            self._goal = self.env.grip_position.copy()
        self._steps_on_waypoint = 0
        self._held = 0


def run_expert_episode(
    env: IvmcFetchEnv,
    expert: WaypointExpert,
    seed: int | None = None,
    max_steps: int = DEMO_EPISODE_STEPS,
    options: dict | None = None,
    on_step: Callable[[dict, np.ndarray, dict], None] | None = None,
    perturb: Callable[[np.ndarray], np.ndarray] | None = None,
) -> dict:
    """Roll the expert out for `max_steps` steps (or until the env terminates); return the final info.

    `on_step(observation, action, info)` is called with the observation the action was chosen from and the
    expert's action. `perturb(action)`, if given, returns the action actually executed (noise injection);
    the expert, being closed-loop, corrects the deviation on the next steps.
    """
    observation, info = env.reset(seed=seed, options=options)
    expert.reset()
    for _ in range(max_steps):
        action = expert.act()
        executed = action if perturb is None else perturb(action)
        next_observation, _, terminated, truncated, info = env.step(executed)
        if on_step is not None:
            on_step(observation, action, info)
        observation = next_observation
        if terminated or truncated:
            break
    return info
