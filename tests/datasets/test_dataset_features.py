"""The demonstration feature spec that the policies are written against."""

import pytest

from lerobot_ivmc.datasets import (
    ACTION_KEY,
    ENV_STATE_KEY,
    IMAGE_KEY,
    SCENE_OBJECT_CELL_KEY,
    SCENE_SEED_KEY,
    SCENE_TARGET_CELL_KEY,
    STATE_KEY,
    demo_features,
)
from lerobot_ivmc.envs import make_task_env


def test_feature_spec_is_fixed():
    features = demo_features(64, use_video=False)
    assert features[IMAGE_KEY] == {
        "dtype": "image",
        "shape": (64, 64, 3),
        "names": ["height", "width", "channels"],
    }
    assert features[STATE_KEY]["dtype"] == "float32" and features[STATE_KEY]["shape"] == (9,)
    assert features[STATE_KEY]["names"][:2] == ["shoulder_pan_joint", "shoulder_lift_joint"]
    assert features[STATE_KEY]["names"][-2:] == ["l_gripper_finger_joint", "r_gripper_finger_joint"]
    assert features[ENV_STATE_KEY] == {
        "dtype": "float32",
        "shape": (6,),
        "names": ["ee_x", "ee_y", "ee_z", "object_x", "object_y", "object_z"],
    }
    assert features[ACTION_KEY] == {
        "dtype": "float32",
        "shape": (4,),
        "names": ["delta_ee_x", "delta_ee_y", "delta_ee_z", "gripper"],
    }
    for key in (SCENE_SEED_KEY, SCENE_OBJECT_CELL_KEY, SCENE_TARGET_CELL_KEY):
        assert features[key] == {"dtype": "int64", "shape": (1,), "names": None}
    assert demo_features(32, use_video=True)[IMAGE_KEY]["dtype"] == "video"
    assert demo_features(32, use_video=True)[IMAGE_KEY]["shape"] == (32, 32, 3)


def test_feature_spec_matches_env_observation_space():
    space = make_task_env("push", obs_type="state").observation_space
    features = demo_features()
    assert space["agent_pos"].shape == features[STATE_KEY]["shape"]
    assert space["environment_state"].shape == features[ENV_STATE_KEY]["shape"]


@pytest.mark.parametrize("size", [0, -1, 3.5])
def test_bad_image_size_is_refused(size):
    with pytest.raises(ValueError, match="image_size"):
        demo_features(size)


def test_batched_image_embedding_writes_lerobot_s_table(tmp_path) -> None:
    """The collector embeds image bytes a batch of rows at a time: the table LeRobot's row-by-row
    `embed_images` gives, and LeRobot's own function is back once the collector's context ends."""
    import datasets
    import lerobot.datasets.lerobot_dataset as lerobot_dataset_module
    import numpy as np
    from lerobot.datasets.utils import embed_images
    from PIL import Image

    from lerobot_ivmc.datasets.assembler import batched_image_embedding, embed_images_in_batches

    paths = []
    for i in range(7):
        paths.append(str(tmp_path / f"frame_{i}.png"))
        Image.fromarray(np.full((8, 8, 3), 30 * i, dtype=np.uint8)).save(paths[-1])
    features = datasets.Features({"image": datasets.Image(), "index": datasets.Value("int64")})
    frames = datasets.Dataset.from_dict({"image": paths, "index": list(range(7))}, features=features)
    rows, batched = embed_images(frames), embed_images_in_batches(frames)
    assert batched.data.table.equals(rows.data.table)
    assert batched[3]["image"].tobytes() == Image.open(paths[3]).tobytes()
    with batched_image_embedding():
        assert lerobot_dataset_module.embed_images is embed_images_in_batches
    assert lerobot_dataset_module.embed_images is embed_images
