"""What recovery needs of a robot, behind one small interface: where the grip point and the fingers are in
the observation, how far one action unit moves the arm, and the gripper's commands in the policy's action.
Each suite defines its robot's (`fetch_env.EMBODIMENT`, `metaworld.embodiment.SAWYER`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# The gripper entry of a manoeuvre's action that means "leave the fingers as they are" (`Embodiment.hold`).
HOLD = float("nan")


@dataclass(frozen=True)
class Embodiment:
    """A robot arm with a delta end-effector action [dx, dy, dz, gripper].

    Args:
        name: the robot.
        metres_per_action_unit: how far one unit of dx, dy or dz moves the grip point.
        gripper_open: the command that opens the fingers.
        gripper_close: the command that closes them.
        gripper_noop: a command that leaves them as they are; None where there is none (MetaWorld's Sawyer
            takes a grab effort), and the last command is repeated instead.
        grip_state_indices: where the grip point's x, y, z sit in `observation.environment_state`.
        finger_state_indices: where the fingers sit in `observation.state`.
        held_gap: the finger reading (the sum of the finger entries) the fingers rest between when closed on
            something: below it they closed on nothing, above it they are open.
        approach_gain: the fraction of the way to a target one step commands (before the action's limit):
            1 for an arm whose action moves the grip point itself; below 1 for one whose action moves a
            target the hand lags behind (MetaWorld's mocap), where a full step overshoots and oscillates.
    """

    name: str
    metres_per_action_unit: float
    gripper_open: float
    gripper_close: float
    gripper_noop: float | None
    grip_state_indices: tuple[int, int, int]
    finger_state_indices: tuple[int, ...]
    held_gap: tuple[float, float]
    approach_gain: float = 1.0

    def closes(self, command: float) -> bool:
        """Whether a gripper command closes the fingers: it is nearer "close" than "open" (a policy's effort
        of 0.6, or a continuous gripper's 0.97, closes MetaWorld's Sawyer as 1 does)."""
        return abs(command - self.gripper_close) < abs(command - self.gripper_open)

    def holds(self, fingers: np.ndarray) -> bool:
        """Whether fingers read as `fingers` (F,) rest apart on something."""
        gap = float(np.sum(fingers))
        return self.held_gap[0] < gap < self.held_gap[1]

    def closed_on_nothing(self, fingers: np.ndarray) -> np.ndarray:
        """(B,) whether fingers read as `fingers` (B, F) have closed past anything they could hold."""
        return np.asarray(fingers, dtype=np.float64).sum(axis=-1) <= self.held_gap[0]

    def move_towards(self, grip: np.ndarray, target: np.ndarray, gripper: float = HOLD) -> np.ndarray:
        """A (4,) action that moves the grip point as far toward `target` (metres) as one step allows."""
        delta = np.clip(self.approach_gain * (target - grip) / self.metres_per_action_unit, -1.0, 1.0)
        return np.array([*delta, gripper], dtype=np.float32)

    def hold(self, last_command: np.ndarray) -> np.ndarray:
        """The gripper commands (B,) that leave the fingers as they are, given each rollout's last one."""
        if self.gripper_noop is None:
            return last_command.astype(np.float64)
        return np.full(len(last_command), self.gripper_noop, dtype=np.float64)

    def remember(self, last_command: np.ndarray, executed: np.ndarray) -> np.ndarray:
        """Each rollout's last gripper command other than no-op, after it executed `executed` (B,)."""
        if self.gripper_noop is None:
            return executed.astype(np.float64)
        commands = np.rint(executed)
        return np.where(commands != self.gripper_noop, commands, last_command)
