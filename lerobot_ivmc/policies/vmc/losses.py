"""The training losses: the paper's Eq. (loss-vmc), four terms equally weighted, and the heads beyond it."""

from __future__ import annotations

import torch
import torch.nn.functional as F  # noqa: N812
from torch import Tensor

from lerobot_ivmc.policies.vmc.gripper import DEFAULT_GRIPPER, GripperReadout
from lerobot_ivmc.policies.vmc.network import POSITION_DIM


def supervised_losses(
    outputs: tuple[Tensor, ...],
    action: Tensor,
    aux: Tensor | None,
    gripper: GripperReadout = DEFAULT_GRIPPER,
) -> dict[str, Tensor]:
    """The four losses of the paper's Eq. (loss-vmc), equally weighted, each a mean over the N labels;
    a fifth, weighed the same, when the outputs include the goal head's.

    Args:
        outputs: decoded delta EE (N, 3), gripper outputs (N, G), EE (N, 3) and object (N, 3) positions,
            optionally the predicted object position at the demo's end (N, 3).
        action: (N, D) demonstrated actions, the gripper command last.
        aux: (N, 6) auxiliary targets (EE then object position, normalised), (N, 9) with the goal head's
            target (the object's position at the demo's end) appended; None for a net without those heads.
        gripper: what the gripper outputs mean (`VMCConfig.gripper`): classes (cross-entropy) or a command
            (MSE).
    """
    delta_ee, gripper_output = outputs[:2]
    losses = {
        "loss_delta_ee": F.mse_loss(delta_ee, action[:, :-1]),
        "loss_gripper": gripper.loss(gripper_output, action[:, -1]),
    }
    if aux is not None:
        losses.update(position_losses(outputs[2:], aux, "loss_"))
    return losses


def frame_position_losses(predicted: Tensor, aux: Tensor) -> dict[str, Tensor]:
    """The frame position head's losses, weighed like the auxiliary ones: its (N, 6) or, with the goal
    head, (N, 9) positions against the targets of the same frames (`position_losses`)."""
    return position_losses(predicted.split(POSITION_DIM, dim=-1), aux, "loss_frame_")


def position_losses(positions: tuple[Tensor, ...], aux: Tensor, prefix: str) -> dict[str, Tensor]:
    """MSE of each predicted (N, 3) position, EE, object, then optionally the object's at the demo's end,
    against its columns of the (N, 6) or (N, 9) targets; named `<prefix>ee_pos`, `obj_pos`, `goal_pos`."""
    names = ("ee_pos", "obj_pos", "goal_pos")[: len(positions)]
    return {
        f"{prefix}{name}": F.mse_loss(position, aux[:, i * POSITION_DIM : (i + 1) * POSITION_DIM])
        for i, (name, position) in enumerate(zip(names, positions, strict=True))
    }


def demo_end_object_position(aux: Tensor, real: Tensor) -> Tensor:
    """The goal head's target: the object's position on each chunk's last real frame, on every frame.

    Args:
        aux: (B, L, 6) auxiliary targets of whole-demo chunks.
        real: (B, L) bool, True for real frames (`chunk_frames_mask`).

    Returns:
        (B, L, 3).
    """
    last = real.sum(dim=1) - 1
    end = aux[torch.arange(aux.shape[0], device=aux.device), last, POSITION_DIM:]
    return end[:, None].expand(-1, aux.shape[1], -1)
