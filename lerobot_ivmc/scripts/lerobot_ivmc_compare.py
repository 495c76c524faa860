"""`lerobot-ivmc-compare`: paired comparison of evaluations on the same scenes.

Two `lerobot-ivmc-eval` runs with the same `--seed` see the same scenes in the same order, so their
episodes pair up. For the task (or any milestone) it counts the scenes both solve, only one solves and
neither solves, and gives the exact McNemar test on the discordant pairs (a two-sided binomial test).

    lerobot-ivmc-compare outputs/eval/bvmc outputs/eval/min_unc outputs/eval/rand

With `--pooled` the folders are pairs (baseline, other) of runs, e.g. one pair per training seed: each pair
is compared, then the counts are summed and tested together.

    lerobot-ivmc-compare --pooled seed1000/none seed1000/retry seed2000/none seed2000/retry
"""

from __future__ import annotations

import argparse
from pathlib import Path

from lerobot_ivmc.evaluation.compare import load_run, paired_outcomes, pooled_outcomes


def describe(header: str, first: str, second: str, result: dict, milestone: str) -> str:
    """One line: a pair's (or the pooled pairs') outcome counts and exact McNemar p."""
    shared = result["episodes"]
    unpaired = (
        f" of {result['episodes_first']} and {result['episodes_second']}"
        if "episodes_first" in result and shared != max(result["episodes_first"], result["episodes_second"])
        else ""
    )
    return (
        f"{header} ({milestone}, {shared} paired scenes{unpaired}): both {result['both']}, "
        f"only {first} {result['only_first']}, only {second} {result['only_second']}, neither "
        f"{result['neither']}; exact McNemar p = {result['mcnemar_exact_p']:.2g}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("baseline", type=Path, help="output folder of the reference run")
    parser.add_argument("others", type=Path, nargs="+", help="output folders of the runs to compare with it")
    parser.add_argument("--milestone", help="a subtask name; default: the task's last milestone (success)")
    parser.add_argument(
        "--pooled", action="store_true", help="read the folders as (baseline, other) pairs and pool them"
    )
    args = parser.parse_args()
    folders = [args.baseline, *args.others]
    if args.pooled and len(folders) % 2:
        parser.error(f"--pooled takes (baseline, other) pairs of folders, got {len(folders)} folders.")
    repeated = [folder for folder in dict.fromkeys(folders) if folders.count(folder) > 1]
    if args.pooled and repeated:
        parser.error(
            f"--pooled takes one (baseline, other) pair per training seed: {repeated[0]} appears twice."
        )
    pairs = (
        list(zip(folders[::2], folders[1::2], strict=True))
        if args.pooled
        else [(args.baseline, other) for other in args.others]
    )
    try:
        runs = {folder: load_run(folder) for folder in folders}
        milestone = args.milestone or list(runs[args.baseline]["per_episode"][0]["subtasks"])[-1]
        results = []
        for first, second in pairs:
            results.append(paired_outcomes(runs[first], runs[second], milestone))
            names = (str(first), str(second)) if args.pooled else (first.name, second.name)
            print(describe(f"{names[0]} vs {names[1]}", *names, results[-1], milestone))
        if args.pooled:
            pooled = pooled_outcomes(results)
            print(describe(f"pooled over {len(pairs)} pairs", "baseline", "other", pooled, milestone))
    except (FileNotFoundError, ValueError, KeyError) as error:
        parser.error(str(error))


if __name__ == "__main__":
    main()
