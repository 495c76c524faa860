"""The candidate actions min_unc ranks: the Monte Carlo samples, optionally widened by Gaussian noise.

With a small learned dropout rate the S samples of a step are near-identical (pick_place lite: p = 1.5%;
two independent measurements of their next-step uncertainty agree on the best one in 5% of states, chance
2%), so the paper's choice among them is hardly a choice. Adding noise of a few centimetres to each
sample's end-effector move spreads the candidates; the foresight head must then be distilled on actions
perturbed the same way (`--foresight.action_noise`) to rank them.
"""

from __future__ import annotations

import torch
from torch import Tensor

# The delta end-effector part of an action: (dx, dy, dz) in [-1, 1] action units; the gripper command
# (last entry) is never perturbed.
MOVE_DIMS = 3


def widen_candidates(samples: Tensor, noise: float, generator: torch.Generator | None = None) -> Tensor:
    """Each sampled action with N(0, noise^2) added to its end-effector move, clipped to the action range.

    Args:
        samples: (..., 4) actions (delta EE in action units, gripper command).
        noise: standard deviation in action units (1 unit = one step's largest move); 0 returns `samples`.
        generator: seeds the noise (CPU).

    Returns:
        A new tensor of the same shape (or `samples` itself when `noise` is 0).
    """
    if noise < 0:
        raise ValueError(f"Candidate noise must be >= 0 action units, got {noise}.")
    if noise == 0:
        return samples
    draw = torch.randn(samples[..., :MOVE_DIMS].shape, generator=generator, dtype=torch.float32)
    widened = samples.clone()
    moves = widened[..., :MOVE_DIMS].float() + noise * draw.to(samples.device)
    widened[..., :MOVE_DIMS] = moves.clamp(-1.0, 1.0).to(samples.dtype)
    return widened
