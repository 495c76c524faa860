"""Expert demonstrations as LeRobotDatasets: the feature spec and the `lerobot-ivmc-collect` collector.

Only the feature spec is imported here; the collector lives in `lerobot_ivmc.datasets.collect`.
"""

from lerobot_ivmc.datasets.features import (
    ACTION_KEY,
    ACTION_NAMES,
    DEMO_FPS,
    ENV_STATE_KEY,
    ENV_STATE_NAMES,
    IMAGE_KEY,
    SCENE_OBJECT_CELL_KEY,
    SCENE_SEED_KEY,
    SCENE_TARGET_CELL_KEY,
    STATE_KEY,
    STATE_NAMES,
    demo_features,
)

__all__ = [
    "ACTION_KEY",
    "ACTION_NAMES",
    "DEMO_FPS",
    "ENV_STATE_KEY",
    "ENV_STATE_NAMES",
    "IMAGE_KEY",
    "SCENE_OBJECT_CELL_KEY",
    "SCENE_SEED_KEY",
    "SCENE_TARGET_CELL_KEY",
    "STATE_KEY",
    "STATE_NAMES",
    "demo_features",
]
