"""Push expert: the paper's two-stage rectangular push (forward to align, then sideways onto the target)."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.envs.fetch_env import GRIPPER_CLOSE
from lerobot_ivmc.experts.waypoint_expert import Waypoint, WaypointExpert

# Grip point to cube centre when a closed finger pair touches a cube face: 2.5 cm half-width plus the
# fingers' half-extent along the push (1.35 cm along x, 1.5 cm along y).
CONTACT_X, CONTACT_Y = 0.0385, 0.04
APPROACH_GAP = 0.03  # start each push this far from contact
HOVER = 0.08  # travel height above the cube centre between pushes
PUSH_SPEED = 0.022


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
