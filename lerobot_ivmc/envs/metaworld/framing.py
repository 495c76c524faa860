"""Frame the camera on a MetaWorld task's workspace (the `framed` render style).

LeRobot's corner2 camera sees the whole table: at 64 px a pick-place puck is two or three pixels, and the
hand, objects and goals of a task fill only the left half of the frame. Framing turns the camera (from
where it stands) to the centre of the task's workspace and narrows its field of view until the workspace,
plus a margin, just fills the frame. The workspace comes from MetaWorld's own task definition: the hand's
start and every object and goal position the task's scenes are drawn from. Parts that move beyond those
positions (a door handle sweeping open) may leave the frame: `diagnostics/metaworld_framing.py` measures,
per task, the share of a scripted episode's hand, object and goal positions inside it.
"""

from __future__ import annotations

import mujoco
import numpy as np

# World metres added around the workspace box on every side, and above it for the hand's lifts.
MARGIN = 0.03
LIFT = 0.05


def task_workspace(raw_env) -> tuple[np.ndarray, np.ndarray]:
    """(3,) low and (3,) high corners (world metres) of the box holding a MetaWorld task's hand start and
    every position its scenes draw objects and goals from (`_random_reset_space`, `goal_space`)."""
    points = [np.asarray(raw_env.hand_init_pos, dtype=np.float64)]
    for space in (raw_env._random_reset_space, getattr(raw_env, "goal_space", None)):
        if space is None:
            continue
        for corner in (space.low, space.high):
            corner = np.asarray(corner, dtype=np.float64)
            if corner.size % 3:
                raise ValueError(
                    f"{type(raw_env).__name__}'s spaces do not hold 3-D positions; it cannot be framed."
                )
            points += list(corner.reshape(-1, 3))
    points = np.stack(points)
    low, high = points.min(0) - MARGIN, points.max(0) + MARGIN
    high[2] += LIFT
    return low, high


def look_at(rotation: np.ndarray, position: np.ndarray, target: np.ndarray) -> np.ndarray:
    """A camera's (3, 3) world rotation (columns: right, up, back) turned by the smallest rotation that makes
    it look at `target` from `position` (MuJoCo cameras look along their -z)."""
    old_axis = rotation[:, 2]
    new_axis = (position - target) / np.linalg.norm(position - target)
    cross = np.cross(old_axis, new_axis)
    sine, cosine = np.linalg.norm(cross), float(old_axis @ new_axis)
    if sine < 1e-12:
        return rotation.copy()
    k = cross / sine
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return (np.eye(3) + sine * skew + (1 - cosine) * skew @ skew) @ rotation


def frame_camera(
    model: mujoco.MjModel, data: mujoco.MjData, camera: str, low: np.ndarray, high: np.ndarray
) -> None:
    """Turn fixed camera `camera` of `model` to the centre of the box [low, high] and set its vertical field
    of view (square frames) so the box's corners just fit. Changes only the camera; `data` is read."""
    camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
    if camera_id < 0 or model.cam_mode[camera_id] != mujoco.mjtCamLight.mjCAMLIGHT_FIXED:
        raise ValueError(f"Camera {camera!r} is not a fixed camera of this model; it cannot be framed.")
    mujoco.mj_kinematics(model, data)
    body_rotation = data.xmat[model.cam_bodyid[camera_id]].reshape(3, 3)
    position = data.cam_xpos[camera_id].copy()
    rotation = look_at(data.cam_xmat[camera_id].reshape(3, 3), position, (low + high) / 2)
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    in_camera = (corners - position) @ rotation  # (8, 3): right, up, back
    half_tangent = np.abs(in_camera[:, :2] / -in_camera[:, 2:]).max()
    quaternion = np.empty(4)
    mujoco.mju_mat2Quat(quaternion, (body_rotation.T @ rotation).ravel())
    model.cam_quat[camera_id] = quaternion
    model.cam_fovy[camera_id] = np.degrees(2 * np.arctan(half_tangent))
    mujoco.mj_kinematics(model, data)
