"""min_unc's candidate widening: noise on the end-effector move only, in range, seeded."""

from __future__ import annotations

import pytest
import torch

from lerobot_ivmc.recovery.candidates import widen_candidates
from lerobot_ivmc.recovery.config import RecoveryConfig


def test_noise_moves_the_end_effector_part_only_and_stays_in_range() -> None:
    samples = torch.full((2, 50, 4), 0.9)
    samples[..., 3] = -1.0  # gripper command
    widened = widen_candidates(samples, 0.5, torch.Generator().manual_seed(0))
    assert widened.shape == samples.shape
    assert torch.equal(widened[..., 3], samples[..., 3])
    assert widened[..., :3].abs().max() <= 1.0
    # The candidates now differ from each other (they were identical) and about half hit the +1 clip.
    assert widened[0, :, 0].std() > 0.1
    assert 0.2 < (widened[..., :3] == 1.0).float().mean() < 0.8
    assert torch.equal(samples, torch.full_like(samples, 0.9).index_fill_(-1, torch.tensor([3]), -1.0))


def test_same_seed_same_candidates_and_zero_noise_is_the_samples() -> None:
    samples = torch.rand(1, 8, 4) * 2 - 1
    first = widen_candidates(samples, 0.3, torch.Generator().manual_seed(3))
    again = widen_candidates(samples, 0.3, torch.Generator().manual_seed(3))
    assert torch.equal(first, again)
    assert widen_candidates(samples, 0.0) is samples
    with pytest.raises(ValueError, match="noise"):
        widen_candidates(samples, -0.1)


def test_candidate_noise_is_refused_where_it_would_do_nothing_or_leave_the_action_range() -> None:
    with pytest.raises(ValueError, match="use --recovery.mode=min_unc"):
        RecoveryConfig(mode="rand", candidate_noise=0.3)
    with pytest.raises(ValueError, match=r"in \[0, 1\]"):
        RecoveryConfig(mode="min_unc", candidate_noise=1.5)
    assert RecoveryConfig(mode="min_unc", candidate_noise=0.0).candidate_noise == 0.0
