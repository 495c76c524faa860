"""Push expert: the paper's two-stage rectangular push (forward to align, then sideways onto the target)."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.envs.fetch_env import GRIPPER_CLOSE
from lerobot_ivmc.envs.tasks.push import PUSH_CONTACT
from lerobot_ivmc.experts.waypoint_expert import Waypoint, WaypointExpert

# The push task's contact geometry (`envs/tasks/push.py`).
CONTACT_X, CONTACT_Y = PUSH_CONTACT.contact
APPROACH_GAP, HOVER, PUSH_SPEED = PUSH_CONTACT.approach_gap, PUSH_CONTACT.hover, PUSH_CONTACT.speed


class PushExpert(WaypointExpert):
    def plan(self) -> list[Waypoint]:
        env = self.env
        z = env.object_shape.rest_height
        target = env.target_position

        def behind(env) -> np.ndarray:
            cube = env.object_position
            return np.array([cube[0] - CONTACT_X - APPROACH_GAP, cube[1], z])

        def beside(env) -> np.ndarray:
            cube = env.object_position
            side = np.sign(target[1] - cube[1])
            return np.array([cube[0], cube[1] - side * (CONTACT_Y + APPROACH_GAP), z])

        def push_forward(env) -> np.ndarray:
            return np.array([target[0] - CONTACT_X, env.object_position[1], z])

        def push_sideways(env) -> np.ndarray:
            side = np.sign(target[1] - env.object_position[1])
            return np.array([env.object_position[0], target[1] - side * CONTACT_Y, z])

        def lifted(env) -> np.ndarray:
            return env.grip_position + [0.0, 0.0, HOVER]

        return [
            Waypoint(lambda env: behind(env) + [0, 0, HOVER], GRIPPER_CLOSE, tolerance=0.02),
            Waypoint(behind, GRIPPER_CLOSE),
            Waypoint(push_forward, GRIPPER_CLOSE, tolerance=0.005, speed=PUSH_SPEED),
            Waypoint(lifted, GRIPPER_CLOSE, tolerance=0.02),
            Waypoint(lambda env: beside(env) + [0, 0, HOVER], GRIPPER_CLOSE, tolerance=0.02),
            Waypoint(beside, GRIPPER_CLOSE),
            Waypoint(push_sideways, GRIPPER_CLOSE, tolerance=0.005, speed=PUSH_SPEED),
            Waypoint(lifted, GRIPPER_CLOSE, tolerance=0.02),
        ]
