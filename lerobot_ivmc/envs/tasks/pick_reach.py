"""Pick-and-reach: pick the red stick up at one end and touch the blue target with the other end."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.envs.fetch_env import IvmcFetchEnv
from lerobot_ivmc.envs.scene_model import TABLE_TOP_Z, ObjectShape
from lerobot_ivmc.envs.scenes import Grid
from lerobot_ivmc.envs.tasks.common import distance, is_picked, xy_distance

STICK_HALF_LENGTH = 0.1
# The stick is grasped this far in from its near end (the end closer to the robot).
GRASP_INSET = 0.03
PICK_REACH_DISTANCE = 0.03
# The far end touches the target when it is over the disc and at most this high above the table.
TOUCH_HEIGHT = 0.03


class PickReachEnv(IvmcFetchEnv):
    """Milestones: ``reach`` (grip point at the stick's near end), ``pick`` (stick grasped and lifted),
    ``task`` (while held, the stick's far end touches the target)."""

    task = "pick_reach"
    task_description = "Pick up the red stick at one end and reach the blue target with the other end."
    subtasks = ("reach", "pick", "task")
    # The stick lies along x so the fingers, which close along y, clamp across its width.
    object_shape = ObjectShape(half_size=(STICK_HALF_LENGTH, 0.0125, 0.0125), mass=0.3)
    # Two non-overlapping 6x8 grids, 3 cm apart: sticks on the robot's right, targets on its left.
    object_grid = Grid(x_range=(1.20, 1.35), y_range=(0.48, 0.69))
    target_grid = Grid(x_range=(1.30, 1.45), y_range=(0.81, 1.02))
    object_held_at_end = True  # the stick touches the target while held

    @property
    def grasp_point(self) -> np.ndarray:
        """Where the gripper should hold the stick: near its end closer to the robot, (3,)."""
        return self._point_on_stick(-STICK_HALF_LENGTH + GRASP_INSET)

    @property
    def free_end(self) -> np.ndarray:
        """Centre of the stick's far end face, (3,)."""
        return self._point_on_stick(STICK_HALF_LENGTH)

    def _point_on_stick(self, offset_along: float) -> np.ndarray:
        return self.object_position + self.object_rotation @ np.array([offset_along, 0.0, 0.0])

    def _subtask_status(self) -> dict[str, bool]:
        end = self.free_end
        touches = (
            xy_distance(end, self.target_position) < self.target_radius
            and end[2] < TABLE_TOP_Z + TOUCH_HEIGHT
        )
        return {
            "reach": distance(self.grip_position, self.grasp_point) < PICK_REACH_DISTANCE,
            "pick": is_picked(self),
            "task": touches and self.is_grasped(),
        }
