"""LeRobot 0.4.4's generic policy tests (`tests/policies/test_policies.py`: `test_policy_defaults`,
`test_save_and_load_pretrained`) with upstream's dummy features: one 84-px camera, a 6-D state, a 6-D action
and no environment state."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.policies.factory import get_policy_class, make_policy_config
from lerobot.utils.constants import ACTION, OBS_IMAGES, OBS_STATE

CAMERA = f"{OBS_IMAGES}.laptop"


def upstream_config(policy_name: str):
    config = make_policy_config(policy_name)
    config.output_features = {ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(6,))}
    config.input_features = {
        CAMERA: PolicyFeature(type=FeatureType.VISUAL, shape=(3, 84, 84)),
        OBS_STATE: PolicyFeature(type=FeatureType.STATE, shape=(6,)),
    }
    return config


@pytest.mark.parametrize("policy_name", ["vmc", "bvmc"])
def test_policy_defaults(policy_name: str) -> None:
    policy = get_policy_class(policy_name)(upstream_config(policy_name))
    batch = {CAMERA: torch.rand(2, 3, 84, 84), OBS_STATE: torch.randn(2, 6)}
    action = policy.select_action(batch)
    assert action.shape == (2, 6) and set(action[:, -1].tolist()) <= {-1.0, 0.0, 1.0}


@pytest.mark.parametrize("policy_name", ["vmc", "bvmc"])
def test_save_and_load_pretrained(policy_name: str, tmp_path: Path) -> None:
    policy_cls = get_policy_class(policy_name)
    config = upstream_config(policy_name)
    policy = policy_cls(config)
    policy.save_pretrained(tmp_path / policy_name)
    loaded = policy_cls.from_pretrained(tmp_path / policy_name, config=config)
    torch.testing.assert_close(list(policy.parameters()), list(loaded.parameters()), rtol=0, atol=0)
