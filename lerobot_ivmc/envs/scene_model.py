"""Builds the MuJoCo model of a task: gymnasium-robotics' Fetch table scene plus our object, target, camera.

We start from gymnasium-robotics' `pick_and_place.xml` (the Fetch arm, the table and a free cube) and edit
it with `mujoco.MjSpec`, so the robot model and its meshes stay the maintained upstream ones.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

# Headless rendering: EGL works without a display (Mesa on CPU machines). Respect a user's choice. Set
# only once the simulator is loaded, i.e. when an ivmc env is built, not when the plugin is imported.
os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from lerobot_ivmc.envs.camera import CAMERA_NAME  # noqa: E402

OBJECT_BODY = "object0"
TARGET_BODY = "target0"
TABLE_TOP_Z = 0.4
# A view from the far side of the table, looking down at the workspace and the gripper.
_CAMERA_POSITION = np.array([1.72, 0.75, 1.22])
_CAMERA_LOOK_AT = np.array([1.29, 0.75, 0.40])
_CAMERA_FOVY = 45.0
_RED = [0.85, 0.1, 0.1, 1.0]
_BLUE = [0.1, 0.25, 0.9, 1.0]


@dataclass(frozen=True)
class ObjectShape:
    """Box half-sizes of the manipulated object (a cube or a stick lying along x)."""

    half_size: tuple[float, float, float]
    mass: float

    @property
    def rest_height(self) -> float:
        """z of the object's centre when it lies on the table."""
        return TABLE_TOP_Z + self.half_size[2]


def fetch_assets_dir() -> Path:
    import gymnasium_robotics

    return Path(gymnasium_robotics.__file__).parent / "envs" / "assets" / "fetch"


def _look_at_xyaxes(position: np.ndarray, target: np.ndarray) -> list[float]:
    forward = (target - position) / np.linalg.norm(target - position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    return [*right, *up]


def build_model(shape: ObjectShape, target_radius: float) -> mujoco.MjModel:
    """Compile the Fetch scene with a red box object, a blue target disc and the fixed front camera."""
    spec = mujoco.MjSpec.from_file(str(fetch_assets_dir() / "pick_and_place.xml"))
    spec.delete(spec.site("target0"))
    # The mocap body draws long green guide lines across the scene; hide them from the camera.
    for geom in spec.body("robot0:mocap").geoms:
        geom.rgba = [0.0, 0.0, 0.0, 0.0]

    obj = spec.body(OBJECT_BODY)
    obj_geom = obj.geoms[0]
    obj_geom.size = list(shape.half_size)
    obj_geom.material = ""
    obj_geom.rgba = _RED
    obj_geom.mass = shape.mass
    obj.sites[0].rgba = [0.0, 0.0, 0.0, 0.0]

    target = spec.worldbody.add_body(name=TARGET_BODY, pos=[1.3, 0.75, TABLE_TOP_Z])
    target.add_geom(
        name=TARGET_BODY,
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[target_radius, 0.0015, 0.0],
        rgba=_BLUE,
        contype=0,
        conaffinity=0,
    )

    spec.worldbody.add_camera(
        name=CAMERA_NAME,
        pos=list(_CAMERA_POSITION),
        xyaxes=_look_at_xyaxes(_CAMERA_POSITION, _CAMERA_LOOK_AT),
        fovy=_CAMERA_FOVY,
    )
    return spec.compile()
