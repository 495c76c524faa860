"""The paper's uncertainty, Eqs. (weighted-concat) and (unc-tr-cov), against a NumPy reference."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lerobot_ivmc.policies.bvmc.uncertainty import trace_cov_uncertainty, weighted_norm_direction


def numpy_uncertainty(samples: np.ndarray, lam: float) -> float:
    """Reference: transform each (3,) sample, then the trace of np.cov over the S rows."""
    rows = []
    for u in samples:
        norm = np.linalg.norm(u)
        direction = u / norm if norm > 0 else np.zeros(3)
        rows.append(np.concatenate([[lam * norm], (1 - lam) * direction]))
    return float(np.trace(np.cov(np.stack(rows), rowvar=False)))


@pytest.mark.parametrize("lam", [0.0, 0.3, 0.5, 1.0])
def test_matches_numpy_on_hand_made_samples(lam: float) -> None:
    samples = np.array(
        [[0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, -0.3], [0.5, 0.5, 0.5], [-0.2, 0.1, 0.05]],
        dtype=np.float64,
    )
    got = trace_cov_uncertainty(torch.from_numpy(samples), lam)
    assert got.shape == ()
    assert got.item() == pytest.approx(numpy_uncertainty(samples, lam), rel=1e-10, abs=1e-12)


def test_batched_leading_dims_match_numpy() -> None:
    rng = np.random.default_rng(0)
    samples = rng.normal(size=(2, 3, 50, 3))
    got = trace_cov_uncertainty(torch.from_numpy(samples), 0.4)
    assert got.shape == (2, 3)
    want = np.array([[numpy_uncertainty(samples[i, j], 0.4) for j in range(3)] for i in range(2)])
    np.testing.assert_allclose(got.numpy(), want, rtol=1e-10)


def test_zero_command_is_guarded() -> None:
    samples = torch.tensor([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.1, 0.0, 0.0]], dtype=torch.float64)
    x = weighted_norm_direction(samples, 0.5)
    assert torch.isfinite(x).all()
    assert torch.equal(x[0], torch.zeros(4, dtype=torch.float64))
    got = trace_cov_uncertainty(samples, 0.5).item()
    assert got == pytest.approx(numpy_uncertainty(samples.numpy(), 0.5))


def test_identical_samples_have_zero_uncertainty() -> None:
    samples = torch.tensor([[0.2, -0.1, 0.3]]).expand(10, 3)
    assert trace_cov_uncertainty(samples, 0.5).item() == pytest.approx(0.0, abs=1e-12)


def test_direction_change_counts_even_for_small_commands() -> None:
    """The reason for the transform: slow but disagreeing commands are still uncertain."""
    small = torch.tensor([[0.01, 0.0, 0.0], [-0.01, 0.0, 0.0]])
    assert trace_cov_uncertainty(small, 0.5) > 100 * (small.var(dim=0).sum())


def test_rejects_fewer_than_two_samples() -> None:
    with pytest.raises(ValueError, match="at least 2 samples"):
        trace_cov_uncertainty(torch.zeros(4, 1, 3), 0.5)


def test_rejects_bad_shapes_and_lambda() -> None:
    with pytest.raises(ValueError, match="size 3"):
        trace_cov_uncertainty(torch.zeros(5, 4), 0.5)
    with pytest.raises(ValueError, match="lambda"):
        trace_cov_uncertainty(torch.zeros(5, 3), 1.5)
