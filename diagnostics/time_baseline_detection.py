"""Would a time-conditioned score detect failures better than the trigger's max window sum? Offline, from the
uncertainty traces a study already wrote.

The trigger compares the window sum of the uncertainty with one threshold at every step. A policy may be
uncertain at the same phase of every episode, successes included (door-open-v3, training seed 1000: the
threshold is crossed at steps 37-45 in two thirds of the episodes it fires in); one threshold then flags
successes. The time-conditioned score divides the window sum at step t by the q-quantile of the successful
validation episodes' window sums at step t (carried forward once fewer than `--min_successes` of them are
still running), and takes the episode's maximum, in the manner of the time-varying calibration of FAIL-Detect.
The quantile is chosen on validation scenes alone (two folds: the baseline from one half's successes scores
the other half); the test scenes are scored once, with the chosen quantile.

    python -m diagnostics.time_baseline_detection --val_dir <study>/threshold/fc1 \\
        --test_dir <study>/eval/bvmc_fc1_none
"""

import argparse
import json
from pathlib import Path

import numpy as np

from lerobot_ivmc.evaluation.detection import auroc
from lerobot_ivmc.evaluation.traces import TRACES_FILE, load_traces

# The trigger's first step (`--recovery.initial_interval`): earlier window sums are never compared.
FIRST_STEP = 20


def load_run(folder: Path) -> tuple[list[np.ndarray], np.ndarray]:
    """Per episode its (T_e,) window sums (index = step), and (E,) success, of an evaluation without
    recovery."""
    episodes = json.loads((folder / "eval_info.json").read_text())["per_episode"]
    traces = [trace["window_sum"] for trace in load_traces(folder / TRACES_FILE)]
    return traces, np.array([bool(e["success"]) for e in episodes])


def success_baseline(
    traces: list[np.ndarray], successes: np.ndarray, q: float, min_successes: int
) -> np.ndarray:
    """(T,) the q-quantile of the successful episodes' window sums at each step, carried forward where
    fewer than `min_successes` are still running (NaN before the first step with enough)."""
    length = max(len(sums) for sums in traces)
    running = np.full((int(successes.sum()), length), np.nan)  # successes end early: NaN past their end
    for row, sums in enumerate(sums for sums, success in zip(traces, successes, strict=True) if success):
        running[row, : len(sums)] = sums
    baseline, last = np.full(length, np.nan), np.nan
    for step, column in enumerate(running.T):
        values = column[np.isfinite(column)]
        last = float(np.quantile(values, q)) if len(values) >= min_successes else last
        baseline[step] = last
    return baseline


def scores(traces: list[np.ndarray], baseline: np.ndarray | None) -> np.ndarray:
    """(E,) each episode's max window sum from `FIRST_STEP` on; divided by the baseline when one is given
    (steps past the baseline's end use its last value)."""
    out = []
    for sums in traces:
        values = sums[FIRST_STEP:]
        if baseline is not None:
            values = values / baseline[np.minimum(np.arange(FIRST_STEP, len(sums)), len(baseline) - 1)]
        out.append(float(np.nanmax(values)) if np.isfinite(values).any() else 0.0)
    return np.array(out)


def validation_auroc(traces: list[np.ndarray], successes: np.ndarray, q: float, min_successes: int) -> float:
    """Mean AUROC over two folds of the validation episodes: one half's successes make the baseline, the
    other half is scored."""
    index = np.arange(len(traces))
    results = []
    for fold in (0, 1):
        base, scored = index[index % 2 == fold], index[index % 2 != fold]
        baseline = success_baseline([traces[i] for i in base], successes[base], q, min_successes)
        results.append(auroc(scores([traces[i] for i in scored], baseline), ~successes[scored]))
    return float(np.nanmean(results))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--val_dir", type=Path, required=True, help="the threshold stage's validation run")
    parser.add_argument("--test_dir", type=Path, required=True, help="BVMC's test run without recovery")
    parser.add_argument("--quantiles", type=float, nargs="+", default=[0.5, 0.75, 0.9, 1.0])
    parser.add_argument("--min_successes", type=int, default=5)
    args = parser.parse_args()
    val, val_successes = load_run(args.val_dir)
    test, test_successes = load_run(args.test_dir)
    if val_successes.sum() < 2 * args.min_successes:
        raise SystemExit(
            f"{args.val_dir} has {int(val_successes.sum())} successful episodes: too few for a baseline."
        )
    chosen = {q: validation_auroc(val, val_successes, q, args.min_successes) for q in args.quantiles}
    q = max(chosen, key=chosen.get)
    baseline = success_baseline(val, val_successes, q, args.min_successes)
    print(f"{args.test_dir}: {len(test)} test episodes, {int((~test_successes).sum())} failures")
    print(
        "  validation AUROC per quantile (two folds): "
        + ", ".join(f"{k}: {v:.3f}" for k, v in chosen.items())
    )
    failures = ~test_successes
    print(f"  test AUROC, max window sum (the trigger's score): {auroc(scores(test, None), failures):.3f}")
    print(f"  test AUROC, time-conditioned (q = {q}): {auroc(scores(test, baseline), failures):.3f}")


if __name__ == "__main__":
    main()
