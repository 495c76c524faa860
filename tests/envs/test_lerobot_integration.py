"""The env works through LeRobot's own env factory, observation preprocessing and plugin discovery."""

import subprocess
import sys

import numpy as np
from lerobot.envs.configs import EnvConfig
from lerobot.envs.factory import make_env
from lerobot.envs.utils import add_envs_task, env_to_policy_features, preprocess_observation

from lerobot_ivmc.envs.configuration_ivmc import IMAGE_KEY, IvmcEnv


def test_make_env_builds_vectorised_envs_from_the_ivmc_config():
    cfg = IvmcEnv(task="push", image_size=32, episode_length=7)
    envs = make_env(cfg, n_envs=2)
    vec = envs["ivmc"][0]
    obs, _ = vec.reset(seed=[0, 1])
    assert obs["pixels"]["front"].shape == (2, 32, 32, 3)
    batch = preprocess_observation(obs)
    assert batch[IMAGE_KEY].shape == (2, 3, 32, 32)
    assert batch["observation.state"].shape == (2, 9)
    assert batch["observation.environment_state"].shape == (2, 6)
    for _ in range(7):
        obs, _, terminated, truncated, info = vec.step(np.zeros((2, 4), dtype=np.float32))
    assert truncated.all(), "episode_length becomes the TimeLimit"
    assert "is_success" in info["final_info"]
    assert vec.call("_max_episode_steps")[0] == 7
    # LeRobot's rollout gives the policy the task's instruction, the one the demos' frames carry.
    assert (
        add_envs_task(vec, {"x": np.zeros((2, 1))})["task"] == ["Push the red cube onto the blue target."] * 2
    )
    vec.close()


def test_config_features_match_what_the_env_returns():
    features = env_to_policy_features(IvmcEnv(task="pick_reach", image_size=40))
    assert features[IMAGE_KEY].shape == (3, 40, 40)
    assert features["observation.state"].shape == (9,)
    assert features["action"].shape == (4,)


def test_bad_config_values_are_refused():
    import pytest

    with pytest.raises(ValueError, match="Unknown task"):
        IvmcEnv(task="stacking")
    with pytest.raises(ValueError, match="env.image_size must be a positive integer number of pixels"):
        IvmcEnv(task="push", image_size=0)
    with pytest.raises(ValueError, match="env.render_size must be .* at most 2048, got 4096"):
        IvmcEnv(task="push", render_size=4096)


def test_plugin_is_discovered_by_lerobot():
    """A fresh interpreter: only LeRobot's discovery (as lerobot-train / lerobot-eval call it) imports us."""
    code = (
        "from lerobot.utils.import_utils import register_third_party_plugins\n"
        "from lerobot.envs.configs import EnvConfig\n"
        "assert 'ivmc' not in EnvConfig.get_known_choices()\n"
        "register_third_party_plugins()\n"
        "print(EnvConfig.get_choice_class('ivmc').__module__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().endswith("lerobot_ivmc.envs.configuration_ivmc")
    assert EnvConfig.get_choice_class("ivmc") is IvmcEnv
