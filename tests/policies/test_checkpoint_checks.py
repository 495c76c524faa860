"""Checkpoints load strictly: missing, unexpected or unreadable tensors are refused, naming the file."""

from pathlib import Path

import pytest
import torch
from helpers.policies import make_config
from safetensors.torch import load_file, save_file
from torch import nn

from lerobot_ivmc.cli import run_cli
from lerobot_ivmc.policies import BVMCConfig, BVMCPolicy, VMCConfig, VMCPolicy
from lerobot_ivmc.policies.checkpoint_checks import CheckpointError

POLICIES = [(VMCConfig, VMCPolicy), (BVMCConfig, BVMCPolicy)]


def _saved(tmp_path: Path, config_cls, policy_cls) -> tuple[Path, nn.Module]:
    policy = policy_cls(make_config(config_cls))
    policy.save_pretrained(tmp_path)
    return tmp_path / "model.safetensors", policy


@pytest.mark.parametrize(("config_cls", "policy_cls"), POLICIES)
def test_a_whole_checkpoint_loads_exactly(tmp_path, config_cls, policy_cls):
    _, policy = _saved(tmp_path, config_cls, policy_cls)
    loaded = policy_cls.from_pretrained(tmp_path)
    for name, tensor in policy.state_dict().items():
        torch.testing.assert_close(loaded.state_dict()[name], tensor, rtol=0, atol=0)


@pytest.mark.parametrize(("config_cls", "policy_cls"), POLICIES)
def test_missing_tensor_is_refused_naming_file_and_key(tmp_path, config_cls, policy_cls):
    model_file, _ = _saved(tmp_path, config_cls, policy_cls)
    tensors = load_file(model_file)
    del tensors["net.decoder.weight"]
    save_file(tensors, model_file)
    with pytest.raises(CheckpointError, match=rf"{model_file}.*missing keys net\.decoder\.weight\."):
        policy_cls.from_pretrained(tmp_path)


def test_unexpected_tensor_is_refused_naming_file_and_key(tmp_path):
    model_file, _ = _saved(tmp_path, BVMCConfig, BVMCPolicy)
    tensors = load_file(model_file)
    save_file({**tensors, "net.extra.weight": torch.zeros(2)}, model_file)
    with pytest.raises(CheckpointError, match=rf"{model_file}.*unexpected keys net\.extra\.weight\."):
        BVMCPolicy.from_pretrained(tmp_path)


def test_tensor_of_another_shape_is_refused_naming_file(tmp_path):
    model_file, _ = _saved(tmp_path, VMCConfig, VMCPolicy)
    tensors = load_file(model_file)
    tensors["net.decoder.weight"] = tensors["net.decoder.weight"][:, :-1].contiguous()
    save_file(tensors, model_file)
    with pytest.raises(
        CheckpointError, match=rf"{model_file} does not fit the VMCPolicy.*net\.decoder\.weight"
    ):
        VMCPolicy.from_pretrained(tmp_path)


@pytest.mark.parametrize("keep", [0, 7, 1000, -100])
def test_truncated_checkpoint_is_refused_naming_file(tmp_path, keep):
    model_file, _ = _saved(tmp_path, VMCConfig, VMCPolicy)
    data = model_file.read_bytes()
    model_file.write_bytes(data[:keep])
    with pytest.raises(CheckpointError, match=rf"{model_file} is not a readable safetensors file"):
        VMCPolicy.from_pretrained(tmp_path)


def test_strictness_follows_the_model_s_own_optional_submodules(tmp_path):
    """Keys are compared with the built model's `state_dict()`: an optional head (like bvmc's foresight
    head) is expected exactly when the config builds it."""

    class WithOptionalHead(VMCPolicy):
        with_head = True

        def __init__(self, config, **kwargs):
            super().__init__(config, **kwargs)
            self.head = nn.Linear(3, 2) if self.with_head else None

    WithOptionalHead(make_config(VMCConfig)).save_pretrained(tmp_path)
    assert WithOptionalHead.from_pretrained(tmp_path).head is not None
    WithOptionalHead.with_head = False
    with pytest.raises(CheckpointError, match="unexpected keys head.bias, head.weight"):
        WithOptionalHead.from_pretrained(tmp_path)
    (tmp_path / "without").mkdir()
    WithOptionalHead(make_config(VMCConfig)).save_pretrained(tmp_path / "without")
    WithOptionalHead.with_head = True
    with pytest.raises(CheckpointError, match="missing keys head.bias, head.weight"):
        WithOptionalHead.from_pretrained(tmp_path / "without")


def test_the_cli_ends_on_a_damaged_checkpoint_with_one_line(tmp_path, capsys):
    model_file, _ = _saved(tmp_path, VMCConfig, VMCPolicy)
    model_file.write_bytes(model_file.read_bytes()[:100])
    with pytest.raises(SystemExit) as exit_info:
        run_cli(lambda: VMCPolicy.from_pretrained(tmp_path))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: Checkpoint file {model_file} is not a readable")
