"""Helpers for the policy tests: synthetic configs and batches, and a tiny expert dataset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from lerobot_ivmc.policies import BVMCConfig, VMCConfig
from lerobot_ivmc.recovery.threshold import ThresholdRecord

IMAGE_KEY = "observation.images.front"
IMAGE_SIZE = 64
STATE_DIM = 9
TINY_REPO_ID = "local/ivmc_pick_place_tiny"


def policy_features() -> tuple[dict[str, PolicyFeature], dict[str, PolicyFeature]]:
    """Input and output features as LeRobot derives them from the demo dataset."""
    inputs = {
        IMAGE_KEY: PolicyFeature(type=FeatureType.VISUAL, shape=(3, IMAGE_SIZE, IMAGE_SIZE)),
        OBS_STATE: PolicyFeature(type=FeatureType.STATE, shape=(STATE_DIM,)),
        OBS_ENV_STATE: PolicyFeature(type=FeatureType.ENV, shape=(6,)),
    }
    return inputs, {ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(4,))}


def make_config(cls: type[VMCConfig] = BVMCConfig, **kwargs) -> VMCConfig:
    """A config of `cls` on CPU with the demo dataset's features: the paper's network (no goal or frame
    position head) in window training (the K-frame batches of `make_batch`) unless the kwargs say else."""
    inputs, outputs = policy_features()
    kwargs = {"training_mode": "window", "goal_head": False, "frame_position_head": False, **kwargs}
    return cls(device="cpu", input_features=inputs, output_features=outputs, **kwargs)


def make_batch(batch_size: int = 4, k: int | None = 4, seed: int = 0) -> dict[str, torch.Tensor]:
    """A training batch of K-frame windows (or single frames when k is None), as after preprocessing."""
    g = torch.Generator().manual_seed(seed)
    lead = (batch_size,) if k is None else (batch_size, k)
    batch = {
        IMAGE_KEY: torch.rand(*lead, 3, IMAGE_SIZE, IMAGE_SIZE, generator=g),
        OBS_STATE: torch.randn(*lead, STATE_DIM, generator=g),
        OBS_ENV_STATE: torch.randn(*lead, 6, generator=g),
        ACTION: torch.cat(
            [
                torch.rand(batch_size, 3, generator=g) * 2 - 1,
                torch.randint(-1, 2, (batch_size, 1), generator=g),
            ],
            dim=-1,
        ),
    }
    if k is not None:
        pad = torch.zeros(batch_size, k, dtype=torch.bool)
        pad[0, :2] = True  # first sample starts an episode: two padded frames
        batch[f"{OBS_STATE}_is_pad"] = pad
    return batch


def observation_batch(batch_size: int = 2, seed: int = 0) -> dict[str, torch.Tensor]:
    """One rollout step's observation (no time axis, no action)."""
    batch = make_batch(batch_size, k=None, seed=seed)
    return {IMAGE_KEY: batch[IMAGE_KEY], OBS_STATE: batch[OBS_STATE]}


def demo_features(image_size: int) -> dict[str, dict]:
    """The demo dataset's feature spec (image, state, auxiliary targets, action)."""
    return {
        IMAGE_KEY: {
            "dtype": "image",
            "shape": (image_size, image_size, 3),
            "names": ["height", "width", "channels"],
        },
        OBS_STATE: {"dtype": "float32", "shape": (STATE_DIM,), "names": None},
        OBS_ENV_STATE: {
            "dtype": "float32",
            "shape": (6,),
            "names": ["ee_x", "ee_y", "ee_z", "object_x", "object_y", "object_z"],
        },
        ACTION: {
            "dtype": "float32",
            "shape": (4,),
            "names": ["delta_ee_x", "delta_ee_y", "delta_ee_z", "gripper"],
        },
    }


def build_expert_dataset(
    root: Path, num_episodes: int = 2, max_steps: int = 30, image_size: int = 64
) -> Path:
    """Record `num_episodes` pick_place expert episodes into a LeRobot dataset at `root`."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from lerobot_ivmc.envs import make_task_env
    from lerobot_ivmc.experts import make_expert, run_expert_episode

    dataset = LeRobotDataset.create(
        TINY_REPO_ID, fps=25, root=root, features=demo_features(image_size), use_videos=False
    )
    env = make_task_env("pick_place", obs_type="pixels_agent_pos", image_size=image_size)
    expert = make_expert(env)

    def on_step(obs: dict, action: np.ndarray, info: dict) -> None:
        dataset.add_frame(
            {
                IMAGE_KEY: obs["pixels"]["front"],
                OBS_STATE: obs["agent_pos"].astype(np.float32),
                OBS_ENV_STATE: obs["environment_state"].astype(np.float32),
                ACTION: np.asarray(action, dtype=np.float32),
                "task": "pick_place",
            }
        )

    for episode in range(num_episodes):
        run_expert_episode(env, expert, seed=episode, max_steps=max_steps, on_step=on_step)
        dataset.save_episode()
    dataset.finalize()
    env.close()
    return root


# A threshold record as `lerobot-ivmc-threshold` writes it.
THRESHOLD_RECORD = ThresholdRecord(
    threshold=2.5,
    method="argmax",
    window=20,
    task="pick_place",
    split="val",
    num_samples=8,
    uncertainty_lambda=0.5,
    episodes=[{"seed": 0, "u": 3.0, "success": False}],
)
