"""The paper's maximum uncertainty u of an episode and its recovery threshold ("Picking Uncertainty
Threshold"): picking it (argmax, conformal) and resolving the one an evaluation uses (the record a checkpoint
carries is `policies/bvmc/threshold_record.py`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from lerobot_ivmc.policies.bvmc.threshold_record import THRESHOLD_FILE, ThresholdRecord, check_finite

DEFAULT_WINDOW = 20  # the paper: "a sliding window of 20 frames best avoids noisy peaks"
# How a threshold is picked: the paper's argmax, or split conformal on the successful episodes.
THRESHOLD_METHODS = ("argmax", "conformal")
# What the threshold is compared with: the paper's window sum, the time-conditioned score
# (`recovery/time_baseline.py`), or whichever of the two tells the validation failures apart better.
SCORES = ("window_sum", "time_conditioned", "auto")


def window_sums(uncertainties: Sequence[float] | np.ndarray, window: int) -> np.ndarray:
    """Sum of the last `window` step uncertainties at every step (fewer at the episode's start).

    Args:
        uncertainties: (T,) per-step uncertainties of one episode.
        window: the sliding window's length in steps.

    Returns:
        (T,) running window sums.
    """
    if window < 1:
        raise ValueError(f"window must be >= 1 step, got {window}.")
    u = np.asarray(uncertainties, dtype=np.float64)
    cumulative = np.concatenate([[0.0], np.cumsum(u)])
    end = np.arange(1, len(u) + 1)
    return cumulative[end] - cumulative[np.maximum(end - window, 0)]


def max_window_sum(uncertainties: Sequence[float] | np.ndarray, window: int) -> float:
    """u(x): the maximum along the episode of the sliding-window sum of step uncertainties."""
    if len(uncertainties) == 0:
        raise ValueError("An episode needs at least one step to have a maximum uncertainty.")
    return float(window_sums(uncertainties, window).max())


def argmax_threshold(scores: Sequence[float], successes: Sequence[bool]) -> tuple[float, np.ndarray]:
    """The paper's threshold: i* = argmax_i |{x: u(x) > u_i}| * r - |{x: u(x) > u_i, success}|, C = u_{i*}.

    Under the paper's assumption that a recovered episode succeeds at the average rate r, the bracket is
    the gain in successes from recovering every episode whose u exceeds u_i. Ties go to the highest u_i:
    the same expected gain with the fewest recoveries (so with no validation failure, where every candidate
    gains nothing, no validation episode would trigger one).

    Args:
        scores: u of each validation episode.
        successes: its task success.

    Returns:
        The threshold C and the gain of every candidate u_i in increasing order of u.
    """
    u = check_finite("The validation episodes' u", scores)
    ok = np.asarray(successes, dtype=bool)
    if u.shape != ok.shape or u.ndim != 1 or len(u) == 0:
        raise ValueError(f"Need one success flag per score, got {u.shape} scores and {ok.shape} flags.")
    candidates = np.sort(u)
    above = u[None, :] > candidates[:, None]  # (candidate, episode)
    gains = above.sum(axis=1) * ok.mean() - (above & ok[None, :]).sum(axis=1)
    best = np.flatnonzero(np.isclose(gains, gains.max(), rtol=0.0, atol=1e-9))[-1]
    return float(candidates[best]), gains


def conformal_min_successes(alpha: float) -> int:
    """The fewest successful calibration episodes that give a conformal threshold at `alpha`: the least n
    with ceil((n + 1)(1 - alpha)) <= n."""
    return math.ceil((1.0 - alpha) / alpha - 1e-9)


def conformal_threshold(success_scores: Sequence[float], alpha: float) -> float:
    """Split conformal threshold from the scores of n successful calibration episodes.

    The ceil((n + 1)(1 - alpha))-th smallest score: on a new successful episode exchangeable with the
    calibration ones, P(score > threshold) <= alpha, i.e. the episode-level false-alarm rate is at most
    alpha (FAIL-Detect, Sentinel's STAC calibration).

    Args:
        success_scores: u of each successful calibration episode.
        alpha: the false-alarm bound, in (0, 1).

    Returns:
        The threshold.
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must lie in (0, 1), got {alpha}.")
    scores = np.sort(check_finite("The calibration episodes' u", success_scores))
    n = len(scores)
    rank = math.ceil((n + 1) * (1.0 - alpha) - 1e-9)  # the guard keeps 10 * 0.9 at 9
    if rank > n:
        needed = conformal_min_successes(alpha)
        raise ValueError(
            f"A conformal threshold at alpha={alpha} needs at least {needed} successful calibration "
            f"episodes; got {n}. Evaluate more validation episodes (--eval.n_episodes) or raise alpha."
        )
    return float(scores[rank - 1])


def resolve_threshold(
    mode: str,
    override: float | None,
    window: int | None,
    record: ThresholdRecord | None,
    task: str,
) -> tuple[float | None, int, str]:
    """The threshold and window an evaluation uses, and where the threshold came from.

    An explicit `override` wins over the checkpoint's record; a record picked on another task, or with
    another window than `window`, is refused.

    Returns:
        (threshold or None, window, source): source is "override", "checkpoint" or "none".
    """
    if record is not None and record.task != task:
        raise ValueError(
            f"The checkpoint's threshold was picked on task {record.task!r}, not {task!r}: pick one for "
            f"{task!r} with `lerobot-ivmc-threshold --policy.path=<checkpoint> --env.task={task} ...`, or "
            "pass --recovery.threshold=<value>."
        )
    if record is not None and window is not None and window != record.window:
        raise ValueError(
            f"The checkpoint's threshold applies to a window of {record.window} steps, not {window}: drop "
            "--recovery.window, or pick a threshold for that window (lerobot-ivmc-threshold "
            f"--recovery.window={window})."
        )
    window = window or (record.window if record is not None else DEFAULT_WINDOW)
    if override is not None:
        return float(check_finite("--recovery.threshold", override)), window, "override"
    if record is not None:
        return record.threshold, window, "checkpoint"
    if mode != "none":
        raise ValueError(
            f"--recovery.mode={mode} needs a threshold and the checkpoint has none ({THRESHOLD_FILE}): pick "
            "one on validation scenes with `lerobot-ivmc-threshold --policy.path=<checkpoint> --env.task="
            f"{task} --env.split=val ...` and evaluate the checkpoint it writes, or pass "
            "--recovery.threshold=<value>."
        )
    return None, window, "none"


def resolve_deadline(setting: int | str, record: ThresholdRecord | None) -> tuple[int, str]:
    """The deadline an evaluation uses (`--recovery.deadline`: steps, 0 for none, or "auto": the record's)
    and where it came from: "flag", "checkpoint" or "none"."""
    if setting != "auto":
        return int(setting), "flag" if setting else "none"
    if record is None or record.deadline is None:
        why = (
            "the checkpoint has no threshold record"
            if record is None
            else "its threshold record holds none (no successful validation episode, or picked before "
            "records kept one)"
        )
        raise ValueError(
            f"--recovery.deadline=auto reads the checkpoint's threshold record, but {why}: pick the "
            "threshold with lerobot-ivmc-threshold and evaluate the checkpoint it writes, or pass "
            "--recovery.deadline=<steps>."
        )
    return record.deadline, "checkpoint"
