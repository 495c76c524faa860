"""`lerobot-ivmc-compare`: paired comparison of evaluations on the same scenes.

Two `lerobot-ivmc-eval` runs with the same `--seed` see the same scenes in the same order, so their
episodes pair up. For the task (or any milestone) it counts the scenes both solve, only one solves and
neither solves, and gives the exact McNemar test on the discordant pairs (a two-sided binomial test).

    lerobot-ivmc-compare outputs/eval/bvmc outputs/eval/min_unc outputs/eval/rand
"""

from __future__ import annotations

import argparse
from pathlib import Path

from lerobot_ivmc.evaluation.compare import load_run, paired_outcomes


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("baseline", type=Path, help="output folder of the reference run")
    parser.add_argument("others", type=Path, nargs="+", help="output folders of the runs to compare with it")
    parser.add_argument("--milestone", help="a subtask name; default: the task's last milestone (success)")
    args = parser.parse_args()
    try:
        base = load_run(args.baseline)
        milestone = args.milestone or list(base["per_episode"][0]["subtasks"])[-1]
        for other in args.others:
            result = paired_outcomes(base, load_run(other), milestone)
            shared = result["episodes"]
            unpaired = (
                f" of {result['episodes_first']} and {result['episodes_second']}"
                if shared != max(result["episodes_first"], result["episodes_second"])
                else ""
            )
            print(
                f"{args.baseline.name} vs {other.name} ({milestone}, {shared} paired scenes{unpaired}): "
                f"both "
                f"{result['both']}, only {args.baseline.name} {result['only_first']}, only {other.name} "
                f"{result['only_second']}, neither {result['neither']}; exact McNemar p = "
                f"{result['mcnemar_exact_p']:.3f}"
            )
    except (FileNotFoundError, ValueError, KeyError) as error:
        parser.error(str(error))


if __name__ == "__main__":
    main()
