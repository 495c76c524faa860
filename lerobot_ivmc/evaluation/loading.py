"""Build a checkpoint's policy and the processor pipelines around it, as `lerobot-eval` does."""

from __future__ import annotations

from dataclasses import dataclass

from lerobot.configs.eval import EvalPipelineConfig
from lerobot.envs.factory import make_env_pre_post_processors
from lerobot.envs.utils import preprocess_observation
from lerobot.policies.factory import make_policy, make_pre_post_processors
from lerobot.policies.pretrained import PreTrainedPolicy


@dataclass
class LoadedPolicy:
    """A policy in eval mode with its processors, in the order LeRobot's `rollout` takes them."""

    policy: PreTrainedPolicy
    env_preprocessor: object
    env_postprocessor: object
    preprocessor: object
    postprocessor: object

    @property
    def processors(self) -> tuple:
        return self.env_preprocessor, self.env_postprocessor, self.preprocessor, self.postprocessor

    def to_policy_batch(self, observation: dict) -> dict:
        """A batched numpy observation (as a vector env returns it) -> the policy's input batch."""
        return self.preprocessor(self.env_preprocessor(preprocess_observation(observation)))


def load_policy(cfg: EvalPipelineConfig) -> LoadedPolicy:
    """`cfg.policy` (from `--policy.path`) built for `cfg.env`, with its saved processors."""
    policy = make_policy(cfg=cfg.policy, env_cfg=cfg.env, rename_map=cfg.rename_map)
    policy.eval()
    preprocessor, postprocessor = make_pre_post_processors(
        policy_cfg=cfg.policy,
        pretrained_path=cfg.policy.pretrained_path,
        preprocessor_overrides={
            "device_processor": {"device": str(policy.config.device)},
            "rename_observations_processor": {"rename_map": cfg.rename_map},
        },
    )
    env_preprocessor, env_postprocessor = make_env_pre_post_processors(env_cfg=cfg.env, policy_cfg=cfg.policy)
    return LoadedPolicy(policy, env_preprocessor, env_postprocessor, preprocessor, postprocessor)
