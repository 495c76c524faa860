"""Fig. 3's binning: success per bin of maximum uncertainty, Spearman's rho, and the bound ties put on it."""

import math

import numpy as np
import pytest

from lerobot_ivmc.evaluation.success_by_uncertainty import most_negative_rho, success_by_uncertainty_bins


def test_bins_sort_episodes_by_uncertainty_into_equal_bins() -> None:
    rng = np.random.default_rng(0)
    u = rng.permutation(np.arange(100, dtype=float))
    success = u < 70  # the 30 most uncertain episodes fail
    binned = success_by_uncertainty_bins(u, success)
    assert binned["count"] == [10] * 10 and binned["num_episodes"] == 100
    assert binned["mean_u"] == sorted(binned["mean_u"])
    assert binned["success_rate"] == [1.0] * 7 + [0.0] * 3
    # A perfect ordering with 7 bins tied at 100% and 3 at 0% reaches only the bound the ties allow.
    assert binned["spearman_rho"] == pytest.approx(binned["spearman_rho_best"])
    assert binned["spearman_rho"] == pytest.approx(-0.7977, abs=1e-4)


def test_the_bound_is_reached_only_by_a_perfect_ordering() -> None:
    best = most_negative_rho(range(10), [1.0] * 6 + [0.6, 0.4, 0.0, 0.0])
    assert best == pytest.approx(-0.884, abs=1e-3)
    # The same bin rates, a 60% bin second least uncertain: 5 episodes per bin, bin b's u is b.
    rates = [1.0, 0.6, 1.0, 1.0, 1.0, 1.0, 1.0, 0.4, 0.0, 0.0]
    u = [float(b) for b in range(10) for _ in range(5)]
    success = [i < 5 * rate for rate in rates for i in range(5)]
    binned = success_by_uncertainty_bins(u, success)
    assert binned["success_rate"] == rates
    assert binned["spearman_rho_best"] == pytest.approx(best)
    assert binned["spearman_rho"] > best + 0.05


def test_rho_is_undefined_when_every_bin_succeeds() -> None:
    binned = success_by_uncertainty_bins(np.linspace(0, 1, 50), [True] * 50)
    assert math.isnan(binned["spearman_rho"]) and math.isnan(binned["spearman_rho_best"])


def test_mismatched_inputs_are_refused() -> None:
    with pytest.raises(ValueError, match="one success flag per score"):
        success_by_uncertainty_bins([0.1, 0.2], [True])
