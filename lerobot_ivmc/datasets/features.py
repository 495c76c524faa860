"""The feature spec of the expert demonstration datasets, shared by the collector and the policies.

Keys, dtypes and names follow LeRobot's conventions (`lerobot.envs.utils.preprocess_observation` maps the
env's ``pixels``/``agent_pos``/``environment_state`` to the same keys), so a policy trained on a dataset
reads the live env's observations unchanged.
"""

from __future__ import annotations

from lerobot_ivmc.envs.camera import CAMERA_NAME
from lerobot_ivmc.envs.fetch_env import ARM_JOINTS, FINGER_JOINTS

# The paper records observation-action tuples at 25 Hz; a demonstration lasts 4 s.
DEMO_FPS = 25

IMAGE_KEY = f"observation.images.{CAMERA_NAME}"
# The single camera of `lerobot/metaworld_mt50` and of LeRobot's MetaWorld env.
METAWORLD_IMAGE_KEY = "observation.image"
STATE_KEY = "observation.state"
ENV_STATE_KEY = "observation.environment_state"
ACTION_KEY = "action"
SCENE_SEED_KEY = "scene.seed"
SCENE_OBJECT_CELL_KEY = "scene.object_cell"
SCENE_TARGET_CELL_KEY = "scene.target_cell"

STATE_NAMES = [name.removeprefix("robot0:") for name in ARM_JOINTS + FINGER_JOINTS]
# Auxiliary targets of the policy: end-effector (grip point) position, then object position.
ENV_STATE_NAMES = ["ee_x", "ee_y", "ee_z", "object_x", "object_y", "object_z"]
ACTION_NAMES = ["delta_ee_x", "delta_ee_y", "delta_ee_z", "gripper"]


def demo_features(image_size: int = 64, use_video: bool = False) -> dict[str, dict]:
    """LeRobot features of a demonstration dataset (without LeRobot's default index/timestamp features).

    Args:
        image_size: height and width of the front camera image, in pixels.
        use_video: store the camera as an mp4 video (dtype "video") instead of PNG frames (dtype "image").

    Returns:
        ``{key: {"dtype", "shape", "names"}}`` as `LeRobotDataset.create(features=...)` expects.
    """
    if not isinstance(image_size, int) or image_size <= 0:
        raise ValueError(f"image_size must be a positive number of pixels, got {image_size!r}.")
    scalar = {"dtype": "int64", "shape": (1,), "names": None}
    return {
        IMAGE_KEY: {
            "dtype": "video" if use_video else "image",
            "shape": (image_size, image_size, 3),
            "names": ["height", "width", "channels"],
        },
        STATE_KEY: {"dtype": "float32", "shape": (len(STATE_NAMES),), "names": list(STATE_NAMES)},
        ENV_STATE_KEY: {"dtype": "float32", "shape": (len(ENV_STATE_NAMES),), "names": list(ENV_STATE_NAMES)},
        ACTION_KEY: {"dtype": "float32", "shape": (len(ACTION_NAMES),), "names": list(ACTION_NAMES)},
        SCENE_SEED_KEY: dict(scalar),
        SCENE_OBJECT_CELL_KEY: dict(scalar),
        SCENE_TARGET_CELL_KEY: dict(scalar),
    }
