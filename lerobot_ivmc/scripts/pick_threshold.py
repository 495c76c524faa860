"""`lerobot-ivmc-threshold`: pick the recovery threshold of a bvmc checkpoint on validation scenes.

Runs the Bayesian VMC (mean of S samples, no recovery) through `lerobot-ivmc-eval` on validation
scenes, records per episode its success and u (the maximum sliding-window sum of step uncertainties),
picks the threshold with the paper's argmax, and writes a NEW checkpoint folder
`<output_dir>/pretrained_model`: a copy of the input with `recovery_threshold.json` (the threshold, the
window and the (u, success) pairs it came from), which `lerobot-ivmc-eval --recovery.mode=...` finds from
`--policy.path` alone. The evaluation's own outputs (eval_info.json, traces, Fig. 3) stay in `<output_dir>`.

    lerobot-ivmc-threshold --policy.path=<bvmc checkpoint> --env.type=ivmc --env.task=pick_place \\
        --env.split=val --eval.n_episodes=100 --eval.batch_size=10 --seed=0 --output_dir=outputs/threshold
"""

import logging
import shutil
from dataclasses import dataclass
from pathlib import Path

from lerobot.configs import parser

from lerobot_ivmc.evaluation.eval_subtasks import IvmcEvalConfig, evaluate
from lerobot_ivmc.recovery.threshold import (
    DEFAULT_WINDOW,
    THRESHOLD_METHODS,
    ThresholdRecord,
    argmax_threshold,
    conformal_threshold,
)
from lerobot_ivmc.scripts.errors import cli_main

logger = logging.getLogger(__name__)

CHECKPOINT_DIR = "pretrained_model"


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


@parser.wrap()
def threshold_main(cfg: ThresholdPipelineConfig) -> ThresholdRecord:
    record = pick(cfg)
    above = sum(e["u"] > record.threshold for e in record.episodes)
    print(
        f"{record.task}: threshold C = {record.threshold:.4f} ({record.method}, window {record.window}) from "
        f"{len(record.episodes)} {record.split} episodes; {above} of them exceed it."
    )
    if all(e["success"] for e in record.episodes):
        print(
            f"No {record.split} episode failed: the threshold has nothing to learn from. Recovery will "
            "trigger only above every validation episode's uncertainty; to bound false alarms instead, use "
            "--method=conformal --alpha=<rate>."
        )
    print(f"Checkpoint with the threshold: {Path(cfg.output_dir) / CHECKPOINT_DIR}")
    return record


def main() -> None:
    cli_main(threshold_main)


if __name__ == "__main__":
    main()
