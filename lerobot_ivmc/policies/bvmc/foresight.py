"""Uncertainty foresight: predicts the uncertainty of the next step from the embedding and an action.

The paper's Fig. 2 (orange): a small network on [e_t, a_t] trained by distillation to predict the Bayesian
VMC uncertainty at t + 1 after executing a_t, so that the minimum-uncertainty recovery can rank the S
sampled actions of a step without trying them (Section "Following Minimum Uncertainty").
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

# The uncertainty spans orders of magnitude along an episode (near 0 when the samples agree, ~0.1 when
# they scatter), so the head regresses log(u + floor): its ranking of actions is what recovery needs.
LOG_FLOOR = 1e-6


class UncertaintyForesight(nn.Module):
    """Two fully connected layers: [e_t, a_t] -> log of the foreseen uncertainty at t + 1.

    Args:
        embedding_dim: size of the LSTM embedding e_t.
        action_dim: size of the action a_t (delta EE (3) + gripper command).
        hidden_dim: width of the hidden layer.
    """

    def __init__(self, embedding_dim: int, action_dim: int, hidden_dim: int):
        super().__init__()
        self.layers = nn.Sequential(
            nn.Linear(embedding_dim + action_dim, hidden_dim), nn.ReLU(), nn.Linear(hidden_dim, 1)
        )

    def forward(self, embedding: Tensor, action: Tensor) -> Tensor:
        """Predicted log(u_{t+1} + LOG_FLOOR): (..., embedding_dim) and (..., action_dim) -> (...)."""
        return self.layers(torch.cat([embedding, action], dim=-1)).squeeze(-1)


def log_uncertainty(uncertainty: Tensor) -> Tensor:
    """The regression target of the head: log(u + LOG_FLOOR)."""
    return torch.log(uncertainty.clamp_min(0.0) + LOG_FLOOR)


def from_log_uncertainty(log_u: Tensor) -> Tensor:
    """Inverse of `log_uncertainty` (clamped at 0)."""
    return (torch.exp(log_u) - LOG_FLOOR).clamp_min(0.0)
