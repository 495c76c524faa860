"""What did a policy believe when its episode ended? Medians over `lerobot-ivmc-inspect` records.

`lerobot-ivmc-inspect` reruns one eval scene with the policy alone and records per step the true grip,
object and target positions next to what the network believes (its auxiliary object estimate and, with the
goal head, where it believes the object must end up). This script reads such records, e.g. of the test
scenes a BVMC failed in `lerobot-ivmc-eval`, and prints, at each episode's last step, in the table plane
(x, y; cm): how far the object is from the target, how far the believed object is from the true one, how
far the believed goal is from the believed object and from the target, and the mean |delta-EE action|
(action units, gripper excluded) over the last 20 steps. A policy that idles with its believed goal on its
believed object, while the true object is elsewhere, believes the task done (docs/RESULTS.md, push).

    for s in 0 3 4; do lerobot-ivmc-inspect --policy.path=<bvmc> --env.type=ivmc --env.task=push \\
        --env.split=test --env.episode_length=200 --episode_seed=$s --output_dir=<out>; done
    python benchmarks/failure_beliefs.py <out> [--json beliefs.json]
"""

import argparse
import json
from pathlib import Path

import numpy as np

PLANE = slice(0, 2)
LAST_STEPS = 20


def final_beliefs(record: dict) -> dict:
    """The last step's distances (cm, table plane) and the recent mean |action| of one inspected episode."""
    steps = record["per_step"]

    def last(key: str) -> np.ndarray:
        return np.asarray(steps[key][-1], dtype=float)[PLANE]

    def cm(a: np.ndarray, b: np.ndarray) -> float:
        return round(float(np.linalg.norm(a - b)) * 100, 2)

    actions = np.abs(np.asarray(steps["action"][-LAST_STEPS:], dtype=float)[:, :3])
    row = {
        "episode_seed": record["episode_seed"],
        "success_alone": record["success"],
        "steps": record["steps"],
        "object_to_target_cm": cm(last("object"), last("target")),
        "believed_object_error_cm": cm(last("believed_object"), last("object")),
        f"mean_abs_action_last_{LAST_STEPS}_steps_units": round(float(actions.mean()), 4),
    }
    if "believed_goal" in steps:
        row["believed_goal_to_believed_object_cm"] = cm(last("believed_goal"), last("believed_object"))
        row["believed_goal_to_target_cm"] = cm(last("believed_goal"), last("target"))
    return row


def summarise(rows: list[dict]) -> dict:
    """Medians over the episodes that fail again when rerun alone."""
    failures = [r for r in rows if not r["success_alone"]]
    keys = [k for k in rows[0] if k.endswith(("_cm", "_units"))] if rows else []
    return {
        "failures": len(failures),
        "median_over_failures": {k: round(float(np.median([r[k] for r in failures])), 2) for k in keys}
        if failures
        else {},
        "episodes": rows,
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("folders", nargs="+", type=Path, help="folders holding inspect_seed*.json records")
    parser.add_argument("--json", type=Path, help="also write the summary here (never overwritten)")
    args = parser.parse_args()
    paths = sorted(p for folder in args.folders for p in folder.glob("inspect_seed*.json"))
    if not paths:
        parser.error(
            f"no inspect_seed*.json in {[str(f) for f in args.folders]}: run lerobot-ivmc-inspect first."
        )
    rows = [final_beliefs(json.loads(p.read_text())) for p in paths]
    summary = summarise(rows)
    for row in rows:
        print(row)
    print(f"{summary['failures']} of {len(rows)} fail alone; medians: {summary['median_over_failures']}")
    if args.json:
        if args.json.exists():
            parser.error(f"{args.json} exists: give another --json path (results are never overwritten).")
        args.json.write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
