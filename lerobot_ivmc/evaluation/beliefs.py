"""Step a vmc or bvmc policy one frame at a time and read what its network believes, in world coordinates.

The network's auxiliary heads predict the end-effector and object positions (and, with `goal_head`, where
the object must end up) in the normalised space of `observation.environment_state`; `BeliefReader` maps
them back to metres so they can be compared with the simulator's true positions.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from lerobot.configs.eval import EvalPipelineConfig
from torch import Tensor

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.evaluation.feature_stats import env_state_stats
from lerobot_ivmc.evaluation.loading import LoadedPolicy
from lerobot_ivmc.evaluation.plugin_envs import check_plugin_env
from lerobot_ivmc.policies.vmc.gripper import deterministic_action
from lerobot_ivmc.recovery.foresight_ranking import batch_observations

GRIP, OBJECT = slice(0, 3), slice(3, 6)


def check_network_request(cfg: EvalPipelineConfig, command: str, any_plugin_env: bool = False) -> None:
    """Refuse, naming `command`, a config whose env is not an ivmc task (with `any_plugin_env`: not one of
    the plugin's envs) or whose policy is not a vmc or bvmc checkpoint (the networks whose beliefs
    `BeliefReader` reads)."""
    if any_plugin_env:
        check_plugin_env(cfg.env, command)
    elif not isinstance(cfg.env, IvmcEnv):
        raise ValueError(f"{command} runs on --env.type=ivmc, got {cfg.env.type!r}.")
    if cfg.policy is None or cfg.policy.pretrained_path is None:
        raise ValueError("Pass --policy.path=<vmc or bvmc checkpoint folder>.")
    if cfg.policy.type not in ("vmc", "bvmc"):
        raise ValueError(f"{command} reads vmc and bvmc networks, got {cfg.policy.type!r}.")


@dataclass
class PolicyStep:
    """One control step of a single rollout.

    Attributes:
        action: (4,) the action the policy executes (VMC's deterministic pass; BVMC's Monte Carlo mean).
        uncertainty: BVMC's uncertainty of this step, None for VMC.
        beliefs: world positions (3,) the deterministic pass believes: "grip", "object" and, for a net
            trained with `goal_head`, "goal".
    """

    action: Tensor
    uncertainty: float | None
    beliefs: dict[str, list[float]]


class BeliefReader:
    """Runs a loaded policy on one env's observations, step by step, carrying its memory.

    Args:
        loaded: the policy and processors (`load_policy`).
    """

    def __init__(self, loaded: LoadedPolicy):
        self.loaded = loaded
        self.policy = loaded.policy
        mean, std = env_state_stats(loaded.preprocessor)
        # The heads learn the entries at the policy's aux indices (all six of the Fetch tasks' state).
        indices = list(self.policy.config.aux_indices or range(len(mean)))
        self.mean, self.std = mean[indices], std[indices]
        self.bayesian = self.policy.name == "bvmc"
        self.with_goal = bool(getattr(self.policy.config, "goal_head", False))

    def reset(self) -> None:
        """Clear the policy's memory (a new episode)."""
        self.policy.reset()

    @torch.no_grad()
    def step(self, observation: dict, with_action: bool = True) -> PolicyStep:
        """Feed one observation of a single env (as `env.step` returns it); advances the memory.

        Args:
            with_action: also compute the executed action (a bvmc's Monte Carlo mean and uncertainty);
                False reads only the beliefs (the returned action is then VMC's deterministic one).
        """
        batch = self.loaded.to_policy_batch(batch_observations([observation]))
        sampled = self.bayesian and with_action
        if sampled:
            prediction = self.policy.sample(batch)
            embedding, uncertainty = prediction.embedding, float(prediction.uncertainty[0])
        else:
            embedding, uncertainty = self.policy.step_embedding(batch), None
        # The deterministic pass: the positions the net believes, and VMC's action (its select_action's).
        outputs = self.policy.net.decode(embedding, stochastic=False, with_goal=self.with_goal)
        if sampled:
            action = prediction.mean_action[0]
        else:
            action = deterministic_action(outputs[0], outputs[1], self.policy.config.gripper)[0]
        beliefs = {"grip": self.to_world(outputs[2], GRIP), "object": self.to_world(outputs[3], OBJECT)}
        if self.with_goal:
            beliefs["goal"] = self.to_world(outputs[4], OBJECT)
        return PolicyStep(action.float().cpu(), uncertainty, beliefs)

    def to_world(self, normalised: Tensor, part: slice) -> list[float]:
        """A decoded position of the first rollout, (3,) in metres."""
        return (normalised[0].float().cpu() * self.std[part] + self.mean[part]).tolist()
