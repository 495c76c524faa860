"""`lerobot-ivmc-compare`: paired comparison of evaluations on the same scenes.

Two `lerobot-ivmc-eval` runs with the same `--seed` see the same scenes in the same order, so their
episodes pair up. For the task (or any milestone) it counts the scenes both solve, only one solves and
neither solves, and gives the exact McNemar test on the discordant pairs (a two-sided binomial test).

    lerobot-ivmc-compare outputs/eval/bvmc outputs/eval/min_unc outputs/eval/rand
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from scipy import stats

EVAL_INFO_FILE = "eval_info.json"


def load_episodes(folder: Path) -> list[dict]:
    path = Path(folder) / EVAL_INFO_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: pass the --output_dir of a lerobot-ivmc-eval run.")
    return json.loads(path.read_text())["per_episode"]


def paired_outcomes(a: list[dict], b: list[dict], milestone: str) -> dict:
    """Counts of (a, b) outcomes on paired episodes and the exact McNemar p-value."""
    if [e["seed"] for e in a] != [e["seed"] for e in b]:
        raise ValueError(
            "The runs did not evaluate the same scenes: rerun them with the same --seed and counts."
        )
    flags = [
        (bool(x["subtasks"][milestone]), bool(y["subtasks"][milestone])) for x, y in zip(a, b, strict=True)
    ]
    only_a = sum(x and not y for x, y in flags)
    only_b = sum(y and not x for x, y in flags)
    discordant = only_a + only_b
    p = stats.binomtest(only_b, discordant, 0.5).pvalue if discordant else 1.0
    return {
        "milestone": milestone,
        "episodes": len(flags),
        "both": sum(x and y for x, y in flags),
        "only_first": only_a,
        "only_second": only_b,
        "neither": sum(not x and not y for x, y in flags),
        "mcnemar_exact_p": float(p),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("baseline", type=Path, help="output folder of the reference run")
    parser.add_argument("others", type=Path, nargs="+", help="output folders of the runs to compare with it")
    parser.add_argument("--milestone", help="a subtask name; default: the task's last milestone (success)")
    args = parser.parse_args()
    try:
        base = load_episodes(args.baseline)
        milestone = args.milestone or list(base[0]["subtasks"])[-1]
        for other in args.others:
            result = paired_outcomes(base, load_episodes(other), milestone)
            print(
                f"{args.baseline.name} vs {other.name} ({milestone}, {result['episodes']} paired scenes): "
                f"both "
                f"{result['both']}, only {args.baseline.name} {result['only_first']}, only {other.name} "
                f"{result['only_second']}, neither {result['neither']}; exact McNemar p = "
                f"{result['mcnemar_exact_p']:.3f}"
            )
    except (FileNotFoundError, ValueError, KeyError) as error:
        parser.error(str(error))


if __name__ == "__main__":
    main()
