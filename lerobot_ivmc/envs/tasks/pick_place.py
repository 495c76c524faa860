"""Pick-and-place: pick the red cube up and drop it on the blue target."""

from __future__ import annotations

from lerobot_ivmc.envs.fetch_env import IvmcFetchEnv
from lerobot_ivmc.envs.scene_model import ObjectShape
from lerobot_ivmc.envs.tasks.common import TABLE_GRID, distance, is_picked, rests_on_target

# The gripper has reached the cube when its grip point is this close to the cube's centre.
PICK_REACH_DISTANCE = 0.03


class PickPlaceEnv(IvmcFetchEnv):
    """Milestones: ``reach`` (grip point at the cube), ``pick`` (cube grasped and lifted),
    ``place`` (after the pick, the cube released and resting on the target)."""

    task = "pick_place"
    task_description = "Pick up the red cube and place it on the blue target."
    subtasks = ("reach", "pick", "place")
    object_shape = ObjectShape(half_size=(0.025, 0.025, 0.025), mass=2.0)
    object_grid = TABLE_GRID
    target_grid = TABLE_GRID

    def _subtask_status(self) -> dict[str, bool]:
        picked = self.progress["pick"] or is_picked(self)
        return {
            "reach": distance(self.grip_position, self.object_position) < PICK_REACH_DISTANCE,
            "pick": picked,
            # A cube pushed onto the target is not placed: it must have been picked up first.
            "place": picked and rests_on_target(self) and not self.is_grasped(),
        }
