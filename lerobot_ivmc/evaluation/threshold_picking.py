"""Picking a bvmc checkpoint's recovery threshold on validation scenes, the library of
`lerobot-ivmc-threshold` (`scripts/lerobot_ivmc_threshold.py`): the evaluation without recovery, the
threshold by the paper's argmax or by conformal calibration, and a new checkpoint folder holding the
threshold record."""

import logging
import shutil
from dataclasses import dataclass
from pathlib import Path

from lerobot_ivmc.constants import PRETRAINED_MODEL_DIR
from lerobot_ivmc.evaluation.eval_subtasks import IvmcEvalConfig, evaluate
from lerobot_ivmc.recovery.threshold import (
    DEFAULT_WINDOW,
    THRESHOLD_METHODS,
    ThresholdRecord,
    argmax_threshold,
    conformal_threshold,
)

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
    """

    method: str = "argmax"
    alpha: float = 0.1


def check_inputs(cfg: ThresholdPipelineConfig) -> Path:
    if cfg.method not in THRESHOLD_METHODS:
        raise ValueError(f"--method must be one of {THRESHOLD_METHODS}, got {cfg.method!r}.")
    if cfg.policy is None or cfg.policy.pretrained_path is None or cfg.policy.type != "bvmc":
        raise ValueError("Pass --policy.path=<bvmc checkpoint folder>: thresholds apply to bvmc uncertainty.")
    if not 0.0 < cfg.alpha < 1.0:
        raise ValueError(f"--alpha must lie in (0, 1), got {cfg.alpha}.")
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
        episodes=[
            {"seed": e["seed"], "u": u, "success": ok}
            for e, u, ok in zip(episodes, scores, successes, strict=True)
        ],
    )
    shutil.copytree(source, checkpoint)
    record.save(checkpoint)
    return record
