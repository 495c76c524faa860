"""`lerobot-ivmc-eval`: `lerobot-eval` for the ivmc tasks, reporting the paper's subtask success too.

It parses the same arguments as `lerobot-eval` and runs LeRobot's own `eval_policy` (rollout, seeding,
videos); the only difference is a wrapper on each sub-env that keeps the episode's milestones, which are
added to `eval_info.json` as `subtasks` (per episode) and `aggregated_subtasks` (rates with standard errors).

    lerobot-ivmc-eval --policy.path=outputs/train/bvmc/checkpoints/last/pretrained_model \\
        --env.type=ivmc --env.task=pick_place --eval.n_episodes=50 --eval.batch_size=10 --seed=0
"""

import json
import logging
from dataclasses import asdict
from pathlib import Path
from pprint import pformat

import gymnasium as gym
import torch
from lerobot.configs import parser
from lerobot.configs.eval import EvalPipelineConfig
from lerobot.envs.factory import make_env_pre_post_processors
from lerobot.policies.factory import make_policy, make_pre_post_processors
from lerobot.scripts.lerobot_eval import eval_policy
from lerobot.utils.import_utils import register_third_party_plugins
from lerobot.utils.random_utils import set_seed

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.evaluation.metrics import aggregate_milestones
from lerobot_ivmc.evaluation.milestone_recorder import MilestoneRecorder

logger = logging.getLogger(__name__)


def make_recorded_vector_env(env_cfg: IvmcEnv, n_envs: int) -> gym.vector.SyncVectorEnv:
    """The vector env LeRobot's `make_env` would build, with a `MilestoneRecorder` on each sub-env."""

    def make_one() -> gym.Env:
        return MilestoneRecorder(gym.make(env_cfg.gym_id, disable_env_checker=True, **env_cfg.gym_kwargs))

    return gym.vector.SyncVectorEnv(
        [make_one for _ in range(n_envs)], autoreset_mode=gym.vector.AutoresetMode.SAME_STEP
    )


def collect_episode_milestones(env: gym.vector.SyncVectorEnv, n_episodes: int) -> list[dict[str, bool]]:
    """Milestones of the evaluated episodes in `eval_policy`'s order (batch-major, then sub-env)."""
    per_env = env.get_attr("episode_milestones")
    n_batches = len(per_env[0])
    episodes = [per_env[j][b] for b in range(n_batches) for j in range(len(per_env))]
    return episodes[:n_episodes]


def evaluate(cfg: EvalPipelineConfig) -> dict:
    """Evaluate `cfg.policy` on `cfg.env`; write and return the eval info with subtask metrics."""
    if not isinstance(cfg.env, IvmcEnv):
        raise ValueError(
            f"lerobot-ivmc-eval evaluates --env.type=ivmc, got {cfg.env.type!r}; use lerobot-eval."
        )
    if cfg.seed is None:
        raise ValueError("Pass --seed: episodes are matched to their subtask records through seeded resets.")
    logger.info(pformat(asdict(cfg)))
    set_seed(cfg.seed)
    env = make_recorded_vector_env(cfg.env, cfg.eval.batch_size)
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
    output_dir = Path(cfg.output_dir)
    with torch.no_grad():
        info = eval_policy(
            env,
            policy,
            env_preprocessor,
            env_postprocessor,
            preprocessor,
            postprocessor,
            n_episodes=cfg.eval.n_episodes,
            max_episodes_rendered=10,
            videos_dir=output_dir / "videos",
            start_seed=cfg.seed,
        )
    milestones = collect_episode_milestones(env, cfg.eval.n_episodes)
    env.close()
    for episode, flags in zip(info["per_episode"], milestones, strict=True):
        episode["subtasks"] = flags
    info["aggregated_subtasks"] = aggregate_milestones(milestones)
    output_dir.mkdir(parents=True, exist_ok=True)
    (output_dir / "eval_info.json").write_text(json.dumps(info, indent=2))
    return info


@parser.wrap()
def eval_main(cfg: EvalPipelineConfig) -> dict:
    info = evaluate(cfg)
    print(f"{cfg.env.task}: {cfg.eval.n_episodes} episodes on {cfg.env.split} scenes (seeds {cfg.seed}..)")
    for name, rate in info["aggregated_subtasks"].items():
        print(f"  {name:<6} {rate['pc']:6.2f} +- {rate['stderr']:.2f} %")
    print(f"Eval info: {Path(cfg.output_dir) / 'eval_info.json'}")
    return info


def main() -> None:
    logging.basicConfig(level=logging.INFO)
    register_third_party_plugins()
    eval_main()


if __name__ == "__main__":
    main()
