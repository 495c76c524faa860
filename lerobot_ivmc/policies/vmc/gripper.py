"""The gripper head: the action's last entry learned as classes of commands or as one continuous command.

`--policy.gripper_head=classes` (the paper's): a class per command, {-1, 0, +1} (close / no-op / open) or a
dataset's `--policy.gripper_levels`, cross-entropy, the most likely class executed. `continuous`: the
command itself in action units [-1, 1], MSE, executed as predicted (a dataset whose gripper command takes
any value in that range, e.g. a teleoperated effort). Each readout maps the decoder's gripper outputs to
commands, for one pass and for the Monte Carlo samples of bvmc.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F  # noqa: N812
from torch import Tensor

# The default gripper classes' commands, close / no-op / open (class index = command + 1).
GRIPPER_COMMANDS = (-1.0, 0.0, 1.0)
# How `--policy.gripper_head` learns the action's last entry.
GRIPPER_HEADS = ("classes", "continuous")
# A demo's gripper command farther than this from every one of `--policy.gripper_levels` is refused.
LEVEL_TOLERANCE = 0.05


def gripper_commands(class_index: Tensor, levels: tuple[float, ...] = GRIPPER_COMMANDS) -> Tensor:
    """Map gripper class indices to their commands (`VMCConfig.gripper_commands`), as float."""
    return torch.tensor(levels, dtype=torch.get_default_dtype(), device=class_index.device)[class_index]


def gripper_labels(command: Tensor, levels: tuple[float, ...] = GRIPPER_COMMANDS) -> Tensor:
    """Map gripper commands to class indices: the nearest level, refused farther than `LEVEL_TOLERANCE` from
    every level (for the default -1, 0, +1: the command rounded, then shifted, as the studies learned it)."""
    if tuple(levels) == GRIPPER_COMMANDS:
        return (torch.round(command).clamp(-1, 1) + 1).long()
    distance = (command[..., None] - torch.tensor(levels, dtype=command.dtype, device=command.device)).abs()
    nearest, labels = distance.min(dim=-1)
    if nearest.numel() and (worst := float(nearest.max())) > LEVEL_TOLERANCE:
        far = float(command.flatten()[nearest.flatten().argmax()])
        raise ValueError(
            f"A gripper command of {far:g} is {worst:.2g} from the nearest of "
            f"--policy.gripper_levels={list(levels)}: give the levels the dataset's actions take, or "
            "--policy.gripper_head=continuous."
        )
    return labels


@dataclass(frozen=True)
class GripperClasses:
    """Gripper classes whose commands are `levels` (ascending): G = len(levels) logits."""

    levels: tuple[float, ...] = GRIPPER_COMMANDS

    @property
    def out_dim(self) -> int:
        """The decoder's gripper outputs: one logit per class."""
        return len(self.levels)

    def loss(self, output: Tensor, command: Tensor) -> Tensor:
        """Cross-entropy of (N, G) logits against the (N,) demonstrated commands' classes."""
        return F.cross_entropy(output, gripper_labels(command, self.levels))

    def learned(self, command: Tensor) -> Tensor:
        """(N,) what the head learns for (N,) demonstrated commands: their classes' levels."""
        return gripper_commands(gripper_labels(command, self.levels), self.levels)

    def command(self, output: Tensor) -> Tensor:
        """(...) the most likely class's command of (..., G) logits."""
        return gripper_commands(output.argmax(dim=-1), self.levels)

    def sample_values(self, output: Tensor) -> Tensor:
        """(B, S, G) class probabilities of (B, S, G) sampled logits."""
        return output.softmax(dim=-1)

    def mean_command(self, values: Tensor) -> Tensor:
        """(B,) the command of the class of highest mean probability over the (B, S, G) samples."""
        return gripper_commands(values.sum(dim=1).argmax(dim=-1), self.levels)  # argmax of sum = of mean

    def sample_commands(self, values: Tensor) -> Tensor:
        """(B, S) each sample's most likely command."""
        return gripper_commands(values.argmax(dim=-1), self.levels)


@dataclass(frozen=True)
class ContinuousGripper:
    """One continuous gripper command in action units, regressed (MSE) and executed as predicted, clamped
    to [-1, 1] (a regression overshoots its demos' extremes a little; the envs refuse a command past 1)."""

    out_dim: int = 1

    def loss(self, output: Tensor, command: Tensor) -> Tensor:
        """MSE of the (N, 1) predicted against the (N,) demonstrated commands."""
        return F.mse_loss(output[..., 0], command)

    def learned(self, command: Tensor) -> Tensor:
        """(N,) what the head learns for (N,) demonstrated commands: the commands."""
        return command

    def command(self, output: Tensor) -> Tensor:
        """(...) the command of (..., 1) outputs."""
        return output[..., 0].clamp(-1.0, 1.0)

    def sample_values(self, output: Tensor) -> Tensor:
        """(B, S, 1) the sampled commands."""
        return output

    def mean_command(self, values: Tensor) -> Tensor:
        """(B,) the mean of the (B, S, 1) sampled commands."""
        return self.sample_commands(values).mean(dim=1)

    def sample_commands(self, values: Tensor) -> Tensor:
        """(B, S) each sample's command."""
        return values[..., 0].clamp(-1.0, 1.0)


GripperReadout = GripperClasses | ContinuousGripper
DEFAULT_GRIPPER = GripperClasses()


def gripper_readout(head: str, levels: tuple[float, ...]) -> GripperReadout:
    """The readout of `--policy.gripper_head` (`GRIPPER_HEADS`); `levels` are the classes' commands."""
    return ContinuousGripper() if head == "continuous" else GripperClasses(tuple(levels))


def deterministic_action(
    delta_ee: Tensor, gripper_output: Tensor, gripper: GripperReadout = DEFAULT_GRIPPER
) -> Tensor:
    """The executed action (B, 4) from one decoded pass: delta EE (B, 3) and the gripper's command of its
    (B, G) outputs."""
    return torch.cat([delta_ee, gripper.command(gripper_output)[:, None]], dim=-1)
