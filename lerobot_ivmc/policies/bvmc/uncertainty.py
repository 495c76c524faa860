"""The paper's uncertainty measure over Monte Carlo samples of the delta end-effector command.

Eq. (weighted-concat): u = [u_x, u_y, u_z] -> X = [lambda * |u|, (1 - lambda) * u / |u|] (4-D).
Eq. (unc-tr-cov): uncertainty = Tr(cov([X^1, ..., X^S])), the trace of the sample covariance.
"""

from __future__ import annotations

import torch
from torch import Tensor

# Below this norm a command counts as zero: its unit vector is taken as 0 instead of dividing by 0.
NORM_EPS = 1e-8


def weighted_norm_direction(delta_ee: Tensor, lam: float) -> Tensor:
    """Map delta-EE commands to the weighted norm-and-direction vector of Eq. (weighted-concat).

    Args:
        delta_ee: (..., 3) delta end-effector commands.
        lam: weight of the norm; the unit vector gets 1 - lam.

    Returns:
        (..., 4) tensor [lam * |u|, (1 - lam) * u / |u|]; the direction part is 0 where |u| = 0.
    """
    if delta_ee.shape[-1] != 3:
        raise ValueError(f"delta_ee must end in a dimension of size 3, got shape {tuple(delta_ee.shape)}.")
    norm = torch.linalg.vector_norm(delta_ee, dim=-1, keepdim=True)
    direction = delta_ee / norm.clamp_min(NORM_EPS)
    return torch.cat([lam * norm, (1.0 - lam) * direction], dim=-1)


def trace_cov_uncertainty(delta_ee_samples: Tensor, lam: float) -> Tensor:
    """Trace of the sample covariance of the transformed samples, Eq. (unc-tr-cov).

    The covariance is the unbiased one (divides by S - 1), as `numpy.cov`.

    Args:
        delta_ee_samples: (..., S, 3) Monte Carlo samples of the delta end-effector command.
        lam: the norm weight lambda of Eq. (weighted-concat), in [0, 1].

    Returns:
        (...) uncertainty per leading index.
    """
    if delta_ee_samples.dim() < 2:
        raise ValueError(f"Expected samples of shape (..., S, 3), got {tuple(delta_ee_samples.shape)}.")
    num_samples = delta_ee_samples.shape[-2]
    if num_samples < 2:
        raise ValueError(f"The sample covariance needs at least 2 samples, got S={num_samples}.")
    if not 0.0 <= lam <= 1.0:
        raise ValueError(f"lambda must lie in [0, 1], got {lam}.")
    # Tr(cov) is the sum of the per-dimension unbiased variances.
    return weighted_norm_direction(delta_ee_samples, lam).var(dim=-2).sum(dim=-1)
