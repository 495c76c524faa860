"""Would the time-conditioned score detect failures better than the paper's max window sum? Offline, from
the uncertainty traces a study already wrote, without evaluating again.

The time-conditioned score (`recovery/time_baseline.py`, `lerobot-ivmc-threshold --score=time_conditioned`)
divides the window sum at step t by a quantile of the successful validation episodes' window sums at step t.
The quantile and C are chosen on the validation run alone, as `lerobot-ivmc-threshold` chooses them; the test
run is scored once.

    python -m diagnostics.time_baseline_detection --val_dir <study>/threshold/fc1 \\
        --test_dir <study>/eval/bvmc_fc1_none
"""

import argparse
from pathlib import Path

import numpy as np

from lerobot_ivmc.evaluation.compare import load_run
from lerobot_ivmc.evaluation.detection import auroc
from lerobot_ivmc.evaluation.threshold_picking import fit_time_baseline
from lerobot_ivmc.evaluation.traces import TRACES_FILE, load_traces
from lerobot_ivmc.recovery.threshold import DEFAULT_WINDOW, argmax_threshold, window_sums
from lerobot_ivmc.recovery.time_baseline import normalized_sums


def load_episodes(folder: Path, window: int) -> tuple[list[np.ndarray], np.ndarray]:
    """Per episode its (T_e,) window sums (index = step), made again from the step uncertainties (a run
    scored by a time-conditioned threshold records ratios), and (E,) success, of an evaluation without
    recovery."""
    episodes = load_run(folder)["per_episode"]
    traces = [window_sums(trace["uncertainty"], window) for trace in load_traces(folder / TRACES_FILE)]
    return traces, np.array([bool(e["success"]) for e in episodes])


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--val_dir", type=Path, required=True, help="the threshold stage's validation run")
    parser.add_argument("--test_dir", type=Path, required=True, help="BVMC's test run without recovery")
    parser.add_argument("--quantiles", type=float, nargs="+", default=[0.5, 0.75, 0.9, 1.0])
    parser.add_argument("--window", type=int, default=DEFAULT_WINDOW)
    args = parser.parse_args()
    val, val_successes = load_episodes(args.val_dir, args.window)
    test, test_successes = load_episodes(args.test_dir, args.window)
    q, baseline, val_scores, val_auroc = fit_time_baseline(val, val_successes, args.window, args.quantiles)
    window_auroc = auroc([s.max() for s in val], ~val_successes)
    # `lerobot-ivmc-threshold --score=auto` keeps the time-conditioned score only where it is strictly better.
    kept = "time-conditioned" if val_auroc > window_auroc else "max window sum"
    print(
        f"{args.val_dir}: validation AUROC, max window sum {window_auroc:.3f}, time-conditioned "
        f"(cross-fitted) {val_auroc:.3f}: --score=auto keeps the {kept}"
    )
    threshold, _ = argmax_threshold(val_scores, val_successes)
    scores = np.array([normalized_sums(sums, baseline, args.window).max() for sums in test])
    failures = ~test_successes
    flagged = scores > threshold
    print(f"{args.test_dir}: {len(test)} test episodes, {int(failures.sum())} failures")
    print(f"  test AUROC, max window sum (the paper's score): {auroc([s.max() for s in test], failures):.3f}")
    print(f"  test AUROC, time-conditioned (quantile {q}): {auroc(scores, failures):.3f}")
    print(
        f"  at C = {threshold:.3f} (argmax on validation): flags {int((flagged & failures).sum())} of "
        f"{int(failures.sum())} failures and {int((flagged & ~failures).sum())} of {int((~failures).sum())} "
        "successes"
    )


if __name__ == "__main__":
    main()
