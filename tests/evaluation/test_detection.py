"""Failure-prediction metrics on hand-worked scores and scripted traces; the conformal threshold."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_ivmc.evaluation.detection import (
    auroc,
    conformal_sweep,
    first_crossing,
    metrics_at_threshold,
    plot_detection,
)
from lerobot_ivmc.recovery.threshold import conformal_threshold


def test_auroc_by_hand_with_ties() -> None:
    # Failures 3 and 2 against successes 1 and 2: pairs (3>1, 3>2, 2>1, 2=2 counts half) -> 3.5 / 4.
    assert auroc([1.0, 2.0, 2.0, 3.0], [False, False, True, True]) == pytest.approx(0.875)
    assert np.isnan(auroc([1.0, 2.0], [True, True]))


def test_conformal_threshold_by_hand() -> None:
    scores = [0.5, 0.1, 0.4, 0.2, 0.3, 0.9, 0.8, 0.7, 0.6]  # n = 9
    # alpha 0.1: ceil(10 * 0.9) = 9 -> the largest; alpha 0.2: ceil(10 * 0.8) = 8 -> 0.8; 0.5: 5 -> 0.5.
    assert conformal_threshold(scores, 0.1) == 0.9
    assert conformal_threshold(scores, 0.2) == 0.8
    assert conformal_threshold(scores, 0.5) == 0.5
    assert conformal_threshold([1.0, 1.0, 1.0, 2.0], 0.4) == 1.0  # ties: ceil(5 * 0.6) = 3rd smallest
    with pytest.raises(ValueError, match="needs at least 9 successful calibration episodes; got 8"):
        conformal_threshold(scores[:8], 0.1)
    with pytest.raises(ValueError, match="alpha"):
        conformal_threshold(scores, 0.0)


def test_metrics_and_lead_time_from_scripted_traces() -> None:
    traces = [
        np.array([0.0, 0.1, 0.2, 0.1]),  # success, never above 0.5
        np.array([0.0, 0.6, 0.2, 0.1]),  # success, false alarm at step 1
        np.array([0.0, 0.0, 0.0, 0.9, 1.0, 1.0]),  # failure, first above 0.5 at step 3 of 6 -> lead 3
        np.array([0.2, 0.3, 0.4]),  # failure, missed
    ]
    scores = [t.max() for t in traces]
    failures = [False, False, True, True]
    m = metrics_at_threshold(scores, failures, 0.5, traces)
    assert m["tpr"]["pc"] == 50.0 and m["tnr"]["pc"] == 50.0 and m["balanced_accuracy"] == 50.0
    assert m["lead_time_steps"]["mean"] == 3.0 and m["lead_time_steps"]["n"] == 1
    assert first_crossing(traces[2], 0.5) == 3 and first_crossing(traces[0], 0.5) is None


def test_conformal_sweep_checks_the_bound_and_plots(tmp_path) -> None:
    rng = np.random.default_rng(0)
    calibration = rng.normal(size=200)
    test_success, test_failure = rng.normal(size=300), rng.normal(loc=2.0, size=100)
    scores = np.concatenate([test_success, test_failure])
    failures = [False] * 300 + [True] * 100
    sweep = conformal_sweep(calibration, scores, failures, [0.001, 0.05, 0.2])
    assert [row["alpha"] for row in sweep] == [0.05, 0.2]  # 200 successes are too few for 0.001 (needs 999)
    assert all(row["within_bound"] for row in sweep)
    assert sweep[1]["tpr"]["pc"] > sweep[0]["tpr"]["pc"]
    traces = [np.full(5, s) for s in scores]
    paths = plot_detection(scores, failures, traces, {"argmax": 1.0}, sweep, tmp_path, "test")
    assert [p.name for p in paths] == ["roc.png", "score_traces.png", "tpr_tnr_vs_alpha.png"]
    assert all(p.stat().st_size > 0 for p in paths)
