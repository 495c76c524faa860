"""Does a policy's memory drift over a 200-step rollout? Its auxiliary estimates, step bucket by step bucket.

Demos last 100 steps; an evaluation episode lasts up to 200. A carried LSTM memory (sequence training) that
drifts past the demo length shows as estimates of what the camera plainly sees, the gripper and the object
positions, going wrong late in the episode. Each checkpoint acts in closed loop on the same validation
scenes for the full 200 steps (no early end on success), and the mean error of its auxiliary estimates is
printed per 25-step bucket, with the share of rollouts that have succeeded by then. Several checkpoints
side by side (e.g. a sequence-trained one with carried memory and a window-trained one) run on the same
scenes.

    python -m diagnostics.memory_drift --episodes 20 \\
        --policy-path <sequence run>/checkpoints/last/pretrained_model \\
        --policy-path <window run>/checkpoints/last/pretrained_model
"""

import argparse

import numpy as np
import torch
from lerobot.envs.utils import preprocess_observation

from diagnostics.checkpoint import InspectedPolicy
from lerobot_ivmc.envs import MAX_EPISODE_STEPS, TASKS, make_task_env
from lerobot_ivmc.envs.scenes import SPLITS
from lerobot_ivmc.policies.vmc.gripper import deterministic_action

BUCKET = 25


def rollout_errors(
    inspected: InspectedPolicy, task: str, split: str, seeds: list[int]
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-loop rollouts of one checkpoint, one env per seed, batched through the policy.

    Returns:
        (E, T, 2) absolute errors in cm of the EE and object estimates, and (E, T) bool: succeeded by step t.
    """
    policy = inspected.policy
    image_size = policy.config.image_features[policy.image_key].shape[-1]
    envs = [
        make_task_env(task, image_size=image_size, split=split, terminate_on_success=False) for _ in seeds
    ]
    observations = [env.reset(seed=seed)[0] for env, seed in zip(envs, seeds, strict=True)]
    policy.reset()
    errors = np.zeros((len(envs), MAX_EPISODE_STEPS, 2))
    succeeded = np.zeros((len(envs), MAX_EPISODE_STEPS), dtype=bool)
    for t in range(MAX_EPISODE_STEPS):
        batched = {
            "pixels": {
                name: np.stack([o["pixels"][name] for o in observations])
                for name in observations[0]["pixels"]
            },
            "agent_pos": np.stack([o["agent_pos"] for o in observations]),
            "environment_state": np.stack([o["environment_state"] for o in observations]),
        }
        batch = inspected.preprocessor(preprocess_observation(batched))
        with torch.no_grad():
            delta_ee, logits, ee, obj = policy.net.decode(policy.step_embedding(batch), stochastic=False)
        actions = deterministic_action(delta_ee, logits, policy.config.gripper).numpy()
        for i, env in enumerate(envs):
            predicted = inspected.auxiliary_positions(ee[i : i + 1], obj[i : i + 1])
            errors[i, t, 0] = np.linalg.norm(predicted[:3] - env.grip_position) * 100
            errors[i, t, 1] = np.linalg.norm(predicted[3:] - env.object_position) * 100
            observations[i], _, _, _, info = env.step(actions[i])
            succeeded[i, t] = info["is_success"]  # the env keeps a milestone once reached
    for env in envs:
        env.close()
    return errors, succeeded


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--policy-path", action="append", required=True, help="repeat to compare")
    parser.add_argument("--task", default="pick_place", choices=TASKS)
    parser.add_argument("--split", default="val", choices=SPLITS)
    parser.add_argument("--episodes", type=int, default=20, help="scenes: seeds 0..episodes-1")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    seeds = list(range(args.episodes))
    for path in args.policy_path:
        inspected = InspectedPolicy(path)
        errors, succeeded = rollout_errors(inspected, args.task, args.split, seeds)
        memory = inspected.policy.config.rollout_memory
        print(f"\n{path} (rollout memory: {memory}), {args.task} {args.split} scenes 0..{seeds[-1]}")
        print("  steps      EE error cm (mean, p90)   object error cm (mean, p90)   succeeded by then")
        for start in range(0, MAX_EPISODE_STEPS, BUCKET):
            window = errors[:, start : start + BUCKET]
            ee, obj = window[..., 0].ravel(), window[..., 1].ravel()
            print(
                f"  {start:3d}-{start + BUCKET - 1:3d}   {ee.mean():6.2f} {np.percentile(ee, 90):6.2f}"
                f"                {obj.mean():6.2f} {np.percentile(obj, 90):6.2f}"
                f"                 {succeeded[:, start + BUCKET - 1].mean() * 100:5.1f}%"
            )
        first, second = errors[:, :100].mean(axis=(0, 1)), errors[:, 100:].mean(axis=(0, 1))
        print(
            f"  steps 100-199 / 0-99: EE error x{second[0] / first[0]:.2f}, object error "
            f"x{second[1] / first[1]:.2f}"
        )


if __name__ == "__main__":
    main()
