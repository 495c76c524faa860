"""Failure-prediction metrics of a bvmc evaluation without recovery, the library of `lerobot-ivmc-detect`
(`scripts/lerobot_ivmc_detect.py`): AUROC of u, the metrics at the argmax and a conformal threshold, the
conformal sweep against alpha, written to `detection.json` with plots."""

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path

from lerobot_ivmc.atomic_files import write_json_atomic
from lerobot_ivmc.constants import EVAL_INFO_FILE
from lerobot_ivmc.evaluation.compare import time_conditioned
from lerobot_ivmc.evaluation.detection import (
    WINDOW_SUM_LABEL,
    auroc,
    conformal_sweep,
    metrics_at_threshold,
    plot_detection,
)
from lerobot_ivmc.evaluation.traces import TRACES_FILE, load_traces
from lerobot_ivmc.recovery.threshold import ThresholdRecord, check_finite, conformal_threshold
from lerobot_ivmc.recovery.time_baseline import baseline_digest

logger = logging.getLogger(__name__)

DETECTION_FILE = "detection.json"


@dataclass
class DetectionConfig:
    """Args:
    eval_dir: output folder of `lerobot-ivmc-eval` without recovery (the test episodes to score).
    threshold_path: checkpoint folder whose `recovery_threshold.json` gives the argmax threshold and the
        validation episodes for conformal calibration; default: the evaluated checkpoint.
    alpha: the false-alarm bound of the conformal threshold reported next to the argmax one.
    alphas: the alphas of the sweep that checks the conformal guarantee on test successes.
    output_dir: where detection.json and the plots go; default: `<eval_dir>/detection`.
    """

    eval_dir: Path | None = None
    threshold_path: Path | None = None
    alpha: float = 0.1
    alphas: list[float] = field(default_factory=lambda: [0.02, 0.05, 0.1, 0.2, 0.3, 0.5])
    output_dir: Path | None = None


def detect(cfg: DetectionConfig) -> dict:
    if cfg.eval_dir is None or not (Path(cfg.eval_dir) / EVAL_INFO_FILE).is_file():
        raise FileNotFoundError(f"--eval_dir={cfg.eval_dir} holds no eval_info.json of lerobot-ivmc-eval.")
    info = json.loads((Path(cfg.eval_dir) / EVAL_INFO_FILE).read_text())
    if info.get("recovery", {}).get("mode") != "none":
        raise ValueError(
            "Failure prediction is measured on episodes without recovery: pass the output of "
            "lerobot-ivmc-eval --recovery.mode=none (recovery changes what would have failed)."
        )
    threshold_path = cfg.threshold_path or Path(info["run"]["policy_path"])
    record = ThresholdRecord.load(threshold_path)
    if record is None:
        raise FileNotFoundError(
            f"{threshold_path} has no recovery_threshold.json: pick one with lerobot-ivmc-threshold, or pass "
            "--threshold_path."
        )
    if record.task != info["run"]["task"]:
        raise ValueError(
            f"The threshold was picked on {record.task!r}, the eval ran {info['run']['task']!r}."
        )
    if not 0 < cfg.alpha < 1 or not all(0 < a < 1 for a in cfg.alphas):
        raise ValueError(
            f"--alpha and --alphas are false-alarm bounds in (0, 1), got {cfg.alpha}, {cfg.alphas}."
        )
    conditioned = time_conditioned(info)
    digest = info["recovery"].get("baseline_digest")
    if conditioned and record.baseline is not None and digest not in (None, baseline_digest(record.baseline)):
        raise ValueError(
            f"--eval_dir={cfg.eval_dir} scored its episodes with another time-conditioned baseline than the "
            f"threshold of {threshold_path}: evaluate the checkpoint that holds this threshold, or pass its "
            "--threshold_path."
        )
    if conditioned != (record.baseline is not None):
        raise ValueError(
            f"--eval_dir={cfg.eval_dir} scored its episodes by the "
            f"{'time-conditioned' if conditioned else 'window-sum'} score, the threshold of "
            f"{threshold_path} applies to the other: evaluate the checkpoint that holds this threshold, or "
            "pass its --threshold_path."
        )
    episodes = info["per_episode"]
    validation_seeds = {e.get("seed") for e in record.episodes} - {None}
    if info["run"]["split"] == record.split and validation_seeds & {e["seed"] for e in episodes}:
        raise ValueError(
            f"--eval_dir={cfg.eval_dir} ran the {record.split!r} scenes the threshold was picked on: its "
            "metrics would be in-sample. Score a run on held-out scenes (--env.split=test)."
        )
    scores = list(
        check_finite(
            f"max_uncertainty in {cfg.eval_dir}/eval_info.json", [e["max_uncertainty"] for e in episodes]
        )
    )
    failures = [not e["success"] for e in episodes]
    traces = [t["window_sum"] for t in load_traces(Path(cfg.eval_dir) / TRACES_FILE)]
    calibration = [e["u"] for e in record.episodes if e["success"]]
    try:
        conformal = conformal_threshold(calibration, cfg.alpha)
    except ValueError as error:  # too few calibration successes: report the rest, say why this is missing
        conformal, conformal_missing = None, str(error)
    sweep = conformal_sweep(calibration, scores, failures, sorted(cfg.alphas))
    # What the traces and the threshold are on: the window sum, or its time-conditioned ratio.
    summed = "window sum" if record.baseline is None else "time-conditioned window sum"
    result = {
        "task": info["run"]["task"],
        "episodes": len(episodes),
        "failures": int(sum(failures)),
        "window": record.window,
        "score": "max window sum"
        if record.baseline is None
        else f"time-conditioned (quantile {record.baseline_quantile})",
        "auroc": auroc(scores, failures),
        "calibration": {
            "split": record.split,
            "episodes": len(record.episodes),
            "successes": len(calibration),
        },
        "argmax": metrics_at_threshold(scores, failures, record.threshold, traces)
        if record.method == "argmax"
        else None,
        "conformal": {"alpha": cfg.alpha, **metrics_at_threshold(scores, failures, conformal, traces)}
        if conformal is not None
        else {"alpha": cfg.alpha, "unavailable": conformal_missing},
        "conformal_sweep": sweep,
        "lead_time_definition": f"steps from the first {summed} above the threshold to the episode's end",
    }
    output_dir = Path(cfg.output_dir or Path(cfg.eval_dir) / "detection")
    thresholds = {f"conformal a={cfg.alpha}": conformal} if conformal is not None else {}
    if record.method == "argmax":
        thresholds = {"argmax": record.threshold, **thresholds}
    title = f"{result['task']}: {len(episodes)} {info['run']['split']} episodes"
    score_label = WINDOW_SUM_LABEL if record.baseline is None else "window sum / success baseline"
    result["plots"] = [
        p.name
        for p in plot_detection(scores, failures, traces, thresholds, sweep, output_dir, title, score_label)
    ]
    write_json_atomic(output_dir / DETECTION_FILE, result)
    return result
