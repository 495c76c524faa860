"""Distilling a bvmc checkpoint's uncertainty foresight head, the library of `lerobot-ivmc-foresight`
(`scripts/lerobot_ivmc_foresight.py`): rollouts of the policy recording embeddings, actions and the
uncertainty measured at the next step, the head trained on them, its held-out quality and action ranking,
and a new checkpoint folder holding the head."""

import json
import logging
import shutil
from dataclasses import asdict, dataclass, field
from pathlib import Path

import torch
from lerobot.configs.eval import EvalPipelineConfig
from lerobot.utils.random_utils import set_seed

from lerobot_ivmc.constants import PRETRAINED_MODEL_DIR
from lerobot_ivmc.envs import make_task_env_from_config
from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.envs.vector_env import make_vector_env
from lerobot_ivmc.evaluation.compatibility import check_policy_matches_env
from lerobot_ivmc.evaluation.loading import load_policy
from lerobot_ivmc.evaluation.plugin_envs import check_plugin_env
from lerobot_ivmc.recovery.foresight_data import collect_distillation_data, load_shards
from lerobot_ivmc.recovery.foresight_ranking import measure_action_ranking
from lerobot_ivmc.recovery.foresight_training import (
    ForesightConfig,
    foresight_quality,
    split_by_trajectory,
    train_foresight,
)

logger = logging.getLogger(__name__)

REPORT_FILE = "foresight_report.json"
CHECKPOINT_DIR = PRETRAINED_MODEL_DIR


@dataclass
class ForesightPipelineConfig(EvalPipelineConfig):
    """`lerobot-eval`'s config (policy, env, `--eval.batch_size` parallel episodes, seed, output folder)
    plus the distillation settings."""

    foresight: ForesightConfig = field(default_factory=ForesightConfig)


def copy_checkpoint_extras(source: Path, destination: Path) -> None:
    """Copy the processors (and any other file) of a checkpoint folder except config and weights."""
    for path in source.iterdir():
        if path.is_file() and path.name not in ("config.json", "model.safetensors"):
            shutil.copy2(path, destination / path.name)


def check_inputs(cfg: ForesightPipelineConfig) -> Path:
    check_plugin_env(cfg.env, "lerobot-ivmc-foresight")
    if not isinstance(cfg.env, IvmcEnv) and cfg.foresight.ranking_states > 0:
        raise ValueError(
            "--foresight.ranking_states replays simulator snapshots of the Fetch tasks; pass "
            "--foresight.ranking_states=0 on --env.type=meta_world."
        )
    if cfg.policy is None or cfg.policy.pretrained_path is None:
        raise ValueError("Pass --policy.path=<bvmc checkpoint folder>.")
    if cfg.policy.type != "bvmc":
        raise ValueError(
            f"The foresight head distils Bayesian VMC uncertainty: {cfg.policy.pretrained_path} is a "
            f"{cfg.policy.type!r} policy; pass a bvmc checkpoint."
        )
    if cfg.seed is None:
        raise ValueError("Pass --seed: it fixes the distillation scenes and sampled actions.")
    check_policy_matches_env(cfg.policy, cfg.env)
    checkpoint = Path(cfg.output_dir) / CHECKPOINT_DIR
    if checkpoint.exists():
        raise FileExistsError(
            f"{checkpoint} exists: pass another --output_dir (checkpoints are never overwritten)."
        )
    if Path(cfg.output_dir).resolve() == Path(cfg.policy.pretrained_path).resolve():
        raise ValueError(
            "--output_dir must differ from --policy.path: the input checkpoint is never modified."
        )
    return checkpoint


def distill_foresight(cfg: ForesightPipelineConfig) -> dict:
    checkpoint = check_inputs(cfg)
    cfg.env.split = cfg.foresight.split
    set_seed(cfg.seed)
    loaded = load_policy(cfg)
    policy = loaded.policy
    vector_env = make_vector_env(cfg.env, cfg.eval.batch_size, cfg.eval.use_async_envs)
    output_dir = Path(cfg.output_dir)
    spec = {
        "policy": str(Path(cfg.policy.pretrained_path).resolve()),
        "task": cfg.env.task,
        "split": cfg.env.split,
        "num_trajectories": cfg.foresight.num_trajectories,
        "batch_size": cfg.eval.batch_size,
        "seed": cfg.seed,
        "num_samples": policy.config.num_samples,
    }
    if cfg.foresight.action_noise:  # absent (None in a mismatch message) when 0: older collections resume
        spec["action_noise"] = cfg.foresight.action_noise
    shards = collect_distillation_data(
        vector_env,
        policy,
        loaded.processors,
        output_dir / "distillation",
        cfg.foresight.num_trajectories,
        cfg.seed,
        spec,
        cfg.foresight.action_noise,
    )
    vector_env.close()
    records = load_shards(shards)
    train_mask, heldout_mask = split_by_trajectory(records, cfg.foresight.heldout_fraction)
    train = {k: v[train_mask] for k, v in records.items()}
    heldout = {k: v[heldout_mask] for k, v in records.items()}
    torch.manual_seed(cfg.seed)  # the head's initial weights
    head = policy.attach_foresight()
    policy.config.foresight_action_noise = cfg.foresight.action_noise
    losses = train_foresight(head, train, cfg.foresight, cfg.seed)
    report = {
        "spec": spec,
        "settings": asdict(cfg.foresight),
        "num_train_records": int(train_mask.sum()),
        "num_heldout_records": int(heldout_mask.sum()),
        "train_loss_per_epoch": losses,
        "heldout": foresight_quality(head, heldout),
    }
    if cfg.foresight.ranking_states > 0:
        env = make_task_env_from_config(cfg.env)
        first_unused = cfg.seed + len(shards) * cfg.eval.batch_size
        seeds = list(range(first_unused, first_unused + cfg.foresight.ranking_states))
        report["action_ranking"] = measure_action_ranking(
            env,
            policy,
            loaded.to_policy_batch,
            seeds,
            cfg.foresight.ranking_states,
            cfg.foresight.ranking_every,
            cfg.foresight.action_noise,
            cfg.seed,
        )
        env.close()
    checkpoint.mkdir(parents=True)
    policy.save_pretrained(checkpoint)
    copy_checkpoint_extras(Path(cfg.policy.pretrained_path), checkpoint)
    text = json.dumps(report, indent=2, default=float)
    (checkpoint / REPORT_FILE).write_text(text)
    (output_dir / REPORT_FILE).write_text(text)
    return report
