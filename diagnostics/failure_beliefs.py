"""What did a policy believe when its episode ended? Medians over `lerobot-ivmc-inspect` records.

`lerobot-ivmc-inspect` reruns one eval scene with the policy alone and records per step the true grip,
object and target positions next to what the network believes (its auxiliary object estimate and, with the
goal head, where it believes the object must end up). This script reads such records, e.g. of the test
scenes a BVMC failed in `lerobot-ivmc-eval`, and prints, at each episode's last step, in the table plane
(x, y; cm): how far the object is from the target, how far the believed object is from the true one, how
far the believed goal is from the believed object and from the target, and the mean |delta-EE action|
(action units, gripper excluded) over the last 20 steps; with the goal head, for episodes that grasped
the object, also the believed goal's error at the start, the grasp and the release. A policy that idles
with its believed goal on its believed object, while the true object is elsewhere, believes the task done
(docs/archive/RESULTS_superseded.md, "push: the failures are beliefs, and init's fresh start clears them").

    for s in 0 3 4; do lerobot-ivmc-inspect --policy.path=<bvmc> --env.type=ivmc --env.task=push \\
        --env.split=test --env.episode_length=200 --episode_seed=$s --output_dir=<out>; done
    python -m diagnostics.failure_beliefs <out> [--json beliefs.json]
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
        row.update(carry_beliefs(steps, cm))
    return row


def carry_beliefs(steps: dict, cm) -> dict:
    """For an episode that grasped the object: the believed goal's error at the start, the grasp and the
    release (the first step after the grasp without it; the last step if never released), and the object's
    distance from the target at the release (cm, table plane). Empty without a grasp."""
    grasped = np.asarray(steps.get("grasped", []), dtype=bool)
    if not grasped.any():
        return {}
    grasp = int(np.argmax(grasped))
    dropped = np.flatnonzero(~grasped[grasp:])
    release = grasp + int(dropped[0]) if dropped.size else len(grasped) - 1

    def at(key: str, t: int) -> np.ndarray:
        return np.asarray(steps[key][t], dtype=float)[PLANE]

    return {
        "grasp_step": grasp,
        "release_step": release if dropped.size else None,
        "believed_goal_to_target_at_start_cm": cm(at("believed_goal", 0), at("target", 0)),
        "believed_goal_to_target_at_grasp_cm": cm(at("believed_goal", grasp), at("target", grasp)),
        "believed_goal_to_target_at_release_cm": cm(at("believed_goal", release), at("target", release)),
        "object_to_target_at_release_cm": cm(at("object", release), at("target", release)),
        "believed_goal_to_object_at_release_cm": cm(at("believed_goal", release), at("object", release)),
    }


def summarise(rows: list[dict]) -> dict:
    """Medians over the episodes that fail again when rerun alone."""
    failures = [r for r in rows if not r["success_alone"]]
    successes = [r for r in rows if r["success_alone"]]
    return {
        "failures": len(failures),
        "median_over_failures": medians(failures),
        "median_over_successes": medians(successes),
        "episodes": rows,
    }


def medians(rows: list[dict]) -> dict:
    """Median of every distance and action figure over the rows that have it."""
    keys = dict.fromkeys(k for r in rows for k in r if k.endswith(("_cm", "_units")))
    return {k: round(float(np.median([r[k] for r in rows if k in r])), 2) for k in keys}


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
    print(
        f"medians over the {len(rows) - summary['failures']} that succeed: {summary['median_over_successes']}"
    )
    if args.json:
        if args.json.exists():
            parser.error(f"{args.json} exists: give another --json path (results are never overwritten).")
        args.json.write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
