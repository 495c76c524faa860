"""The paper's maximum uncertainty u of an episode and its recovery threshold ("Picking Uncertainty
Threshold"), and the file that carries a picked threshold inside a checkpoint folder."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from lerobot_ivmc.atomic_files import write_json_atomic

THRESHOLD_FILE = "recovery_threshold.json"
DEFAULT_WINDOW = 20  # the paper: "a sliding window of 20 frames best avoids noisy peaks"
# How a threshold is picked: the paper's argmax, or split conformal on the successful episodes.
THRESHOLD_METHODS = ("argmax", "conformal")


def check_finite(name: str, values: Sequence[float] | np.ndarray | float) -> np.ndarray:
    """`values` as a float array if every one is finite, else a ValueError naming `name` and the first bad
    entries: a NaN threshold or uncertainty would silently turn recovery off (NaN > C is never true)."""
    array = np.asarray(values, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(array.reshape(-1)))
    if len(bad):
        where = "" if array.ndim == 0 else f" at {bad[:5].tolist()}{' ...' if len(bad) > 5 else ''}"
        raise ValueError(
            f"{name} must be finite, got {array.reshape(-1)[bad[0]]}{where}: a NaN or infinite uncertainty "
            "means a broken policy or record; retrain or pick the threshold again."
        )
    return array


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


@dataclass
class ThresholdRecord:
    """A picked threshold and the validation episodes it came from (`recovery_threshold.json`).

    Attributes:
        threshold: C, compared with the sliding-window sum of step uncertainties.
        method: how it was picked ("argmax": the paper's; "conformal": split conformal on successes).
        alpha: the false-alarm bound of a conformal threshold (None for argmax).
        window: the sliding window's length it applies to.
        task: the task of the validation episodes.
        split: their scene split.
        num_samples: S, Monte Carlo samples per step (the uncertainty's scale depends on it).
        uncertainty_lambda: lambda of the uncertainty measure.
        episodes: per validation episode: seed, u and success.
    """

    threshold: float
    method: str
    window: int
    task: str
    split: str
    num_samples: int
    uncertainty_lambda: float
    episodes: list[dict] = field(default_factory=list)
    alpha: float | None = None

    def __post_init__(self) -> None:
        check_finite("The threshold", self.threshold)
        check_finite("The validation episodes' u", [e["u"] for e in self.episodes])

    def save(self, folder: Path) -> Path:
        path = Path(folder) / THRESHOLD_FILE
        write_json_atomic(path, asdict(self))
        return path

    @classmethod
    def load(cls, folder: Path | str, **hub_kwargs) -> ThresholdRecord | None:
        """The record of a checkpoint, a local folder or a hub repo id (fetched with `hf_hub_download` and
        `hub_kwargs`, e.g. `revision`, `cache_dir`; the cache serves it offline), or None if it has none."""
        path = Path(folder) / THRESHOLD_FILE
        if not Path(folder).is_dir():
            path = hub_file(str(folder), THRESHOLD_FILE, **hub_kwargs)
        if path is None or not path.is_file():
            return None
        try:
            return cls(**json.loads(path.read_text()))
        except (ValueError, TypeError, KeyError) as error:  # (json's decode error is a ValueError)
            raise ValueError(f"{path} is not a valid threshold record ({error}); pick it again.") from error


def hub_file(repo_id: str, filename: str, **hub_kwargs) -> Path | None:
    """A file of a hub model repo, from the local cache or downloaded; None if the repo has no such file, the
    name is no repo id, or it is neither cached nor reachable."""
    from huggingface_hub import hf_hub_download
    from huggingface_hub.errors import EntryNotFoundError, HFValidationError, LocalEntryNotFoundError

    try:
        return Path(hf_hub_download(repo_id=repo_id, filename=filename, **hub_kwargs))
    except (EntryNotFoundError, LocalEntryNotFoundError, HFValidationError):
        return None


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
