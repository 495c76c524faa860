"""The time-conditioned score (beyond the paper): the sliding-window sum at step t divided by what successful
validation episodes reached at step t, so that a phase where every episode is uncertain does not look like a
failure (the time-varying calibration of FAIL-Detect, applied to the paper's window sum). Fitting the
per-step baseline is here; choosing its quantile on validation scenes is `evaluation/threshold_picking.py`'s.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence

import numpy as np

from lerobot_ivmc.recovery.threshold import max_window_sum, window_sums

# A step's baseline needs this many successful episodes still running; later steps carry the last one.
MIN_SUCCESSES = 5


def success_baseline(
    sums: Sequence[np.ndarray], successes: Sequence[bool], quantile: float, min_successes: int = MIN_SUCCESSES
) -> np.ndarray:
    """The per-step baseline of the time-conditioned score.

    Args:
        sums: per episode, its (T_e,) sliding-window sums (index = step) without recovery.
        successes: per episode, its task success.
        quantile: which quantile of the successes' window sums at each step, in (0, 1].
        min_successes: the fewest successful episodes still running for a step's own quantile.

    Returns:
        (T,) the quantile at each step, T the longest success; past the step where fewer than
        `min_successes` successes still run, the last quantile carried forward.
    """
    ok = np.asarray(successes, dtype=bool)
    if int(ok.sum()) < min_successes:
        raise ValueError(
            f"A time-conditioned baseline needs at least {min_successes} successful validation episodes, "
            f"got {int(ok.sum())}: evaluate more validation scenes (--eval.n_episodes)."
        )
    if not 0.0 < quantile <= 1.0:
        raise ValueError(f"The baseline's quantile must lie in (0, 1], got {quantile}.")
    kept = [np.asarray(s, dtype=np.float64) for s, success in zip(sums, ok, strict=True) if success]
    running = np.full((len(kept), max(len(s) for s in kept)), np.nan)  # NaN past an episode's end
    for row, s in enumerate(kept):
        running[row, : len(s)] = s
    still_running = np.isfinite(running).sum(axis=0)
    last = int(np.flatnonzero(still_running >= min_successes)[-1])
    baseline = np.nanquantile(running[:, : last + 1], quantile, axis=0)
    return np.concatenate([baseline, np.full(running.shape[1] - last - 1, baseline[-1])])


def step_scores(sums: np.ndarray, steps: np.ndarray, baseline: np.ndarray, window: int) -> np.ndarray:
    """Time-conditioned scores: window sums (B,) over the baseline at each one's step (B,) (its last value
    past its end); 0 before the first full window, where no score is compared."""
    steps = np.asarray(steps)
    ratio = np.asarray(sums, dtype=np.float64) / baseline[np.minimum(steps, len(baseline) - 1)]
    return np.where(steps >= window - 1, ratio, 0.0)


def normalized_sums(sums: np.ndarray, baseline: np.ndarray, window: int) -> np.ndarray:
    """(T,) an episode's window sums (T,) as time-conditioned scores, step by step."""
    return step_scores(sums, np.arange(len(sums)), baseline, window)


def episode_score(
    uncertainties: Sequence[float] | np.ndarray, window: int, baseline: np.ndarray | None = None
) -> float:
    """An episode's u: the maximum window sum (the paper's), or with a baseline the maximum time-conditioned
    score."""
    if baseline is None:
        return max_window_sum(uncertainties, window)
    if len(uncertainties) == 0:
        raise ValueError("An episode needs at least one step to have a maximum uncertainty.")
    return float(normalized_sums(window_sums(uncertainties, window), baseline, window).max())


def baseline_digest(baseline: Sequence[float] | np.ndarray) -> str:
    """A short fingerprint of a baseline, recorded with the runs scored by it: u of runs with different
    baselines are not comparable."""
    return hashlib.sha1(np.asarray(baseline, dtype=np.float64).tobytes()).hexdigest()[:16]
