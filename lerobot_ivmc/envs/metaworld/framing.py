"""Frame the camera on a MetaWorld task's workspace (the `framed` render style).

LeRobot's corner2 camera sees the whole table: at 64 px a pick-place puck is two or three pixels, and the
hand, objects and goals of a task fill only the left half of the frame. Framing turns the camera (from
where it stands) to the centre of the task's workspace and narrows its field of view until the workspace,
plus a margin, just fills the frame (never wider than the camera's own view). The workspace comes from
MetaWorld's own task definition: the hand's start, every position the task's scenes draw and its goals.
Parts that move beyond those positions may leave the frame: `diagnostics/metaworld_framing.py` measures,
per task, the share of a scripted episode's hand, object and goal positions inside it.
"""

from __future__ import annotations

import mujoco
import numpy as np

# World metres added around the workspace box on every side, and above it for the hand's lifts.
MARGIN = 0.03
LIFT = 0.05


def task_workspace(raw_env) -> tuple[np.ndarray, np.ndarray]:
    """(3,) low and (3,) high corners (world metres) of the box holding a MetaWorld task's hand start, every
    position its scenes are drawn from (`_random_reset_space`) and its goals (`goal_space`, unless a task sets
    that to the hand's whole range, as drawer-open and button-press do), with `MARGIN` on every side and
    `LIFT` above."""
    spaces = [raw_env._random_reset_space]
    goal_space = getattr(raw_env, "goal_space", None)
    hand_range = (np.asarray(raw_env.hand_low), np.asarray(raw_env.hand_high))
    if goal_space is not None and not (
        np.allclose(goal_space.low, hand_range[0]) and np.allclose(goal_space.high, hand_range[1])
    ):
        spaces.append(goal_space)
    points = [np.asarray(raw_env.hand_init_pos, dtype=np.float64)[None]]
    for space in spaces:
        for corner in (np.asarray(space.low, dtype=np.float64), np.asarray(space.high, dtype=np.float64)):
            if corner.size % 3:
                raise ValueError(
                    f"{type(raw_env).__name__}'s spaces do not hold 3-D positions; it cannot be framed."
                )
            points.append(corner.reshape(-1, 3))
    points = np.concatenate(points)
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
    of view (square frames) so the box's corners just fit, never wider than its own. `data` is brought up
    to date with `mj_forward` before (the camera's pose) and after (the new view)."""
    camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
    if camera_id < 0 or model.cam_mode[camera_id] != mujoco.mjtCamLight.mjCAMLIGHT_FIXED:
        raise ValueError(f"Camera {camera!r} is not a fixed camera of this model; it cannot be framed.")
    mujoco.mj_forward(model, data)
    body_rotation = data.xmat[model.cam_bodyid[camera_id]].reshape(3, 3)
    position = data.cam_xpos[camera_id].copy()
    rotation = look_at(data.cam_xmat[camera_id].reshape(3, 3), position, (low + high) / 2)
    corners = np.array(
        [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
    )
    in_camera = (corners - position) @ rotation  # (8, 3): right, up, back
    if (in_camera[:, 2] >= 0).any():
        raise ValueError(f"Camera {camera!r} stands inside or beside the workspace box; it cannot be framed.")
    half_tangent = np.abs(in_camera[:, :2] / -in_camera[:, 2:]).max()
    fovy = min(np.degrees(2 * np.arctan(half_tangent)), float(model.cam_fovy[camera_id]))
    quaternion = np.empty(4)
    mujoco.mju_mat2Quat(quaternion, (body_rotation.T @ rotation).ravel())
    model.cam_quat[camera_id] = quaternion
    model.cam_fovy[camera_id] = fovy
    mujoco.mj_forward(model, data)
