"""`lerobot-ivmc-detect`: failure-prediction metrics of a bvmc evaluation without recovery.

Reads a `lerobot-ivmc-eval --recovery.mode=none` output (per-episode u and the per-step traces) and the
threshold record of the evaluated checkpoint (its validation episodes), and writes `detection.json` and
plots: AUROC of u for failure; TPR, TNR, balanced accuracy and lead time at the paper's argmax threshold
and at a conformal threshold calibrated on the validation successes; the false-alarm rate on the test
successes against alpha for several alphas (the conformal guarantee, checked).

    lerobot-ivmc-detect --eval_dir=outputs/eval/bvmc_test --alpha=0.1
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.
from lerobot.configs import parser

from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.evaluation.detection_report import DetectionConfig, detect


def percent(rate: dict | None) -> str:
    """A rate as "12.3%", or "n/a" where it is undefined (no episode of that class)."""
    return "n/a" if rate is None else f"{rate['pc']:.1f}%"


@parser.wrap()
def detect_main(cfg: DetectionConfig) -> dict:
    result = detect(cfg)
    print(
        f"{result['task']}: AUROC of u for failure {result['auroc']:.3f} ({result['failures']} failures in "
        f"{result['episodes']} episodes)"
    )
    for name in ("argmax", "conformal"):
        m = result[name]
        if m is None:
            continue
        if "unavailable" in m:
            print(f"  {name:<9} unavailable: {m['unavailable']}")
            continue
        median_lead = (m.get("lead_time_steps") or {}).get("median", float("nan"))
        balanced = m.get("balanced_accuracy", float("nan"))
        print(
            f"  {name:<9} C={m['threshold']:.3f}: TPR {percent(m['tpr'])}, TNR {percent(m['tnr'])}, "
            f"balanced {balanced:.1f}%, lead time {median_lead:.0f} steps (median)"
        )
    for row in result["conformal_sweep"]:
        rate = row["false_alarm_rate"]
        verdict = "within" if row["within_bound"] else "OUTSIDE"
        print(
            f"  alpha {row['alpha']:.2f}: false alarms on test successes {rate['pc']:.1f} +- "
            f"{rate['stderr']:.1f}% ({verdict} alpha + 2 SE)"
        )
    return result


def main() -> None:
    cli_main(detect_main)


if __name__ == "__main__":
    main()
