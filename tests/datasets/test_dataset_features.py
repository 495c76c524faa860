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
