"""Recovery variants against the same policy without recovery, scene by scene, with the failures' phases.

Each folder is a `lerobot-ivmc-eval` run on the same scenes (same `--seed`, split and task); the first is
the policy without recovery. Per variant it prints the success rate, the rescue record of
`lerobot_ivmc.evaluation.compare.rescue_record` (rescued, lost, (rescued - lost) / failures, exact McNemar
p), the phases at which the variant's failures stopped (the first milestone an episode never reached:
for pick_place "reach" = never reached the cube, "pick" = reached, not picked, "place" = picked, not
placed) and, of the baseline's failures in each phase, how many the variant rescued.

    python -m diagnostics.recovery_ablation <eval>/none <eval>/min_unc <eval>/anchor [--json ablation.json]
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

from lerobot_ivmc.evaluation.compare import load_run, rescue_record


def failure_phase(episode: dict) -> str | None:
    """The first milestone the episode never reached (None for a success)."""
    return next((name for name, reached in episode["subtasks"].items() if not reached), None)


def variant_row(baseline: dict, run: dict, milestone: str) -> dict:
    """One variant's success, rescue record, and failure phases (its own, and the baseline's it rescued)."""
    by_seed = {e["seed"]: e for e in run["per_episode"]}
    base_failures = [e for e in baseline["per_episode"] if e["seed"] in by_seed and failure_phase(e)]
    rescued_by_phase = Counter(
        failure_phase(e) for e in base_failures if by_seed[e["seed"]]["subtasks"][milestone]
    )
    return {
        "success_pc": 100.0
        * sum(e["subtasks"][milestone] for e in run["per_episode"])
        / len(run["per_episode"]),
        "episodes": len(run["per_episode"]),
        "recovery": run.get("recovery", {}).get("settings"),
        "episodes_with_recovery": run.get("recovery", {}).get("episodes_with_recovery"),
        "rescue": rescue_record(baseline, run, milestone) if "recovery" in run else None,
        "failure_phases": dict(Counter(p for e in run["per_episode"] if (p := failure_phase(e)))),
        "baseline_failure_phases": dict(Counter(failure_phase(e) for e in base_failures)),
        "rescued_by_phase": dict(rescued_by_phase),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("baseline", type=Path, help="the run without recovery")
    parser.add_argument("variants", type=Path, nargs="+", help="runs with a recovery variant, same scenes")
    parser.add_argument("--json", type=Path, help="also write the rows here")
    args = parser.parse_args()
    baseline = load_run(args.baseline)
    milestone = list(baseline["per_episode"][0]["subtasks"])[-1]
    rows = {"baseline": str(args.baseline), "milestone": milestone, "variants": {}}
    print(
        f"{'variant':<24} {'success':>7} {'rescued':>7} {'lost':>4} {'rate':>6} {'p':>6}  failures by phase"
    )
    for folder in args.variants:
        row = variant_row(baseline, load_run(folder), milestone)
        rows["variants"][folder.name] = row
        r = row["rescue"]
        rate = f"{r['rescue_rate']:.2f}" if r and r["rescue_rate"] is not None else "-"
        print(
            f"{folder.name:<24} {row['success_pc']:7.1f} {r['rescued'] if r else '-':>7} "
            f"{r['lost'] if r else '-':>4} {rate:>6} {r['mcnemar_exact_p'] if r else float('nan'):6.3f}  "
            f"{row['failure_phases']} "
            f"(rescued of the baseline's {row['baseline_failure_phases']}: {row['rescued_by_phase']})"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
