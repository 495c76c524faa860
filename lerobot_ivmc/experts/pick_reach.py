"""Pick-and-reach expert: grasp the stick near one end, lift it, and touch the target with the far end."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.envs.fetch_env import GRIPPER_CLOSE, GRIPPER_OPEN
from lerobot_ivmc.envs.scene_model import TABLE_TOP_Z
from lerobot_ivmc.experts.waypoint_expert import Waypoint, WaypointExpert

HOVER = 0.1
TOUCH_END_HEIGHT = 0.012  # aim the far end's centre this far above the table


class PickReachExpert(WaypointExpert):
    def plan(self) -> list[Waypoint]:
        env = self.env
        target = env.target_position

        def at_grasp(env) -> np.ndarray:
            return env.grasp_point

        def end_over_target(height: float):
            # Place the grip point so that the far end, at its current offset from the grip, meets the target.
            def position(env) -> np.ndarray:
                offset = env.grip_position - env.free_end
                goal = np.array([target[0], target[1], TABLE_TOP_Z + height]) + offset
                return goal

            return position

        return [
            Waypoint(lambda env: at_grasp(env) + [0, 0, HOVER], GRIPPER_OPEN, tolerance=0.02),
            Waypoint(at_grasp, GRIPPER_OPEN, tolerance=0.008),
            Waypoint(at_grasp, GRIPPER_CLOSE, tolerance=0.02, settle_fingers=True),
            Waypoint(lambda env: env.grip_position + [0, 0, HOVER], GRIPPER_CLOSE, tolerance=0.02),
            Waypoint(end_over_target(HOVER), GRIPPER_CLOSE, tolerance=0.015),
            Waypoint(end_over_target(TOUCH_END_HEIGHT), GRIPPER_CLOSE, tolerance=0.008),
        ]
