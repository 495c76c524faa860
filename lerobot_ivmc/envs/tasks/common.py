"""Geometry shared by the tasks: the spawn grid on the table and the milestone tests."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.envs.fetch_env import IvmcFetchEnv
from lerobot_ivmc.envs.scenes import Grid

# The 6x8 spawn grid of cubes and targets: 6 cm apart, in front of the robot, inside the arm's reach.
TABLE_GRID = Grid(x_range=(1.15, 1.45), y_range=(0.54, 0.96))
# A lifted object counts as picked once its centre is this far above its resting height.
PICK_LIFT = 0.03
# An object lying within this height of its resting height is on the table.
ON_TABLE_TOLERANCE = 0.01


def distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b))


def xy_distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a[:2] - b[:2]))


def rests_on_target(env: IvmcFetchEnv) -> bool:
    """The object's centre lies over the target disc and the object is down on the table."""
    on_disc = xy_distance(env.object_position, env.target_position) < env.target_radius
    return on_disc and abs(env.object_lift()) < ON_TABLE_TOLERANCE


def is_picked(env: IvmcFetchEnv) -> bool:
    """Both fingers hold the object and it is lifted off the table."""
    return env.object_lift() > PICK_LIFT and env.is_grasped()
