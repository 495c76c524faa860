"""Where does a bvmc believe the goal: by the goal head on its memory, or by its frame position head?

Runs `lerobot-ivmc-eval` in anchor mode with a threshold that never fires (the rollouts are BVMC's own) and
records, per step and rollout, the goal each head believes. Per episode it anchors each head's goal as
anchor does (the mean over the 30 least uncertain steps up to `--step`, about when the trigger fires) and
measures, in the table plane, its distance from the goal head's label: where the object is at the end of
the scripted demo of the same scene. It prints, over the failures and the successes, the median error and
the share within the target's 3 cm radius. This is how anchor's goal for pick_reach came to be read from
the frame head (docs/archive/RESULTS_studies.md, "pick_reach: the frame head").

    python -m diagnostics.goal_beliefs --policy.path=<bvmc> --env.type=ivmc --env.task=pick_reach \\
        --env.episode_length=200 --env.render_style=fast --env.split=val --eval.n_episodes=100 \\
        --eval.batch_size=10 --seed=0 --recovery.mode=anchor --recovery.threshold=1e9 \\
        --recovery.max_videos=0 --output_dir=<new folder> [--json=<file>]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from lerobot_ivmc.experts import demo_end_object
from lerobot_ivmc.recovery.strategies import belief_anchor
from lerobot_ivmc.recovery.strategy_settings import ANCHOR_GOAL_STEPS
from lerobot_ivmc.scripts.lerobot_ivmc_eval import eval_main

GOAL_POSITION = belief_anchor.GOAL_POSITION
TARGET_RADIUS_CM = 3.0


def record_goal_beliefs() -> dict[str, list]:
    """Patch the controller to keep, per step, each head's believed goal (B, 3), the uncertainty (B,) and
    the batch under way; returns the lists it fills."""
    store: dict[str, list] = {"batch": [], "memory": [], "frame": [], "uncertainty": []}
    update = belief_anchor.AnchorRecovery.observe

    def recording(self, ctx, prediction, uncertainty, normal):
        update(self, ctx, prediction, uncertainty, normal)
        outputs = ctx.policy.net.decode(prediction.embedding, stochastic=False, with_goal=True)
        mean, std = ctx.env_state_mean[3:], ctx.env_state_std[3:]
        store["memory"].append((outputs[4].float().cpu() * std + mean).numpy())
        frame = ctx.policy.frame_positions[:, GOAL_POSITION]
        store["frame"].append((frame.float().cpu() * std + mean).numpy())
        store["uncertainty"].append(np.asarray(uncertainty).copy())
        store["batch"].append(len(ctx.traces) - 1)

    belief_anchor.AnchorRecovery.observe = recording
    return store


def anchored_errors(store: dict, info: dict, step: int, batch_size: int, steps: int) -> list[dict]:
    """Per episode: success and each head's anchored goal error (cm) against the demo's end."""
    batches = np.asarray(store["batch"])
    run = info["run"]
    episodes = []
    for episode in info["per_episode"]:
        batch, row = divmod(episode["episode_ix"], batch_size)
        at = batches == batch
        u = np.stack(store["uncertainty"])[at][:, row]
        last = min(step, len(u) - 1)
        least = np.argsort(u[: last + 1], kind="stable")[:ANCHOR_GOAL_STEPS]
        label = demo_end_object(run["task"], episode["seed"], run["split"], steps)
        errors = {}
        for head in ("memory", "frame"):
            goal = np.stack(store[head])[at][:, row][least].mean(axis=0)
            errors[head] = float(100 * np.linalg.norm(goal[:2] - label[:2]))
        episodes.append({"seed": episode["seed"], "success": bool(episode["success"]), "error_cm": errors})
    return episodes


def summary(episodes: list[dict]) -> dict:
    """Per head: n, median error (cm), share within the target's radius."""
    out = {}
    for head in ("memory", "frame"):
        errors = np.array([e["error_cm"][head] for e in episodes])
        out[head] = {
            "n": len(errors),
            "median_cm": float(np.median(errors)) if len(errors) else float("nan"),
            "within_radius": float(np.mean(errors < TARGET_RADIUS_CM)) if len(errors) else float("nan"),
        }
    return out


def main() -> None:
    args = sys.argv[1:]
    json_path = next((Path(a.split("=", 1)[1]) for a in args if a.startswith("--json=")), None)
    step = int(next((a.split("=", 1)[1] for a in args if a.startswith("--step=")), 70))
    sys.argv = [sys.argv[0], *(a for a in args if not a.startswith(("--json=", "--step=")))]
    store = record_goal_beliefs()
    info = eval_main()
    batch_size = int(next(a.split("=", 1)[1] for a in args if a.startswith("--eval.batch_size=")))
    episode_steps = int(next(a.split("=", 1)[1] for a in args if a.startswith("--env.episode_length=")))
    episodes = anchored_errors(store, info, step, batch_size, episode_steps)
    groups = {
        "failures": summary([e for e in episodes if not e["success"]]),
        "successes": summary([e for e in episodes if e["success"]]),
    }
    for group, heads in groups.items():
        for head, row in heads.items():
            print(
                f"{group:<9} {head:<6} n={row['n']:3d} median {row['median_cm']:.2f} cm, "
                f"within {TARGET_RADIUS_CM:.0f} cm {row['within_radius']:.2f}"
            )
    if json_path:
        json_path.write_text(json.dumps({"step": step, "summary": groups, "episodes": episodes}, indent=1))


if __name__ == "__main__":
    main()
