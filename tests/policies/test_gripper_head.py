"""The gripper head. `--policy.gripper_levels`: the classes a dataset's gripper commands take (MetaWorld's
grab effort of 0.6), learned as the nearest level and executed as it; the default (-1, 0, +1) as before.
`--policy.gripper_head=continuous`: any command, regressed and executed as predicted."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from helpers.policies import make_batch, make_config, observation_batch
from lerobot.utils.constants import ACTION

from lerobot_ivmc.policies import BVMCConfig, VMCConfig
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.policies.vmc.gripper import gripper_labels
from lerobot_ivmc.policies.vmc.modeling_vmc import VMCPolicy

PUSH_LEVELS = [0.0, 0.6]  # MetaWorld's push-v3 demos: the fingers at rest, then a grab effort of 0.6


def test_a_demo_command_is_learned_as_the_class_of_the_nearest_level() -> None:
    near = torch.tensor([0.0, 0.6, 0.58, 0.02])
    assert gripper_labels(near, tuple(PUSH_LEVELS)).tolist() == [0, 1, 1, 0]
    commands = torch.tensor([0.0, 0.6, 0.58, 0.2, 1.0, -1.0])
    # The default levels round as before: 0.6 is learned (and executed) as +1.
    assert gripper_labels(commands).tolist() == [1, 2, 2, 1, 2, 0]


def test_a_demo_command_far_from_every_level_is_refused_in_one_line() -> None:
    with pytest.raises(
        ValueError, match=r"command of -1 is 1 from the nearest of --policy.gripper_levels.*continuous"
    ):
        gripper_labels(torch.tensor([0.0, 0.6, -1.0]), tuple(PUSH_LEVELS))


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_a_policy_with_gripper_levels_executes_the_demos_effort_and_keeps_its_levels(
    cls: type[VMCPolicy], tmp_path: Path
) -> None:
    torch.manual_seed(0)
    policy = cls(make_config(cls.config_class, gripper_levels=PUSH_LEVELS))
    assert policy.net.decoder.out_features == 3 + 2 + 6  # delta EE, two gripper classes, positions
    batch = make_batch(4)
    batch[ACTION][:, -1] = 0.6
    optimizer = torch.optim.Adam(policy.parameters(), lr=1e-2)
    for _ in range(30):  # learn the demos' one gripper class
        loss, _ = policy.forward(batch)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    policy.eval()
    policy.reset()
    action = policy.select_action(observation_batch(2))
    assert action[:, -1].tolist() == pytest.approx([0.6, 0.6])
    if cls is BVMCPolicy:
        policy.reset()
        sampled = policy.sample(observation_batch(2)).samples[..., -1]  # (B, S) each sample's command
        assert torch.isclose(sampled[..., None], torch.tensor(PUSH_LEVELS)).any(-1).all()
    policy.save_pretrained(tmp_path)
    assert cls.from_pretrained(tmp_path).config.gripper_commands == (0.0, 0.6)


@pytest.mark.parametrize("levels", [[0.6], [0.6, 0.0], [0.0, 0.0, 1.0], [0.0, 1.5]])
def test_gripper_levels_that_are_not_ascending_commands_are_refused(levels: list[float]) -> None:
    for cls in (VMCConfig, BVMCConfig):
        with pytest.raises(ValueError, match="--policy.gripper_levels must be at least two distinct"):
            cls(device="cpu", gripper_levels=levels)


def learn_gripper_command(policy: VMCPolicy, command: float, steps: int = 40) -> float:
    """Fit `policy` to a batch whose demos all command the gripper to `command`; the last gripper loss."""
    batch = make_batch(4)
    batch[ACTION][:, -1] = command
    optimizer = torch.optim.Adam(policy.parameters(), lr=1e-2)
    for _ in range(steps):
        loss, losses = policy.forward(batch)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    policy.eval()
    policy.reset()
    return float(losses["loss_gripper"])


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_a_continuous_gripper_executes_a_command_no_class_has(cls: type[VMCPolicy], tmp_path: Path) -> None:
    torch.manual_seed(0)
    policy = cls(make_config(cls.config_class, gripper_head="continuous"))
    assert policy.net.decoder.out_features == 3 + 1 + 6  # delta EE, one gripper command, positions
    # MSE against the demos' command itself (0.37^2 = 0.14 if it were snapped to the no-op class).
    assert learn_gripper_command(policy, 0.37) < 0.01
    executed = policy.select_action(observation_batch(2))[:, -1]
    assert (executed[:, None] - torch.tensor([-1.0, 0.0, 1.0])).abs().min() > 0.01  # not snapped to a class
    if cls is BVMCPolicy:
        policy.reset()
        prediction = policy.sample(observation_batch(2))
        sampled = prediction.samples[..., -1]  # (B, S) each sample's command, not snapped to a level
        assert sampled.shape == (2, policy.config.num_samples) and sampled.unique().numel() > 2
        torch.testing.assert_close(prediction.mean_action[:, -1], sampled.mean(dim=1))
    policy.save_pretrained(tmp_path)
    loaded = cls.from_pretrained(tmp_path)
    assert loaded.config.gripper_head == "continuous"
    actions = []
    for acting in (policy, loaded):
        acting.eval()
        acting.reset()
        torch.manual_seed(1)  # the same dropout masks for bvmc
        actions.append(acting.select_action(observation_batch(2)))
    torch.testing.assert_close(*actions)


def test_the_class_head_snaps_the_same_demos_to_a_level() -> None:
    torch.manual_seed(0)
    policy = VMCPolicy(make_config(VMCConfig))
    learn_gripper_command(policy, 0.37)  # the default classes round 0.37 to the no-op class
    assert policy.select_action(observation_batch(2))[:, -1].tolist() == [0.0, 0.0]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gripper_head": "analog"}, r"--policy.gripper_head must be one of \('classes', 'continuous'\)"),
        ({"gripper_head": "continuous", "gripper_levels": [0.0, 0.6]}, "drop it for a continuous gripper"),
    ],
)
def test_bad_gripper_heads_are_refused_in_one_line(kwargs: dict, match: str) -> None:
    for cls in (VMCConfig, BVMCConfig):
        with pytest.raises(ValueError, match=match):
            cls(device="cpu", **kwargs)
