"""Push: slide the red cube onto the blue target with a two-stage rectangular push."""

from __future__ import annotations

from lerobot_ivmc.envs.fetch_env import IvmcFetchEnv
from lerobot_ivmc.envs.scene_model import ObjectShape
from lerobot_ivmc.envs.scenes import Scene
from lerobot_ivmc.envs.task_traits import PushContact
from lerobot_ivmc.envs.tasks.common import TABLE_GRID, distance, rests_on_target

# The gripper touches a face of the cube when its grip point is within this distance of the cube's
# centre (2.5 cm half-width plus the finger's 1.35 cm half-thickness, plus slack).
PUSH_REACH_DISTANCE = 0.05
# How closed fingers push the cube (the scripted expert's and recovery's): grip point to cube centre at
# contact, 2.5 cm half-width plus the fingers' half-extent along the push (1.35 cm along x, 1.5 cm along y);
# each push starts 3 cm from contact, travels 8 cm above the cube's centre between pushes, at 2.2 cm a step.
PUSH_CONTACT = PushContact(contact=(0.0385, 0.04), approach_gap=0.03, hover=0.08, speed=0.022)


class PushEnv(IvmcFetchEnv):
    """Milestones: ``reach`` (the gripper is at the cube), ``push`` (the cube rests on the target)."""

    task = "push"
    task_description = "Push the red cube onto the blue target."
    subtasks = ("reach", "push")
    object_shape = ObjectShape(half_size=(0.025, 0.025, 0.025), mass=2.0)
    object_grid = TABLE_GRID
    target_grid = TABLE_GRID
    object_picked = False  # pushed, never lifted
    push_contact = PUSH_CONTACT

    @classmethod
    def is_valid_scene(cls, scene: Scene) -> bool:
        # The paper's push goes forward (away from the robot) to align with the target, then sideways:
        # the target is in a further row and in another column.
        object_row, object_col = cls.object_grid.cell(scene.object_cell)
        target_row, target_col = cls.target_grid.cell(scene.target_cell)
        return target_row > object_row and target_col != object_col

    def _subtask_status(self) -> dict[str, bool]:
        return {
            "reach": distance(self.grip_position, self.object_position) < PUSH_REACH_DISTANCE,
            "push": rests_on_target(self),
        }
