"""Step a trained vmc / bvmc checkpoint through one scene in closed loop, next to the scripted expert.

Every `--every` steps it prints where the gripper and the object are, what the policy predicts for them
(its auxiliary heads, in metres), the action the policy executes and the action the expert would take from
the same state (the expert plans along the policy's own trajectory, so read its action as a hint, not an
exact label). This is how the stalled grasp hand-off described in the README was found.

    python -m diagnostics.policy_trace \\
        --policy-path outputs/train/bvmc/checkpoints/012500/pretrained_model --seed 1 --split val
"""

import argparse

import numpy as np
import torch
from lerobot.envs.utils import preprocess_observation

from diagnostics.checkpoint import InspectedPolicy
from lerobot_ivmc.envs import TASKS, make_task_env
from lerobot_ivmc.envs.scenes import SPLITS
from lerobot_ivmc.experts import make_expert
from lerobot_ivmc.policies.vmc.gripper import deterministic_action


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--policy-path", required=True)
    parser.add_argument("--task", default="pick_place", choices=TASKS)
    parser.add_argument("--split", default="val", choices=SPLITS)
    parser.add_argument("--seed", type=int, default=0, help="scene seed")
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--every", type=int, default=4, help="print every this many steps")
    args = parser.parse_args()
    torch.set_num_threads(1)

    inspected = InspectedPolicy(args.policy_path)
    policy = inspected.policy
    image_size = policy.config.image_features[policy.image_key].shape[-1]
    env = make_task_env(args.task, image_size=image_size, split=args.split)
    expert = make_expert(env)
    observation, info = env.reset(seed=args.seed)
    expert.reset()
    policy.reset()
    np.set_printoptions(precision=3, suppress=True)
    for t in range(args.steps):
        batched = {
            "pixels": {name: frame[None] for name, frame in observation["pixels"].items()},
            "agent_pos": observation["agent_pos"][None],
            "environment_state": observation["environment_state"][None],
        }
        batch = inspected.preprocessor(preprocess_observation(batched))
        with torch.no_grad():
            delta_ee, logits, ee, obj = policy.net.decode(policy.step_embedding(batch), stochastic=False)
        action = deterministic_action(delta_ee, logits, policy.config.gripper)[0].numpy()
        predicted = inspected.auxiliary_positions(ee, obj)
        expert_action = expert.act()
        if t % args.every == 0:
            print(
                f"{t:3d} grip {env.grip_position} (pred {predicted[:3]})  object {env.object_position} "
                f"(pred {predicted[3:]})  policy {action}  expert {expert_action}"
            )
        observation, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    print(f"after {t + 1} steps: {info['subtasks']}, success {bool(info['is_success'])}")
    env.close()


if __name__ == "__main__":
    main()
