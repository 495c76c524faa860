"""Open-loop diagnostics of a trained vmc / bvmc checkpoint on recorded demos.

Replays demo episodes frame by frame through the policy (LSTM memory as at rollout, dropout off) and prints
how far its outputs are from the expert's: the delta end-effector command (mean absolute error, in action
units of 5 cm), the gripper command (accuracy), and the auxiliary end-effector and object positions (mean
absolute error per axis, in cm, after undoing the normalisation).

    python -m diagnostics.policy_diagnostics \\
        --policy-path outputs/train/bvmc/checkpoints/005000/pretrained_model \\
        --dataset-root data/ivmc_pick_place --repo-id local/ivmc_pick_place --episodes 20
"""

import argparse

import numpy as np
import torch
from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from diagnostics.checkpoint import InspectedPolicy
from lerobot_ivmc.datasets.features import IMAGE_KEY
from lerobot_ivmc.policies.vmc.gripper import LEVEL_TOLERANCE, ContinuousGripper


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--policy-path", required=True)
    parser.add_argument("--dataset-root", required=True)
    parser.add_argument("--repo-id", required=True)
    parser.add_argument("--episodes", type=int, default=20, help="episodes, spread over the dataset")
    args = parser.parse_args()
    torch.set_num_threads(1)

    inspected = InspectedPolicy(args.policy_path)
    policy, preprocessor = inspected.policy, inspected.preprocessor
    dataset = LeRobotDataset(args.repo_id, root=args.dataset_root)

    delta_errors, gripper_hits, aux_errors = [], [], []
    starts = dataset.meta.episodes["dataset_from_index"]
    ends = dataset.meta.episodes["dataset_to_index"]
    for episode in np.linspace(0, dataset.num_episodes - 1, args.episodes).astype(int):
        policy.reset()
        for index in range(starts[episode], ends[episode]):
            item = dataset[index]
            batch = preprocessor({IMAGE_KEY: item[IMAGE_KEY][None], OBS_STATE: item[OBS_STATE][None]})
            with torch.no_grad():
                embedding = policy.step_embedding(batch)
                delta_ee, logits, ee, obj = policy.net.decode(embedding, stochastic=False)
            expert = item[ACTION].numpy()
            delta_errors.append(np.abs(delta_ee[0].numpy() - expert[:3]))
            # The command the head learned for the expert's: the same class, or a continuous one within
            # the level tolerance.
            gripper = policy.config.gripper
            learned = float(gripper.learned(torch.as_tensor(expert[3:]))[0])
            executed = float(gripper.command(logits)[0])
            tolerance = LEVEL_TOLERANCE if isinstance(gripper, ContinuousGripper) else 0.0
            gripper_hits.append(abs(executed - learned) <= tolerance)
            predicted_aux = inspected.auxiliary_positions(ee, obj)
            aux_errors.append(np.abs(predicted_aux - item[OBS_ENV_STATE].numpy()))
    delta_errors, aux_errors = np.array(delta_errors), np.array(aux_errors) * 100
    print(f"{args.policy_path}: {args.episodes} episodes, {len(gripper_hits)} frames of {args.repo_id}")
    print(f"  delta EE mean abs error (action units, x y z): {np.round(delta_errors.mean(0), 3)}")
    print(f"  gripper command accuracy: {np.mean(gripper_hits):.1%}")
    print(f"  end-effector position mean abs error (cm, x y z): {np.round(aux_errors[:, :3].mean(0), 2)}")
    print(f"  object position mean abs error (cm, x y z): {np.round(aux_errors[:, 3:].mean(0), 2)}")


if __name__ == "__main__":
    main()
