"""A missed grasp, seen by proprioception alone (`--recovery.grasp_miss`): the policy keeps its gripper
closed while the fingers read closed on nothing. A failure the robot can see however sure its policy is."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.envs.embodiment import Embodiment


class GraspMissAlarm:
    """Per rollout, the run of consecutive steps in normal operation with the gripper commanded closed and
    the fingers closed on nothing (`Embodiment.closed_on_nothing`); an alarm once it reaches `steps`.

    Args:
        num_rollouts: B.
        steps: the run's length that raises the alarm (a grasp closing on its object passes through "closed
            on nothing" for a few steps only).
        embodiment: the robot's gripper commands and finger reading.
    """

    def __init__(self, num_rollouts: int, steps: int, embodiment: Embodiment):
        if steps < 1:
            raise ValueError(f"A grasp-miss alarm needs a run of at least 1 step, got {steps}.")
        self.steps = steps
        self.embodiment = embodiment
        self.run = np.zeros(num_rollouts, dtype=np.int64)

    def update(self, fingers: np.ndarray, commands: np.ndarray, active: np.ndarray) -> np.ndarray:
        """Count this step and say which rollouts' grasps missed.

        Args:
            fingers: (B, F) the finger reading of this step's observation.
            commands: (B,) each rollout's last executed gripper command.
            active: (B,) bool, rollouts in normal operation (a manoeuvre's steps break the run).

        Returns:
            (B,) bool: rollouts whose run has reached `steps`.
        """
        closing = np.array([self.embodiment.closes(float(c)) for c in commands])
        missed = active & closing & self.embodiment.closed_on_nothing(fingers)
        self.run = np.where(missed, self.run + 1, 0)
        return self.run >= self.steps

    def clear(self, rows: np.ndarray) -> None:
        """Start the runs of `rows` again (they fired a recovery)."""
        self.run[rows] = 0
