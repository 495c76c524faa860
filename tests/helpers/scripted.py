"""Scripted recovery runs: a bvmc whose uncertainty and actions are scripted, stepped in a real env, and a
robot unlike the Fetch arm and the Sawyer."""

from __future__ import annotations

import dataclasses

import numpy as np
import torch
from lerobot.utils.constants import OBS_ENV_STATE, OBS_STATE

from helpers.policies import IMAGE_KEY, make_config
from lerobot_ivmc.envs import make_task_env
from lerobot_ivmc.envs.embodiment import Embodiment
from lerobot_ivmc.policies import BVMCConfig
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.recovery.controller import IntrospectiveController

# A robot unlike both: 2 cm per action unit, the gripper opened by 0.5 and closed by -0.5, no no-op, one
# finger reading 0.2-0.8 on something.
FAKE = Embodiment("fake", 0.02, 0.5, -0.5, None, (3, 4, 5), (0,), held_gap=(0.2, 0.8))

IDENTITY_STATS = (torch.zeros(6), torch.ones(6))  # the batch carries raw positions


def to_batch(observation: dict) -> dict[str, torch.Tensor]:
    image = torch.from_numpy(observation["pixels"]["front"]).permute(2, 0, 1)[None].float() / 255
    return {
        IMAGE_KEY: image,
        OBS_STATE: torch.as_tensor(observation["agent_pos"], dtype=torch.float32)[None],
        OBS_ENV_STATE: torch.as_tensor(observation["environment_state"], dtype=torch.float32)[None],
    }


def scripted_policy(
    uncertainties: list[float], move: list[float], gripper: float = 0.0, **config
) -> BVMCPolicy:
    """A bvmc (random weights, foresight head) whose step t reports `uncertainties[t]` (a number, or one
    per rollout of the batch) and whose mean action is the constant `move` with the gripper command
    `gripper` (kept: 0), so its path is known."""
    torch.manual_seed(0)
    policy = BVMCPolicy(make_config(BVMCConfig, num_samples=8, **config))
    policy.attach_foresight()
    policy.eval()
    sample = policy.sample
    step = {"t": 0}

    def scripted(batch, *args, **kwargs):
        prediction = sample(batch, *args, **kwargs)
        t = min(step["t"], len(uncertainties) - 1)
        step["t"] += 1
        rows = prediction.mean_action.shape[0]
        mean = torch.tensor([[*move, gripper]], dtype=prediction.mean_action.dtype).repeat(rows, 1)
        uncertainty = torch.tensor(np.atleast_1d(uncertainties[t]), dtype=torch.float32)
        return dataclasses.replace(prediction, uncertainty=uncertainty, mean_action=mean)

    policy.sample = scripted
    return policy


def recorded_changes(controller: IntrospectiveController) -> list:
    """The memory changes the controller applies from now on, in order (the list fills as it runs)."""
    changes, apply = [], controller._apply

    def recording_apply(row, change):
        apply(row, change)
        changes.append(change)

    controller._apply = recording_apply
    return changes


def run_episode(controller: IntrospectiveController, steps: int, seed: int = 0) -> tuple[list, list]:
    """Step a pick_place env with the controller; return per-step grip positions and actions."""
    env = make_task_env("pick_place", image_size=64)
    observation, _ = env.reset(seed=seed)
    controller.reset()
    grips, actions = [], []
    for _ in range(steps):
        grips.append(env.grip_position)
        action = controller.select_action(to_batch(observation))[0].numpy()
        actions.append(action)
        observation, *_ = env.step(action)
    env.close()
    return grips, actions
