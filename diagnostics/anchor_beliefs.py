"""How well does the policy know, when its trigger fires, where the object and the goal are?

Reads `lerobot-ivmc-inspect` records (a bvmc trained with the goal head, one scene each, no recovery) and,
per episode, finds the step at which the recovery trigger would fire (the 20-step window sum of the
uncertainty first above `--threshold`). At that step it measures, in the table plane (cm): the object
head's error, and the error of the goal belief anchored in several ways (the belief at the least uncertain
step so far, the mean over the 10 and 30 least uncertain steps, over the first 10 steps, the median so far,
the belief at the trigger, at the grasp). It prints, over the failed episodes the trigger flags and over
all, each anchor's median error and the share within the target's radius (3 cm) and within 2 cm.

    for s in $(seq 0 59); do lerobot-ivmc-inspect --policy.path=<bvmc> --env.type=ivmc \\
        --env.task=pick_place --env.split=val --env.render_style=fast --episode_seed=$s --seed=0 \\
        --output_dir=<records>; done
    python -m diagnostics.anchor_beliefs <records> --threshold=2.39 [--json anchor_beliefs.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

WINDOW = 20
TARGET_RADIUS_CM = 3.0


def anchors_at_trigger(record: dict, threshold: float) -> dict:
    """One episode: whether the trigger fires, and the errors (cm) of the beliefs at its step."""
    steps = record["per_step"]
    u = np.asarray(steps["uncertainty"], dtype=float)
    goals = np.asarray(steps["believed_goal"], dtype=float)
    objects = np.asarray(steps["believed_object"], dtype=float)
    true_object = np.asarray(steps["object"], dtype=float)
    target = np.asarray(steps["target"][0], dtype=float)
    grasped = np.asarray(steps["grasped"], dtype=bool)
    window_sums = np.convolve(u, np.ones(WINDOW))[: len(u)]
    fired = np.flatnonzero(window_sums > threshold)
    t = int(fired[0]) if len(fired) else min(100, len(u) - 1)
    order = np.argsort(u[: t + 1], kind="stable")
    anchors = {
        "least_uncertain_step": goals[order[0]],
        "mean_10_least_uncertain": goals[order[:10]].mean(axis=0),
        "mean_30_least_uncertain": goals[order[:30]].mean(axis=0),
        "mean_first_10": goals[:10].mean(axis=0),
        "median_so_far": np.median(goals[: t + 1], axis=0),
        "at_trigger": goals[t],
    }
    grasp_steps = np.flatnonzero(grasped[: t + 1])
    if len(grasp_steps):
        anchors["at_grasp"] = goals[grasp_steps[0]]
    return {
        "seed": record["episode_seed"],
        "success": bool(record["success"]),
        "flagged": bool(len(fired)),
        "step": t,
        "holding_at_step": bool(grasped[t]),
        "object_error_cm": float(100 * np.linalg.norm(objects[t, :2] - true_object[t, :2])),
        "goal_error_cm": {k: float(100 * np.linalg.norm(v[:2] - target[:2])) for k, v in anchors.items()},
    }


def summarise(episodes: list[dict]) -> dict:
    """Per anchor: n, median error, shares within the target radius and within 2 cm."""
    names = {name for e in episodes for name in e["goal_error_cm"]}
    out = {}
    for name in sorted(names):
        errors = np.array([e["goal_error_cm"][name] for e in episodes if name in e["goal_error_cm"]])
        out[name] = {
            "n": len(errors),
            "median_cm": float(np.median(errors)),
            "within_radius": float(np.mean(errors < TARGET_RADIUS_CM)),
            "within_2cm": float(np.mean(errors < 2.0)),
        }
    objects = np.array([e["object_error_cm"] for e in episodes])
    out["object_at_trigger"] = {"n": len(objects), "median_cm": float(np.median(objects))}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "records", type=Path, help="folder of lerobot-ivmc-inspect records (inspect_seed*.json)"
    )
    parser.add_argument("--threshold", type=float, required=True, help="C, the 20-step window-sum threshold")
    parser.add_argument("--json", type=Path, help="also write the per-episode values and summaries here")
    args = parser.parse_args()
    paths = sorted(args.records.glob("inspect_seed*.json"))
    if not paths:
        parser.error(f"no inspect_seed*.json in {args.records}: run lerobot-ivmc-inspect first.")
    episodes = [anchors_at_trigger(json.loads(p.read_text()), args.threshold) for p in paths]
    groups = {
        "failed_and_flagged": summarise([e for e in episodes if not e["success"] and e["flagged"]]),
        "all": summarise(episodes),
    }
    for group, rows in groups.items():
        print(f"{group}:")
        for name, row in rows.items():
            extra = ""
            if "within_radius" in row:
                extra = f", within {TARGET_RADIUS_CM:.0f} cm {row['within_radius']:.2f}"
                extra += f", within 2 cm {row['within_2cm']:.2f}"
            print(f"  {name:<26} n={row['n']:3d} median {row['median_cm']:.2f} cm{extra}")
    if args.json:
        args.json.write_text(
            json.dumps({"threshold": args.threshold, "summary": groups, "episodes": episodes}, indent=1)
        )


if __name__ == "__main__":
    main()
