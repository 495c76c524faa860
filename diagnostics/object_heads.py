"""Where do a policy's two object heads place the object on its failures: at the trigger, and after anchor's
look from the start pose?

A policy trained with the frame position head has two estimates of the object's position: the object head
on the LSTM's state (the memory) and the frame position head, which reads one frame's CNN map alone. Per
scene (single env, validation split), the script runs the BVMC without recovery and, for a failed
episode the trigger flags (the window sum of the uncertainty above the checkpoint's threshold), measures
each head's error in the table plane (cm) at the trigger; then runs the same scene with anchor and
`--look-steps` (the look does not depend on either head) and measures both errors at the look's last step.
It prints per scene and the medians, and how many fall within 3 cm (the target's radius). Analysis only:
the truth is read from the simulator beside the policy, never by it.

    python -m diagnostics.object_heads --policy-path <out>/threshold/fc1_seed2000/pretrained_model \\
        --task push --seeds 0,1,2,6,8 --look-steps 6
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch
from lerobot.configs import parser
from lerobot.utils.constants import OBS_STATE

from lerobot_ivmc.envs import make_task_env, task_env_class
from lerobot_ivmc.envs.fetch_env import EMBODIMENT as FETCH_EMBODIMENT
from lerobot_ivmc.evaluation.beliefs import BeliefReader
from lerobot_ivmc.evaluation.eval_subtasks import feature_stats
from lerobot_ivmc.evaluation.inspect_episode import InspectConfig
from lerobot_ivmc.evaluation.loading import LoadedPolicy, load_policy
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.controller import IntrospectiveController
from lerobot_ivmc.recovery.foresight_ranking import batch_observations
from lerobot_ivmc.recovery.manoeuvres import LOOK
from lerobot_ivmc.recovery.strategies.belief_anchor import OBJECT_POSITION
from lerobot_ivmc.recovery.strategy_settings import AnchorSettings

WINDOW = 20
STEPS = 200
RADIUS_CM = 3.0


def load(policy_path: str, task: str) -> LoadedPolicy:
    """The checkpoint as `lerobot-ivmc-inspect` loads it (LeRobot's config parser reads `--policy.path`)."""
    captured = {}

    # (`parser.wrap` reads the annotation at run time: no `from __future__ import annotations` here)
    @parser.wrap()
    def grab(cfg: InspectConfig) -> None:
        captured["cfg"] = cfg

    argv, sys.argv = (
        sys.argv,
        [
            sys.argv[0],
            f"--policy.path={policy_path}",
            "--env.type=ivmc",
            f"--env.task={task}",
            "--env.render_style=fast",
            "--output_dir=/tmp/object_heads",
        ],
    )
    try:
        grab()
    finally:
        sys.argv = argv
    return load_policy(captured["cfg"])


def errors_cm(believed: np.ndarray, truth: np.ndarray) -> float:
    return float(100 * np.linalg.norm(np.asarray(believed)[:2] - np.asarray(truth)[:2]))


def run_scene(
    loaded: LoadedPolicy, task: str, seed: int, threshold: float, look_steps: int | None
) -> dict | None:
    """One scene without recovery (look_steps None) or with anchor's look; the heads' errors (cm) at the
    trigger or at the look's last step, None if the episode never gets there."""
    reader = BeliefReader(loaded)  # its statistics map the frame head's reading to metres
    env_class = task_env_class(task)
    # anchor's controller keeps the memory head's belief each step; without recovery it never fires.
    recovery = RecoveryConfig(
        mode="anchor", anchor=AnchorSettings(look_steps=look_steps or 0, object="memory")
    )
    recovery = recovery.for_task(
        env_class.object_picked, env_class.object_held_at_end, env_class.object_shape.rest_height
    )
    controller = IntrospectiveController(
        loaded.policy,
        recovery,
        threshold if look_steps is not None else float("inf"),
        WINDOW,
        (reader.mean, reader.std),
        seed=0,
        state_stats=feature_stats(loaded.preprocessor, OBS_STATE),
        embodiment=FETCH_EMBODIMENT,
    )
    env = make_task_env(task, image_size=64, split="val", render_style="fast")
    torch.manual_seed(0)
    observation, _ = env.reset(seed=seed)
    controller.reset()
    uncertainties, found, previous, info, errors = [], None, 0, {}, {}
    for step in range(STEPS):
        action = controller.select_action(loaded.to_policy_batch(batch_observations([observation])))[0]
        phase = int(controller.traces[-1].phase[-1][0])
        uncertainties.append(float(controller.traces[-1].uncertainty[-1][0]))
        truth = env.object_position.copy()
        if found is None and look_steps is None and sum(uncertainties[-WINDOW:]) > threshold:
            found = step
        if found is None and look_steps is not None and previous == LOOK and phase != LOOK:
            found = step
        if found == step:
            frame_head = reader.to_world(loaded.policy.frame_positions[:, OBJECT_POSITION], OBJECT_POSITION)
            memory_head = controller.strategy.object_beliefs[0]
            errors = {"memory_cm": errors_cm(memory_head, truth), "frame_cm": errors_cm(frame_head, truth)}
        previous = phase
        observation, _, terminated, _, info = env.step(action.numpy())
        if terminated:
            break
    env.close()
    if found is None:
        return None
    return {"seed": seed, "step": found, "success": bool(info.get("is_success", False)), **errors}


def summary(rows: list[dict]) -> str:
    memory = np.array([r["memory_cm"] for r in rows])
    frame = np.array([r["frame_cm"] for r in rows])
    return (
        f"memory head median {np.median(memory):.1f} cm ({int((memory < RADIUS_CM).sum())} within 3 cm), "
        f"frame head {np.median(frame):.1f} cm ({int((frame < RADIUS_CM).sum())}), of {len(rows)}"
    )


def main() -> None:
    arg_parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    arg_parser.add_argument("--policy-path", required=True, help="a bvmc threshold checkpoint (frame head)")
    arg_parser.add_argument("--task", default="push")
    arg_parser.add_argument("--seeds", required=True, help="validation scene seeds, comma-separated")
    arg_parser.add_argument("--look-steps", type=int, default=6)
    arg_parser.add_argument("--json", type=Path, help="also write the per-scene rows here")
    args = arg_parser.parse_args()
    torch.set_num_threads(1)
    loaded = load(args.policy_path, args.task)
    if loaded.policy.net.frame_position_decoder is None:
        raise SystemExit("This policy has no frame position head: pass one trained with it.")
    threshold = json.loads((Path(args.policy_path) / "recovery_threshold.json").read_text())["threshold"]
    at_trigger, after_look = [], []
    for seed in (int(s) for s in args.seeds.split(",")):
        alone = run_scene(loaded, args.task, seed, threshold, None)
        if alone is None or alone["success"]:
            continue  # a success, or a failure the trigger never flags
        at_trigger.append(alone)
        looked = run_scene(loaded, args.task, seed, threshold, args.look_steps)
        if looked is not None:
            after_look.append(looked)
        shown = f"{looked['memory_cm']:5.1f} / {looked['frame_cm']:5.1f}" if looked else "  -"
        print(
            f"scene {seed:3d}: trigger at step {alone['step']:3d}, memory / frame head "
            f"{alone['memory_cm']:5.1f} / {alone['frame_cm']:5.1f} cm; after the look {shown} cm"
        )
    print(f"at the trigger: {summary(at_trigger)}")
    print(f"after a {args.look_steps}-step look: {summary(after_look)}")
    if args.json:
        args.json.write_text(json.dumps({"at_trigger": at_trigger, "after_look": after_look}, indent=1))


if __name__ == "__main__":
    main()
