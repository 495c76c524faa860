"""The policies' defaults are the measured best recipe (sequence training, goal and frame position heads,
Adam 6e-4), window training keeps its own, and checkpoints saved before the switch still load as trained."""

from __future__ import annotations

import json
import sys
from dataclasses import asdict
from pathlib import Path
from pprint import pformat

import pytest
import torch
from helpers.policies import make_config, observation_batch
from lerobot.configs import parser
from lerobot.configs.eval import EvalPipelineConfig
from lerobot.configs.policies import PreTrainedConfig

from lerobot_ivmc.policies import BVMCConfig, BVMCPolicy, VMCConfig, VMCPolicy
from lerobot_ivmc.policies.legacy_configs import fill_legacy_defaults


@pytest.mark.parametrize("cls", [VMCConfig, BVMCConfig])
def test_defaults_train_whole_demos_with_both_heads_and_window_training_keeps_its_own(cls) -> None:
    default = cls(device="cpu")
    assert (default.training_mode, default.chunk_length, default.rollout_memory) == (
        "sequence",
        100,
        "trajectory",
    )
    assert (default.goal_head, default.frame_position_head, default.optimizer_lr) == (True, True, 6e-4)
    window = cls(device="cpu", training_mode="window")
    assert (window.goal_head, window.optimizer_lr, window.rollout_memory) == (False, 3e-4, "window")
    chosen = cls(device="cpu", goal_head=False, optimizer_lr=1e-4)
    assert (chosen.goal_head, chosen.optimizer_lr) == (False, 1e-4)
    with pytest.raises(ValueError, match="optimizer_lr must be positive"):
        cls(device="cpu", optimizer_lr=0.0)


def save_as_before_the_switch(policy: VMCPolicy, folder: Path) -> None:
    """Save `policy` with a config.json that lacks the fields a checkpoint of that time did not have."""
    policy.save_pretrained(folder)
    path = folder / "config.json"
    saved = json.loads(path.read_text())
    for name in ("training_mode", "goal_head", "frame_position_head", "chunk_memory"):
        del saved[name]
    path.write_text(json.dumps(saved))


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_a_checkpoint_saved_before_the_switch_loads_and_acts_as_trained(cls, tmp_path: Path) -> None:
    torch.manual_seed(0)
    old = cls(make_config(cls.config_class, rollout_memory="window", optimizer_lr=3e-4))
    save_as_before_the_switch(old, tmp_path)
    # The config alone (as `lerobot-eval --policy.path` parses it) gets today's defaults ...
    parsed = PreTrainedConfig.from_pretrained(tmp_path)
    assert (parsed.training_mode, parsed.goal_head, parsed.frame_position_head) == ("sequence", True, True)
    # ... and loading the policy, with or without that config (as LeRobot's `make_policy` passes it),
    # puts back what the checkpoint was trained with, so its tensors load strictly.
    for loaded in (cls.from_pretrained(tmp_path), cls.from_pretrained(tmp_path, config=parsed)):
        config = loaded.config
        assert (config.training_mode, config.goal_head, config.frame_position_head) == (
            "window",
            False,
            False,
        )
        assert config.rollout_memory == "window" and config.optimizer_lr == 3e-4
        old.mc_sampling = loaded.mc_sampling = False
        old.reset(), loaded.reset()
        obs = observation_batch(2)
        assert torch.equal(old.select_action(obs), loaded.select_action(obs))


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_a_pre_switch_config_read_by_a_lerobot_command_holds_the_values_it_acts_with(
    cls, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """As `lerobot-eval --policy.path` (or lerobot-train, lerobot-record) reads it: its logged and saved
    config show the old training mode and heads the policy runs with, not today's defaults."""
    checkpoint = tmp_path / "old"
    save_as_before_the_switch(cls(make_config(cls.config_class, rollout_memory="window")), checkpoint)
    argv = ["lerobot-eval", f"--policy.path={checkpoint}", "--env.type=ivmc", "--env.task=push"]
    argv.append(f"--output_dir={tmp_path / 'eval'}")
    monkeypatch.setattr(sys, "argv", argv)

    def parsed(cfg):
        return cfg

    parsed.__annotations__ = {"cfg": EvalPipelineConfig}  # a class, not this file's postponed string
    read = parser.wrap()(parsed)  # lerobot-eval's own parsing of its command line
    config = read().policy
    assert (config.training_mode, config.goal_head, config.frame_position_head) == ("window", False, False)
    assert config.rollout_memory == "window"
    logged = pformat(asdict(config))  # what lerobot-eval logs before it builds the policy
    assert "'training_mode': 'window'" in logged and "'goal_head': False" in logged
    (tmp_path / "saved").mkdir()
    config._save_pretrained(tmp_path / "saved")  # as a training's checkpoints save it
    saved = json.loads((tmp_path / "saved" / "config.json").read_text())
    assert (saved["training_mode"], saved["goal_head"], saved["frame_position_head"]) == (
        "window",
        False,
        False,
    )
    # A field given on the command line is kept as given.
    monkeypatch.setattr(sys, "argv", [*argv, "--policy.frame_position_head=true"])
    assert read().policy.frame_position_head is True


def test_a_checkpoint_saved_now_keeps_every_field(tmp_path: Path) -> None:
    policy = VMCPolicy(
        make_config(VMCConfig, training_mode="sequence", goal_head=True, frame_position_head=True)
    )
    policy.save_pretrained(tmp_path)
    loaded = VMCPolicy.from_pretrained(tmp_path)
    assert loaded.config == policy.config
    assert loaded.net.goal_decoder is not None and loaded.net.frame_position_decoder is not None


def test_fields_set_on_the_command_line_are_never_filled_in() -> None:
    config = make_config(VMCConfig, training_mode="sequence", goal_head=True, frame_position_head=True)
    saved = {"type", "rollout_memory"}  # a file from before training_mode and the heads existed
    changed = fill_legacy_defaults(config, saved, keep={"frame_position_head"})
    assert changed == ["training_mode", "goal_head", "render_style"]
    assert (config.training_mode, config.goal_head, config.frame_position_head) == ("window", False, True)
    assert config.rollout_memory == "trajectory", "saved in the file: kept"
