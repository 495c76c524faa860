"""Picking a bvmc checkpoint's recovery threshold on validation scenes, the library of
`lerobot-ivmc-threshold` (`scripts/lerobot_ivmc_threshold.py`): the evaluation without recovery, the
threshold by the paper's argmax or by conformal calibration, optionally on the time-conditioned score, and a
new checkpoint folder holding the threshold record."""

import logging
import math
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lerobot_ivmc.constants import PRETRAINED_MODEL_DIR
from lerobot_ivmc.evaluation.detection import auroc
from lerobot_ivmc.evaluation.eval_subtasks import IvmcEvalConfig, evaluate
from lerobot_ivmc.evaluation.traces import TRACES_FILE, load_traces
from lerobot_ivmc.recovery.threshold import (
    DEFAULT_WINDOW,
    SCORES,
    THRESHOLD_METHODS,
    ThresholdRecord,
    argmax_threshold,
    conformal_threshold,
)
from lerobot_ivmc.recovery.time_baseline import MIN_SUCCESSES, normalized_sums, success_baseline

logger = logging.getLogger(__name__)

CHECKPOINT_DIR = PRETRAINED_MODEL_DIR


@dataclass
class ThresholdPipelineConfig(IvmcEvalConfig):
    """`lerobot-ivmc-eval`'s config plus the threshold method.

    Args:
        method: "argmax", the paper's pick (maximise the expected gain in successes from recovering), or
            "conformal": split conformal calibration on the successful episodes only, which bounds the
            episode-level false-alarm rate on successes by `alpha`.
        alpha: the false-alarm bound of the conformal threshold.
        score: what C is compared with: "window_sum" (the paper's), "time_conditioned" (beyond the paper:
            the window sum over a per-step quantile of the successful validation episodes' window sums, so
            that a phase where every episode is uncertain raises no alarm; `recovery/time_baseline.py`), or
            "auto": the one of the two that tells the validation failures from the successes better (AUROC;
            the time-conditioned score's cross-fitted, ties to the window sum).
        quantiles: the baseline's candidate quantiles; the one whose cross-fitted scores best tell the
            validation failures from the successes (AUROC) is kept.
    """

    method: str = "argmax"
    alpha: float = 0.1
    score: str = "window_sum"
    quantiles: list[float] = field(default_factory=lambda: [0.5, 0.75, 0.9, 1.0])


def check_inputs(cfg: ThresholdPipelineConfig) -> Path:
    if cfg.method not in THRESHOLD_METHODS:
        raise ValueError(f"--method must be one of {THRESHOLD_METHODS}, got {cfg.method!r}.")
    if cfg.policy is None or cfg.policy.pretrained_path is None or cfg.policy.type != "bvmc":
        raise ValueError("Pass --policy.path=<bvmc checkpoint folder>: thresholds apply to bvmc uncertainty.")
    if not 0.0 < cfg.alpha < 1.0:
        raise ValueError(f"--alpha must lie in (0, 1), got {cfg.alpha}.")
    if cfg.score not in SCORES:
        raise ValueError(f"--score must be one of {SCORES}, got {cfg.score!r}.")
    if cfg.score != "window_sum" and not (cfg.quantiles and all(0.0 < q <= 1.0 for q in cfg.quantiles)):
        raise ValueError(f"--quantiles must list quantiles in (0, 1], got {cfg.quantiles}.")
    if cfg.recovery.mode != "none":
        raise ValueError("Thresholds are picked on episodes without recovery: drop --recovery.mode.")
    if cfg.env.split == "test":
        raise ValueError(
            "Pick thresholds on validation scenes (--env.split=val): the test scenes are kept for the final "
            "evaluation."
        )
    checkpoint = Path(cfg.output_dir) / CHECKPOINT_DIR
    if checkpoint.exists():
        raise FileExistsError(
            f"{checkpoint} exists: pass another --output_dir (checkpoints are never overwritten)."
        )
    return checkpoint


def pick(cfg: ThresholdPipelineConfig) -> ThresholdRecord:
    checkpoint = check_inputs(cfg)
    cfg.recovery.window = cfg.recovery.window or DEFAULT_WINDOW
    source = Path(cfg.policy.pretrained_path)
    info = evaluate(cfg, ignore_stored_threshold=True)
    episodes = info["per_episode"]
    scores = [e["max_uncertainty"] for e in episodes]
    successes = [bool(e["success"]) for e in episodes]
    baseline, quantile, separation = None, None, None
    traces = load_traces(Path(cfg.output_dir) / TRACES_FILE)
    if cfg.score != "window_sum":
        sums = [trace["window_sum"] for trace in traces]
        scores, baseline, quantile, separation = choose_score(sums, scores, successes, cfg)
    if cfg.method == "conformal":
        threshold = conformal_threshold([u for u, ok in zip(scores, successes, strict=True) if ok], cfg.alpha)
    else:
        threshold, _ = argmax_threshold(scores, successes)
    record = ThresholdRecord(
        threshold=threshold,
        method=cfg.method,
        alpha=cfg.alpha if cfg.method == "conformal" else None,
        window=cfg.recovery.window,
        task=cfg.env.task,
        split=cfg.env.split,
        num_samples=cfg.policy.num_samples,
        uncertainty_lambda=cfg.policy.uncertainty_lambda,
        baseline=None if baseline is None else baseline.tolist(),
        baseline_quantile=quantile,
        score_auroc=separation,
        deadline=success_deadline([len(t["uncertainty"]) for t in traces], successes),
        episodes=[
            {"seed": e["seed"], "u": u, "success": ok}
            for e, u, ok in zip(episodes, scores, successes, strict=True)
        ],
    )
    shutil.copytree(source, checkpoint)
    record.save(checkpoint)
    return record


def success_deadline(lengths: Sequence[int], successes: Sequence[bool]) -> int | None:
    """The deadline `--recovery.deadline=auto` fires at: the longest successful episode's steps + 1 (a rollout
    that runs longer has outlived every success); None without a success."""
    steps = [n for n, ok in zip(lengths, successes, strict=True) if ok]
    return max(steps) + 1 if steps else None


def choose_score(
    sums: list[np.ndarray], window_scores: list[float], successes: list[bool], cfg: ThresholdPipelineConfig
) -> tuple[list[float], np.ndarray | None, float | None, dict[str, float | None]]:
    """The validation episodes' u of the score `cfg.score` asks for, its baseline and quantile (None for the
    window sum), and each score's validation AUROC (None without a failure, or for a time-conditioned score
    `auto` could not fit: too few successes, when it keeps the window sum)."""
    failures = [not ok for ok in successes]
    window_auroc = auroc(window_scores, failures)
    separation = {"window_sum": None if math.isnan(window_auroc) else window_auroc, "time_conditioned": None}
    try:
        quantile, baseline, fitted, fitted_auroc = fit_time_baseline(
            sums, successes, cfg.recovery.window, cfg.quantiles
        )
    except ValueError:
        if cfg.score == "auto":
            return window_scores, None, None, separation
        raise
    separation["time_conditioned"] = None if math.isnan(fitted_auroc) else fitted_auroc
    better = (separation["time_conditioned"] or 0.0) > (separation["window_sum"] or 0.0)
    if cfg.score == "time_conditioned" or better:
        return fitted.tolist(), baseline, quantile, separation
    return window_scores, None, None, separation


def cross_fitted_scores(
    sums: Sequence[np.ndarray], successes: Sequence[bool], window: int, quantile: float
) -> np.ndarray:
    """(E,) each episode's time-conditioned u under a baseline made without it: episodes alternate between
    two folds, and each fold is scored with the other fold's successes."""
    ok = np.asarray(successes, dtype=bool)
    index = np.arange(len(sums))
    scores = np.empty(len(sums))
    for fold in (0, 1):
        base, scored = index[index % 2 == fold], index[index % 2 != fold]
        baseline = success_baseline([sums[i] for i in base], ok[base], quantile)
        for i in scored:
            scores[i] = normalized_sums(sums[i], baseline, window).max()
    return scores


def fit_time_baseline(
    sums: Sequence[np.ndarray], successes: Sequence[bool], window: int, quantiles: Sequence[float]
) -> tuple[float, np.ndarray, np.ndarray, float]:
    """The time-conditioned score's quantile, baseline and the validation episodes' u.

    Args:
        sums: per validation episode, its (T_e,) window sums without recovery.
        successes: per episode, its task success.
        window: the sliding window's length.
        quantiles: the candidates.

    Returns:
        The quantile whose cross-fitted scores have the highest AUROC (ties, or no failure to tell: the
        first listed), the (T,) baseline from all successes at it, the (E,) cross-fitted scores, on which C
        is picked, and their AUROC (NaN without a failure).
    """
    failures = ~np.asarray(successes, dtype=bool)
    halves = [int((~failures[fold::2]).sum()) for fold in (0, 1)]
    if min(halves) < MIN_SUCCESSES:
        raise ValueError(
            f"The time-conditioned score needs {MIN_SUCCESSES} successful validation episodes in each half "
            f"(every other episode), got {halves[0]} and {halves[1]}: evaluate more validation scenes "
            "(--eval.n_episodes), or pass --score=window_sum."
        )
    fitted = {q: cross_fitted_scores(sums, successes, window, q) for q in quantiles}
    separation = {q: auroc(scores, failures) for q, scores in fitted.items()}
    logger.info("Validation AUROC of the cross-fitted time-conditioned score per quantile: %s", separation)
    best = max(quantiles, key=lambda q: -math.inf if math.isnan(separation[q]) else separation[q])
    return best, success_baseline(sums, successes, best), fitted[best], separation[best]
