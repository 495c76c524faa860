"""A checkpoint is checked against the env before the first step; plugin errors end CLIs in one line."""

import draccus
import pytest
from lerobot.configs.eval import EvalPipelineConfig
from lerobot.configs.policies import PreTrainedConfig
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from lerobot_ivmc.envs.configuration_ivmc import IMAGE_KEY, IvmcEnv
from lerobot_ivmc.evaluation.compatibility import (
    EnvMismatchError,
    check_policy_matches_env,
    one_line_errors,
    plugin_error_message,
)
from lerobot_ivmc.policies import BVMCConfig, BVMCPolicy, VMCConfig


def _policy_config(image_size: int = 64, cls: type[VMCConfig] = VMCConfig) -> VMCConfig:
    inputs = {
        IMAGE_KEY: PolicyFeature(type=FeatureType.VISUAL, shape=(3, image_size, image_size)),
        OBS_STATE: PolicyFeature(type=FeatureType.STATE, shape=(9,)),
        OBS_ENV_STATE: PolicyFeature(type=FeatureType.ENV, shape=(6,)),
    }
    outputs = {ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(4,))}
    return cls(device="cpu", input_features=inputs, output_features=outputs)


def test_a_matching_env_passes():
    check_policy_matches_env(_policy_config(64), IvmcEnv(task="push"))
    check_policy_matches_env(_policy_config(32), IvmcEnv(task="push", image_size=32))


def test_another_image_size_is_refused_naming_the_flag(tmp_path):
    # The config as a checkpoint records it.
    BVMCPolicy(_policy_config(64, BVMCConfig)).save_pretrained(tmp_path)
    policy_cfg = PreTrainedConfig.from_pretrained(tmp_path)
    with pytest.raises(EnvMismatchError) as error:
        check_policy_matches_env(policy_cfg, IvmcEnv(task="pick_place", image_size=32))
    message = str(error.value)
    assert isinstance(error.value, ValueError)
    assert "expects observation.images.front of shape (3, 64, 64), this env gives (3, 32, 32)" in message
    assert message.endswith("pass --env.image_size=64.")


def test_a_state_env_is_refused_for_a_pixel_policy_naming_the_flag():
    expected = r"does not give with obs_type='state'; pass --env.obs_type=pixels_agent_pos\.$"
    with pytest.raises(ValueError, match=expected):
        check_policy_matches_env(_policy_config(64), IvmcEnv(task="push", obs_type="state"))
    with pytest.raises(ValueError, match=r"--env.obs_type=pixels_agent_pos --env.image_size=48\.$"):
        check_policy_matches_env(_policy_config(48), IvmcEnv(task="push", obs_type="state"))


def test_the_check_leaves_the_env_config_alone():
    env_cfg = IvmcEnv(task="push", image_size=32)
    before = dict(env_cfg.features)
    with pytest.raises(EnvMismatchError):
        check_policy_matches_env(_policy_config(64), env_cfg)
    assert env_cfg.features == before and env_cfg.image_size == 32


def _parse_eval(args: list[str]) -> EvalPipelineConfig:
    return draccus.parse(EvalPipelineConfig, args=args)


def test_a_plugin_config_error_ends_the_cli_in_one_line(capsys):
    with pytest.raises(SystemExit) as exit_info, one_line_errors("lerobot-ivmc-eval"):
        _parse_eval(["--env.type=ivmc", "--env.image_size=5000", "--policy.type=vmc"])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err == (
        "lerobot-ivmc-eval: error: env.image_size must be a positive integer number of pixels, at most 2048, "
        "got 5000.\n"
    )


def test_other_errors_keep_their_traceback():
    with pytest.raises(KeyError), one_line_errors("lerobot-ivmc-eval"):
        raise KeyError("a bug")
    try:
        raise ValueError("Action must be finite")  # raised here, not while parsing a plugin config
    except ValueError as error:
        assert plugin_error_message(error) is None
    assert plugin_error_message(EnvMismatchError("x\n  y")) == "x y"
