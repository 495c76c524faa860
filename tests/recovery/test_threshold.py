"""The paper's u and threshold pick on hand-worked examples, and how an eval resolves its threshold."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.threshold import (
    THRESHOLD_FILE,
    ThresholdRecord,
    argmax_threshold,
    conformal_threshold,
    max_window_sum,
    resolve_threshold,
    window_sums,
)


def test_window_sums_and_u_by_hand() -> None:
    u = [1.0, 2.0, 3.0, 0.0, 5.0]
    # window 2: 1, 1+2, 2+3, 3+0, 0+5
    np.testing.assert_allclose(window_sums(u, 2), [1, 3, 5, 3, 5])
    np.testing.assert_allclose(window_sums(u, 20), [1, 3, 6, 6, 11])
    assert max_window_sum(u, 3) == 8.0  # 3 + 0 + 5
    with pytest.raises(ValueError, match="window"):
        window_sums(u, 0)


def test_argmax_threshold_by_hand() -> None:
    # Sorted by u: 1 (S), 2 (S), 3 (F), 4 (S), 5 (F), 6 (F); mean success r = 0.5.
    scores = [4.0, 1.0, 6.0, 2.0, 5.0, 3.0]
    successes = [True, True, False, True, False, False]
    threshold, gains = argmax_threshold(scores, successes)
    # candidate u_i: episodes above it (n), successes above (s), gain = n * 0.5 - s
    # u=1: n=5, s=2 -> 0.5; u=2: n=4, s=1 -> 1.0; u=3: n=3, s=1 -> 0.5; u=4: n=2, s=0 -> 1.0;
    # u=5: n=1, s=0 -> 0.5; u=6: n=0 -> 0.
    np.testing.assert_allclose(gains, [0.5, 1.0, 0.5, 1.0, 0.5, 0.0])
    assert threshold == 4.0  # the highest of the tied maxima: the same gain, recovering no success


def test_argmax_threshold_never_recovers_a_policy_that_never_failed() -> None:
    scores = [0.4, 0.9, 0.6, 0.5]
    threshold, gains = argmax_threshold(scores, [True] * 4)
    np.testing.assert_allclose(gains, 0.0)
    assert threshold == 0.9
    assert not any(u > threshold for u in scores)  # no validation episode would trigger a recovery


def test_argmax_threshold_with_ties_and_bad_input() -> None:
    threshold, gains = argmax_threshold([1.0, 1.0, 2.0], [True, False, False])
    # r = 1/3. u=1 (twice): only the u=2 failure is above: 1/3 - 0; u=2: nothing above.
    np.testing.assert_allclose(gains, [1 / 3, 1 / 3, 0.0])
    assert threshold == 1.0
    with pytest.raises(ValueError, match="one success flag per score"):
        argmax_threshold([1.0, 2.0], [True])


def record(task: str = "pick_place", window: int = 20) -> ThresholdRecord:
    return ThresholdRecord(
        0.7, "argmax", window, task, "val", 50, 0.5, [{"seed": 0, "u": 1.0, "success": False}]
    )


def test_threshold_record_round_trip(tmp_path) -> None:
    record().save(tmp_path)
    assert ThresholdRecord.load(tmp_path) == record()
    assert ThresholdRecord.load(tmp_path / "missing") is None


def test_resolve_threshold_prefers_override_and_refuses_mismatches() -> None:
    assert resolve_threshold("min_unc", None, None, record(), "pick_place") == (0.7, 20, "checkpoint")
    assert resolve_threshold("min_unc", 0.3, None, record(), "pick_place") == (0.3, 20, "override")
    assert resolve_threshold("none", None, None, None, "push") == (None, 20, "none")
    with pytest.raises(ValueError, match="lerobot-ivmc-threshold"):
        resolve_threshold("rand", None, None, None, "push")
    with pytest.raises(ValueError, match="picked on task 'pick_place'"):
        resolve_threshold("min_unc", None, None, record(), "push")
    with pytest.raises(ValueError, match="window of 20 steps, not 10"):
        resolve_threshold("min_unc", None, 10, record(), "pick_place")


def test_the_deadline_comes_from_the_flag_or_the_record_and_auto_without_one_says_what_to_do() -> None:
    from dataclasses import replace

    from lerobot_ivmc.evaluation.threshold_picking import success_deadline
    from lerobot_ivmc.recovery.threshold import resolve_deadline

    assert success_deadline([40, 300, 117, 300], [True, False, True, False]) == 118
    assert success_deadline([300, 300], [False, False]) is None
    assert resolve_deadline(0, record()) == (0, "none")
    assert resolve_deadline(90, None) == (90, "flag")
    assert resolve_deadline("auto", replace(record(), deadline=118)) == (118, "checkpoint")
    for without in (None, record()):  # no record; a record without a deadline (no validation success)
        with pytest.raises(
            ValueError, match=r"lerobot-ivmc-threshold .* or pass --recovery.deadline=<steps>"
        ):
            resolve_deadline("auto", without)
    with pytest.raises(ValueError, match="a number of steps or 'auto'"):
        RecoveryConfig(mode="retry", deadline="soon")
    with pytest.raises(ValueError, match="deadline must be >= 1"):
        replace(record(), deadline=0)


def test_a_nan_threshold_or_uncertainty_is_refused_wherever_it_is_read_or_written(tmp_path) -> None:
    """NaN > C is never true: a NaN threshold would silently turn recovery off (min unc = BVMC)."""
    with pytest.raises(ValueError, match=r"validation episodes' u must be finite, got nan at \[1\]"):
        argmax_threshold([0.1, float("nan"), 0.2], [False] * 3)
    with pytest.raises(ValueError, match="must be finite"):
        conformal_threshold([0.1, float("inf")] * 10, 0.1)
    with pytest.raises(ValueError, match="The threshold must be finite"):
        ThresholdRecord(**{**record().__dict__, "threshold": float("nan")})
    (tmp_path / THRESHOLD_FILE).write_text(json.dumps({**record().__dict__, "threshold": float("nan")}))
    with pytest.raises(ValueError, match=f"{tmp_path / THRESHOLD_FILE} is not a valid threshold record"):
        ThresholdRecord.load(tmp_path)
    with pytest.raises(ValueError, match="--recovery.threshold must be finite"):
        resolve_threshold("min_unc", float("nan"), None, None, "push")
    with pytest.raises(ValueError, match="--recovery.threshold must be a finite number"):
        RecoveryConfig(mode="min_unc", threshold=float("nan"))
