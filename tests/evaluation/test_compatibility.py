"""A checkpoint is checked against the env before the first step, naming the flag that fixes a mismatch."""

import json
import sys
from unittest import mock

import pytest
from lerobot.configs.policies import PreTrainedConfig
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from lerobot_ivmc.cli import run_cli
from lerobot_ivmc.envs.configuration_ivmc import IMAGE_KEY, IvmcEnv
from lerobot_ivmc.evaluation.compatibility import (
    EnvMismatchError,
    check_policy_matches_env,
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


def test_another_render_style_is_refused_naming_the_flag():
    policy_cfg = _policy_config(64)
    policy_cfg.render_style = "fetch"
    with pytest.raises(EnvMismatchError, match=r"drawn in the 'fetch' render style, this env draws 'fast'; "):
        check_policy_matches_env(policy_cfg, IvmcEnv(task="push"))
    check_policy_matches_env(policy_cfg, IvmcEnv(task="push", render_style="fetch"))


def test_an_env_of_another_task_is_refused_naming_the_flag():
    policy_cfg = _policy_config(64)
    policy_cfg.trained_task = "push"
    with pytest.raises(
        EnvMismatchError, match=r"trained on 'push' demos, this env is 'pick_place'; pass --env.task=push"
    ):
        check_policy_matches_env(policy_cfg, IvmcEnv(task="pick_place"))
    check_policy_matches_env(policy_cfg, IvmcEnv(task="push"))
    policy_cfg.trained_task = None  # not known (plain lerobot-train, older checkpoints): features only
    check_policy_matches_env(policy_cfg, IvmcEnv(task="pick_place"))


def test_a_checkpoint_saved_before_render_styles_is_checked_as_the_fetch_style(tmp_path):
    BVMCPolicy(_policy_config(64, BVMCConfig)).save_pretrained(tmp_path)
    saved = json.loads((tmp_path / "config.json").read_text())
    del saved["render_style"]
    (tmp_path / "config.json").write_text(json.dumps(saved))
    policy_cfg = PreTrainedConfig.from_pretrained(tmp_path)
    policy_cfg.pretrained_path = tmp_path  # as lerobot-eval's config sets it for --policy.path
    with pytest.raises(EnvMismatchError, match=r"pass --env.render_style=fetch\.$"):
        check_policy_matches_env(policy_cfg, IvmcEnv(task="pick_place"))
    check_policy_matches_env(policy_cfg, IvmcEnv(task="pick_place", render_style="fetch"))


def test_the_cli_ends_on_a_mismatch_with_one_line(capsys):
    with pytest.raises(SystemExit) as exit_info:
        run_cli(lambda: check_policy_matches_env(_policy_config(64), IvmcEnv(task="push", image_size=32)))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: This vmc checkpoint does not fit the ivmc env")


def test_a_missing_policy_folder_is_named_as_missing(capsys, tmp_path):
    missing = tmp_path / "outputs" / "train" / "pretrained_model"
    with mock.patch.object(sys, "argv", ["lerobot-ivmc-eval", f"--policy.path={missing}"]):
        with pytest.raises(SystemExit) as exit_info:
            run_cli(lambda: None)
    assert exit_info.value.code == 2
    assert capsys.readouterr().err == (
        f"error: --policy.path={missing}: no such folder (and not a hub repo id '<user>/<name>'); pass the "
        "pretrained_model folder of a checkpoint.\n"
    )
