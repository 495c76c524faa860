"""Pick-and-place expert: grasp the cube from above, carry it over the target, lower and release it."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.envs.fetch_env import GRIPPER_CLOSE, GRIPPER_OPEN
from lerobot_ivmc.experts.waypoint_expert import Waypoint, WaypointExpert

HOVER = 0.1  # approach and carry height above the cube's resting centre
RELEASE_HEIGHT = 0.02  # the cube's centre is released this far above its resting height


class PickPlaceExpert(WaypointExpert):
    def plan(self) -> list[Waypoint]:
        env = self.env
        z = env.object_shape.rest_height
        target = env.target_position

        def at_cube(env) -> np.ndarray:
            return np.array([*env.object_position[:2], z])

        def over_target(height: float):
            return lambda env: np.array([target[0], target[1], z + height])

        return [
            Waypoint(lambda env: at_cube(env) + [0, 0, HOVER], GRIPPER_OPEN, tolerance=0.02),
            Waypoint(at_cube, GRIPPER_OPEN, tolerance=0.008),
            Waypoint(at_cube, GRIPPER_CLOSE, tolerance=0.02, settle_fingers=True),
            Waypoint(lambda env: at_cube(env) + [0, 0, HOVER], GRIPPER_CLOSE, tolerance=0.02),
            Waypoint(over_target(HOVER), GRIPPER_CLOSE, tolerance=0.015),
            Waypoint(over_target(RELEASE_HEIGHT), GRIPPER_CLOSE, tolerance=0.01),
            Waypoint(over_target(RELEASE_HEIGHT), GRIPPER_OPEN, tolerance=0.02, settle_fingers=True),
            Waypoint(over_target(HOVER), GRIPPER_OPEN, tolerance=0.02),
        ]
