"""The time-conditioned score on scripted uncertainty streams: the baseline, the trigger that compares it,
and picking its quantile and C on validation episodes."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from lerobot_ivmc.evaluation.detection import auroc
from lerobot_ivmc.evaluation.threshold_picking import choose_score, cross_fitted_scores, fit_time_baseline
from lerobot_ivmc.recovery.threshold import ThresholdRecord, argmax_threshold, max_window_sum, window_sums
from lerobot_ivmc.recovery.time_baseline import episode_score, normalized_sums, success_baseline
from lerobot_ivmc.recovery.trigger import RecoveryTrigger

WINDOW = 5


def success_stream(rng: np.random.Generator, length: int = 80) -> np.ndarray:
    """A success: uncertain in a phase every episode goes through (steps 20-30), calm after it."""
    u = 0.1 + 0.01 * rng.random(length)
    u[20:30] += 1.0
    return u


def failure_stream(rng: np.random.Generator, length: int = 120) -> np.ndarray:
    """A failure: the same phase, then uncertain for longer than any success, but far less than in the
    phase."""
    u = success_stream(rng, length)
    u[50:] += 0.3
    return u


def episodes(seed: int = 0, n_success: int = 12, n_failure: int = 6) -> tuple[list[np.ndarray], np.ndarray]:
    rng = np.random.default_rng(seed)
    streams = [success_stream(rng) for _ in range(n_success)] + [
        failure_stream(rng) for _ in range(n_failure)
    ]
    return streams, np.array([True] * n_success + [False] * n_failure)


def fired_steps(trigger: RecoveryTrigger, stream: np.ndarray) -> list[int]:
    return [t for t, u in enumerate(stream) if trigger.update(np.array([u]), np.array([True]))[0]]


def test_baseline_is_the_successes_quantile_per_step_carried_past_their_end() -> None:
    sums = [
        np.array([1.0, 2.0, 3.0]),
        np.array([3.0, 4.0]),
        np.array([5.0, 6.0, 9.0, 9.0]),
        np.array([100.0]),
    ]
    baseline = success_baseline(sums, [True, True, True, False], quantile=1.0, min_successes=2)
    # The failure is left out; step 2 has only 2 successes running, step 3 one: the last value carries.
    np.testing.assert_allclose(baseline, [5.0, 6.0, 9.0, 9.0])
    np.testing.assert_allclose(success_baseline(sums, [True] * 3 + [False], 0.5, 2)[:2], [3.0, 4.0])
    with pytest.raises(ValueError, match="at least 5 successful validation episodes, got 3"):
        success_baseline(sums, [True, True, True, False], quantile=1.0)


def test_a_phase_every_episode_is_uncertain_in_raises_no_alarm_but_a_failure_does() -> None:
    streams, successes = episodes()
    sums = [window_sums(u, WINDOW) for u in streams]
    # The paper's score cannot tell them apart: the shared phase is every episode's maximum.
    raw = [max_window_sum(u, WINDOW) for u in streams]
    assert auroc(raw, ~successes) < 0.8
    baseline = success_baseline(sums, successes, quantile=1.0)
    rng = np.random.default_rng(1)
    new_success, new_failure = success_stream(rng), failure_stream(rng)
    assert fired_steps(RecoveryTrigger(1, 1.5, WINDOW, 10, baseline=baseline), new_success) == []
    fired = fired_steps(RecoveryTrigger(1, 1.5, WINDOW, 10, baseline=baseline), new_failure)
    assert fired and 50 <= fired[0] < 60  # within a window of the failure's own uncertainty
    # The raw trigger at any C that spares the success's phase never fires on the failure.
    assert fired_steps(RecoveryTrigger(1, max_window_sum(new_success, WINDOW), WINDOW, 10), new_failure) == []


def test_trigger_compares_what_the_episode_score_takes_the_maximum_of() -> None:
    streams, successes = episodes()
    baseline = success_baseline([window_sums(u, WINDOW) for u in streams], successes, quantile=0.9)
    stream = failure_stream(np.random.default_rng(2))
    trigger = RecoveryTrigger(1, np.inf, WINDOW, 0, baseline=baseline)
    compared = []
    for u in stream:
        trigger.update(np.array([u]), np.array([True]))
        compared.append(trigger.decision_sums[0])
    expected = normalized_sums(window_sums(stream, WINDOW), baseline, WINDOW)
    np.testing.assert_allclose(compared, expected)
    assert np.all(expected[: WINDOW - 1] == 0.0)  # nothing compared before a full window
    assert episode_score(stream, WINDOW, baseline) == pytest.approx(max(compared))
    assert episode_score(stream, WINDOW) == max_window_sum(stream, WINDOW)


def test_picking_on_validation_separates_and_every_score_is_out_of_sample() -> None:
    streams, successes = episodes()
    sums = [window_sums(u, WINDOW) for u in streams]
    quantile, baseline, scores, separation = fit_time_baseline(sums, successes, WINDOW, [0.5, 1.0])
    assert auroc(scores, ~successes) == separation == 1.0
    threshold, _ = argmax_threshold(scores, successes)
    assert all(scores[~successes] > threshold) and not any(scores[successes] > threshold)
    # Each episode's score comes from the other fold's successes: changing episode 0 moves the scores
    # of the other fold and its own, never those of its fold's other episodes.
    changed = [s.copy() for s in sums]
    changed[0] = changed[0] * 3.0
    before = cross_fitted_scores(sums, successes, WINDOW, quantile)
    after = cross_fitted_scores(changed, successes, WINDOW, quantile)
    moved = np.flatnonzero(~np.isclose(before, after))
    assert 0 in moved and any(moved % 2 == 1) and all((moved == 0) | (moved % 2 == 1))
    np.testing.assert_allclose(baseline, success_baseline(sums, successes, quantile))


def test_record_keeps_the_baseline_and_refuses_a_bad_one(tmp_path) -> None:
    fields = dict(threshold=1.2, method="argmax", window=WINDOW, task="push-v3", split="val", num_samples=8)
    record = ThresholdRecord(
        **fields, uncertainty_lambda=1.0, baseline=[1.0, 2.0], baseline_quantile=0.9, episodes=[]
    )
    record.save(tmp_path)
    loaded = ThresholdRecord.load(tmp_path)
    assert loaded.baseline == [1.0, 2.0] and loaded.baseline_quantile == 0.9
    with pytest.raises(ValueError, match="baseline's window sums must be positive"):
        ThresholdRecord(**fields, uncertainty_lambda=1.0, baseline=[1.0, 0.0], episodes=[])


def test_a_fresh_memory_restarts_the_clock_the_baseline_is_read_by() -> None:
    """After a recovery that resets the policy's memory the policy starts again: its window sums are
    compared with the successes' early steps, and steps inside the manoeuvre do not count."""
    baseline = np.array([1.0] * 5 + [10.0] * 95)
    trigger = RecoveryTrigger(1, threshold=np.inf, window=2, initial_interval=0, baseline=baseline)

    def step(active: bool = True) -> float:
        trigger.update(np.array([1.0]), np.array([active]))
        return float(trigger.decision_sums[0])

    scores = [step() for _ in range(10)]
    assert scores[0] == 0.0 and scores[1:5] == [2.0] * 4 and scores[9] == pytest.approx(0.2)
    step(active=False)  # inside a manoeuvre: no clock step
    trigger.restart_clock(0)
    trigger.values[0], trigger.counts[0] = 0.0, 0  # the window the firing cleared
    assert [step(), step(), step()] == [0.0, 2.0, 2.0]


def test_auto_keeps_the_score_that_tells_the_validation_failures_apart() -> None:
    """Where failures are more uncertain in the shared phase too, the window sum separates them as well
    and auto keeps it (ties go to the paper's); where they are not, auto takes the time-conditioned."""
    streams, successes = episodes()
    sums = [window_sums(u, WINDOW) for u in streams]
    raw = [float(s.max()) for s in sums]
    cfg = SimpleNamespace(score="auto", quantiles=[0.5, 1.0], recovery=SimpleNamespace(window=WINDOW))
    scores, baseline, quantile, separation = choose_score(sums, raw, list(successes), cfg)
    assert baseline is not None and separation["time_conditioned"] > separation["window_sum"]
    louder = [u * (1.0 if ok else 3.0) for u, ok in zip(streams, successes, strict=True)]
    sums = [window_sums(u, WINDOW) for u in louder]
    raw = [float(s.max()) for s in sums]
    scores, baseline, quantile, separation = choose_score(sums, raw, list(successes), cfg)
    assert separation["window_sum"] == 1.0 and baseline is None and quantile is None and scores == raw
    cfg.score = "time_conditioned"
    assert choose_score(sums, raw, list(successes), cfg)[1] is not None


def test_detect_and_compare_refuse_scores_of_another_baseline(tmp_path) -> None:
    """u made with one baseline is not compared with a threshold or u of another, nor with the window sum."""
    import json

    from lerobot_ivmc.evaluation.compare import rescue_record
    from lerobot_ivmc.evaluation.detection_report import DetectionConfig, detect
    from lerobot_ivmc.recovery.time_baseline import baseline_digest

    checkpoint, eval_dir = tmp_path / "checkpoint", tmp_path / "eval"
    checkpoint.mkdir()
    eval_dir.mkdir()
    ThresholdRecord(
        threshold=1.0,
        method="argmax",
        window=WINDOW,
        task="push-v3",
        split="val",
        num_samples=8,
        uncertainty_lambda=1.0,
        baseline=[1.0, 2.0],
        baseline_quantile=1.0,
        episodes=[],
    ).save(checkpoint)
    source = "checkpoint (argmax), time-conditioned (quantile 1.0)"
    info = {
        "run": {"task": "push-v3", "split": "test", "policy_path": str(checkpoint)},
        "recovery": {
            "mode": "none",
            "threshold_source": source,
            "baseline_digest": baseline_digest([1.0, 3.0]),
        },
        "per_episode": [
            {"seed": 0, "max_uncertainty": 2.0, "success": False, "subtasks": {"success": False}}
        ],
    }
    (eval_dir / "eval_info.json").write_text(json.dumps(info))
    with pytest.raises(ValueError, match="another time-conditioned baseline than the threshold"):
        detect(DetectionConfig(eval_dir=eval_dir))
    (eval_dir / "eval_info.json").write_text(json.dumps({**info, "recovery": {"mode": "none"}}))
    with pytest.raises(ValueError, match="scored its episodes by the window-sum score"):
        detect(DetectionConfig(eval_dir=eval_dir))
    recovered = {**info, "recovery": {**info["recovery"], "threshold": 1.0}}
    recovered["per_episode"] = [{**info["per_episode"][0], "success": True, "subtasks": {"success": True}}]
    assert rescue_record(info, recovered, "success")["flagged"] == 1
    recovered["recovery"]["baseline_digest"] = baseline_digest([1.0, 2.0])
    rescue = rescue_record(info, recovered, "success")
    assert rescue["flagged"] is None and rescue["rescued"] == 1
