"""Failure prediction measured as the field measures runtime failure detectors (FAIL-Detect, Sentinel).

One score per episode, the paper's u (the maximum sliding-window sum of step uncertainties), label =
task failure. Reported: AUROC; at a threshold, TPR (failures flagged), TNR (successes not flagged),
balanced accuracy and the alarm lead time of flagged failures (steps from the first step whose window sum
exceeds the threshold to the end of the episode: a failed episode runs to the 200-step limit, so this is
the time left to act); and, for conformal thresholds calibrated on successful validation episodes, the
false-alarm rate on test successes against the bound alpha.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from sklearn.metrics import roc_auc_score, roc_curve

from lerobot_ivmc.evaluation.metrics import rate_with_stderr
from lerobot_ivmc.recovery.threshold import conformal_threshold

# The score-traces plot's axis for the paper's score.
WINDOW_SUM_LABEL = "sliding-window sum of uncertainty"


def first_crossing(window_sums: np.ndarray, threshold: float) -> int | None:
    """The first step whose window sum exceeds the threshold, or None."""
    above = np.flatnonzero(np.asarray(window_sums) > threshold)
    return int(above[0]) if len(above) else None


def auroc(scores: Sequence[float], failures: Sequence[bool]) -> float:
    """Area under the ROC curve of the score for failure (NaN when only one class is present)."""
    failures = np.asarray(failures, dtype=bool)
    if failures.all() or not failures.any():
        return float("nan")
    return float(roc_auc_score(failures, np.asarray(scores, dtype=np.float64)))


def metrics_at_threshold(
    scores: Sequence[float],
    failures: Sequence[bool],
    threshold: float,
    traces: Sequence[np.ndarray] | None = None,
) -> dict:
    """TPR, TNR, balanced accuracy (rates with binomial standard errors, in percent) and lead times.

    Args:
        scores: u per episode.
        failures: task failure per episode.
        threshold: an episode is flagged when u > threshold.
        traces: optional window-sum trace per episode, for the lead time of flagged failures.
    """
    u = np.asarray(scores, dtype=np.float64)
    failed = np.asarray(failures, dtype=bool)
    flagged = u > threshold
    result: dict = {
        "threshold": float(threshold),
        "failures": int(failed.sum()),
        "successes": int((~failed).sum()),
    }
    result["tpr"] = rate_with_stderr(flagged[failed].tolist()) if failed.any() else None
    result["tnr"] = rate_with_stderr((~flagged[~failed]).tolist()) if (~failed).any() else None
    if result["tpr"] and result["tnr"]:
        result["balanced_accuracy"] = (result["tpr"]["pc"] + result["tnr"]["pc"]) / 2
    if traces is not None:
        leads = [
            len(trace) - first_crossing(trace, threshold)
            for trace, f, g in zip(traces, failed, flagged, strict=True)
            if f and g
        ]
        result["lead_time_steps"] = (
            {
                "mean": float(np.mean(leads)),
                "std": float(np.std(leads)),
                "median": float(np.median(leads)),
                "q25": float(np.percentile(leads, 25)),
                "q75": float(np.percentile(leads, 75)),
                "n": len(leads),
            }
            if leads
            else None
        )
    return result


def conformal_sweep(
    calibration_success_scores: Sequence[float],
    test_scores: Sequence[float],
    test_failures: Sequence[bool],
    alphas: Sequence[float],
) -> list[dict]:
    """Per alpha: the conformal threshold from calibration successes, and on test: the false-alarm rate of
    successes (with its standard error, against alpha) and the TPR. Alphas too small for the number of
    calibration successes are skipped."""
    u = np.asarray(test_scores, dtype=np.float64)
    failed = np.asarray(test_failures, dtype=bool)
    rows = []
    for alpha in alphas:
        try:
            threshold = conformal_threshold(calibration_success_scores, alpha)
        except ValueError:
            continue
        false_alarms = rate_with_stderr((u[~failed] > threshold).tolist())
        rows.append(
            {
                "alpha": float(alpha),
                "threshold": threshold,
                "false_alarm_rate": false_alarms,
                "within_bound": false_alarms["pc"] <= 100 * alpha + 2 * false_alarms["stderr"],
                "tpr": rate_with_stderr((u[failed] > threshold).tolist()) if failed.any() else None,
            }
        )
    return rows


def plot_detection(
    scores: Sequence[float],
    failures: Sequence[bool],
    traces: Sequence[np.ndarray],
    thresholds: dict[str, float],
    sweep: list[dict],
    folder: Path,
    title: str,
    score_label: str = WINDOW_SUM_LABEL,
) -> list[Path]:
    """ROC curve, score traces of successes and failures with the thresholds, TPR / TNR vs alpha.

    `score_label` names what the traces hold: the window sum, or its time-conditioned ratio."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    failed = np.asarray(failures, dtype=bool)
    paths = []

    fig, ax = plt.subplots(figsize=(4, 4), dpi=120)
    if failed.any() and (~failed).any():
        fpr, tpr, _ = roc_curve(failed, scores)
        ax.plot(fpr, tpr, color="tab:red", label=f"u (AUROC {auroc(scores, failed):.2f})")
    else:
        missing = "failure" if not failed.any() else "success"
        ax.text(0.5, 0.5, f"no {missing} among these episodes:\nROC undefined", ha="center", va="center")
    ax.plot([0, 1], [0, 1], color="grey", ls=":", lw=1)
    ax.set_xlabel("false-positive rate (successes flagged)")
    ax.set_ylabel("true-positive rate (failures flagged)")
    paths.append(_save(fig, ax, title, folder / "roc.png", legend_loc="lower right"))

    fig, ax = plt.subplots(figsize=(6, 3.4), dpi=120)
    for trace, f in zip(traces, failed, strict=True):
        ax.plot(trace, color="tab:red" if f else "tab:blue", alpha=0.25, lw=0.8)
    for (name, value), style in zip(thresholds.items(), ("--", "-.", ":"), strict=False):
        ax.axhline(value, color="black", ls=style, lw=1, label=f"{name} threshold {value:.2f}")
    ax.plot([], [], color="tab:blue", label="successes")
    ax.plot([], [], color="tab:red", label="failures")
    ax.set_xlabel("step")
    ax.set_ylabel(score_label)
    paths.append(_save(fig, ax, title, folder / "score_traces.png", legend_loc="upper left"))

    if sweep:
        fig, ax = plt.subplots(figsize=(4, 3.4), dpi=120)
        alphas = [row["alpha"] for row in sweep]
        ax.plot(alphas, [100 - row["false_alarm_rate"]["pc"] for row in sweep], "o-", label="TNR (test)")
        if sweep[0]["tpr"] is not None:
            ax.plot(alphas, [row["tpr"]["pc"] for row in sweep], "s-", label="TPR (test)")
        ax.plot(alphas, [100 * (1 - a) for a in alphas], color="grey", ls=":", label="1 - alpha")
        ax.set_xlabel("alpha (conformal false-alarm bound)")
        ax.set_ylabel("[%]")
        paths.append(_save(fig, ax, title, folder / "tpr_tnr_vs_alpha.png", legend_loc="best"))
    return paths


def _save(fig, ax, title: str, path: Path, legend_loc: str) -> Path:
    import matplotlib.pyplot as plt

    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc=legend_loc)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
