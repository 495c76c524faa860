"""The evaluation behind `lerobot-ivmc-eval` (`scripts/lerobot_ivmc_eval.py`): LeRobot's own `eval_policy`
(rollout, seeding, videos) on ivmc envs whose sub-envs record the episodes' milestones, a `bvmc` policy
inside `IntrospectiveController` (Algorithm 1), and what the command writes: `eval_info.json` with
`subtasks` and `aggregated_subtasks`, the uncertainty traces, Fig. 3 and the recovery videos."""

import logging
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from pprint import pformat

import gymnasium as gym
import numpy as np
import torch
from lerobot.configs.eval import EvalPipelineConfig
from lerobot.envs.configs import EnvConfig
from lerobot.scripts.lerobot_eval import eval_policy
from lerobot.utils.constants import OBS_STATE
from lerobot.utils.random_utils import set_seed

from lerobot_ivmc.atomic_files import write_json_atomic
from lerobot_ivmc.constants import EVAL_INFO_FILE
from lerobot_ivmc.datasets.root_lock import EVAL_LOCK_FILE, RootLock
from lerobot_ivmc.envs.vector_env import make_vector_env
from lerobot_ivmc.evaluation.compatibility import check_policy_matches_env
from lerobot_ivmc.evaluation.feature_stats import env_state_stats, feature_stats
from lerobot_ivmc.evaluation.loading import load_policy
from lerobot_ivmc.evaluation.metrics import aggregate_milestones
from lerobot_ivmc.evaluation.milestone_recorder import MilestoneRecorder
from lerobot_ivmc.evaluation.plugin_envs import (
    check_plugin_env,
    embodiment_of,
    recovery_settings,
    task_traits_of,
)
from lerobot_ivmc.evaluation.recovery_videos import (
    RecoveryVideoStore,
    recovery_phase_summary,
    write_recovery_video,
)
from lerobot_ivmc.evaluation.success_by_uncertainty import (
    plot_success_by_uncertainty,
    success_by_uncertainty_bins,
)
from lerobot_ivmc.evaluation.traces import TRACES_FILE, episode_traces, save_traces
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.controller import IntrospectiveController
from lerobot_ivmc.recovery.threshold import ThresholdRecord, check_finite, resolve_deadline, resolve_threshold
from lerobot_ivmc.recovery.time_baseline import baseline_digest

logger = logging.getLogger(__name__)

FIG3_FILE = "uncertainty_vs_success.png"


# As `lerobot-eval`, which renders the first 10 episodes into `videos/`.
DEFAULT_EPISODES_RENDERED = 10


@dataclass
class IvmcEvalConfig(EvalPipelineConfig):
    """`lerobot-eval`'s config plus the recovery settings (`--recovery.mode=min_unc`, ...).

    Args:
        recovery: the recovery settings.
        max_episodes_rendered: episodes LeRobot's `eval_policy` renders into `videos/` at
            `--env.render_size` (0: none; recovery videos are made apart from these).
        park_finished_envs: a sub-env whose episode ended before its batch's last repeats its final
            observation instead of simulating an unseeded episode nobody reads (false: LeRobot's way; the
            same per-episode results, slower).
    """

    recovery: RecoveryConfig = field(default_factory=RecoveryConfig)
    max_episodes_rendered: int = DEFAULT_EPISODES_RENDERED
    park_finished_envs: bool = True

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.max_episodes_rendered < 0:
            raise ValueError(f"--max_episodes_rendered must be >= 0, got {self.max_episodes_rendered}.")


def make_recorded_vector_env(
    env_cfg: EnvConfig, n_envs: int, use_async: bool = False, park: bool = True
) -> gym.vector.VectorEnv:
    """The vector env LeRobot's `make_env` would build, with a `MilestoneRecorder` on each sub-env (and
    finished sub-envs parked, as `make_vector_env` says)."""
    return make_vector_env(env_cfg, n_envs, use_async, wrap=MilestoneRecorder, park=park)


def episode_order(per_env: list[list], n_episodes: int) -> list:
    """Per-env records in `eval_policy`'s episode order (batch-major, then sub-env)."""
    n_batches = len(per_env[0])
    episodes = [per_env[j][b] for b in range(n_batches) for j in range(len(per_env))]
    return episodes[:n_episodes]


def collect_episode_milestones(env: gym.vector.VectorEnv, n_episodes: int) -> list[dict[str, bool]]:
    """Milestones of the evaluated episodes in `eval_policy`'s order (batch-major, then sub-env)."""
    return episode_order(env.get_attr("episode_milestones"), n_episodes)


def check_recovery_request(cfg: IvmcEvalConfig) -> None:
    """Refuse recovery for a policy type without uncertainty before anything is built."""
    if cfg.policy is None:
        raise ValueError("Pass --policy.path=<checkpoint folder>.")
    if cfg.recovery.mode != "none" and cfg.policy.type != "bvmc":
        raise ValueError(
            f"--recovery.mode={cfg.recovery.mode} needs a bvmc checkpoint (Monte Carlo uncertainty); "
            f"{cfg.policy.pretrained_path} is a {cfg.policy.type!r} policy. Use --recovery.mode=none."
        )


def evaluate(cfg: IvmcEvalConfig, ignore_stored_threshold: bool = False) -> dict:
    """Evaluate `cfg.policy` on `cfg.env`; write and return the eval info with subtask and recovery data.

    `ignore_stored_threshold` skips the checkpoint's `recovery_threshold.json` (to pick a new one).
    """
    check_plugin_env(cfg.env, "lerobot-ivmc-eval")
    recovery_settings(cfg.recovery, cfg.env)  # refuses a mode the env has no settings for
    if cfg.seed is None:
        raise ValueError("Pass --seed: episodes are matched to their subtask records through seeded resets.")
    check_recovery_request(cfg)
    check_policy_matches_env(cfg.policy, cfg.env)
    output_dir = Path(cfg.output_dir)
    # One evaluation writes a folder at a time (a second one would mix its videos and results with ours).
    with RootLock(output_dir, EVAL_LOCK_FILE, "evaluation", "--output_dir", FileExistsError):
        if (output_dir / EVAL_INFO_FILE).exists():
            raise FileExistsError(
                f"{output_dir / EVAL_INFO_FILE} exists: pass another --output_dir (results are never "
                "overwritten)."
            )
        return run_evaluation(cfg, output_dir, ignore_stored_threshold)


def run_evaluation(cfg: IvmcEvalConfig, output_dir: Path, ignore_stored_threshold: bool) -> dict:
    """`evaluate`'s run, in the output folder it holds."""
    is_bayesian = cfg.policy.type == "bvmc"
    threshold, window, source, baseline, deadline_source = None, 0, "none", None, "none"
    if is_bayesian:
        path = cfg.policy.pretrained_path
        record = ThresholdRecord.load(path) if path and not ignore_stored_threshold else None
        threshold, window, source = resolve_threshold(
            cfg.recovery.mode, cfg.recovery.threshold, cfg.recovery.window, record, cfg.env.task
        )
        if source == "checkpoint":
            source = (
                f"checkpoint ({record.method}{'' if record.alpha is None else f', alpha={record.alpha}'})"
            )
        deadline, deadline_source = resolve_deadline(cfg.recovery.deadline, record)
        cfg.recovery = replace(cfg.recovery, deadline=deadline)
        # A time-conditioned record's baseline holds for an overriding C too: C is on its scale.
        if record is not None and record.baseline is not None:
            baseline = np.asarray(record.baseline)
            source += f", time-conditioned (quantile {record.baseline_quantile})"
    logger.info(pformat(asdict(cfg)))
    set_seed(cfg.seed)
    env = make_recorded_vector_env(
        cfg.env, cfg.eval.batch_size, cfg.eval.use_async_envs, park=cfg.park_finished_envs
    )
    loaded = load_policy(cfg)
    policy = loaded.policy
    controller, video_store = None, None
    if is_bayesian:
        if cfg.recovery.mode != "none" and cfg.recovery.max_videos > 0:
            video_store = RecoveryVideoStore(cfg.recovery.max_videos, policy.config.image_feature_key)
        controller = IntrospectiveController(
            policy,
            recovery_settings(cfg.recovery, cfg.env),
            threshold,
            window,
            env_state_stats(loaded.preprocessor),
            seed=cfg.seed,
            observers=(video_store,) if video_store is not None else (),
            state_stats=feature_stats(loaded.preprocessor, OBS_STATE),
            embodiment=embodiment_of(cfg.env),
            task_traits=task_traits_of(cfg.env),
            baseline=baseline,
        )
    # Seed again once everything is built: the Monte Carlo masks then do not depend on how many random
    # draws building the policy took (e.g. a checkpoint with or without a foresight head).
    set_seed(cfg.seed)
    with torch.no_grad():
        info = eval_policy(
            env,
            controller if controller is not None else policy,
            *loaded.processors,
            n_episodes=cfg.eval.n_episodes,
            max_episodes_rendered=cfg.max_episodes_rendered,
            videos_dir=output_dir / "videos",
            start_seed=cfg.seed,
        )
    if controller is not None:
        controller.end_batch()
    n = cfg.eval.n_episodes
    milestones = collect_episode_milestones(env, n)
    lengths_per_env = env.get_attr("episode_lengths")
    env.close()
    for episode, flags in zip(info["per_episode"], milestones, strict=True):
        episode["subtasks"] = flags
    info["aggregated_subtasks"] = aggregate_milestones(milestones)
    info["run"] = {
        "task": cfg.env.task,
        "split": cfg.env.split,
        "policy_path": str(cfg.policy.pretrained_path),
        "policy_type": cfg.policy.type,
        "num_fc_layers": cfg.policy.num_fc_layers,
        "seed": cfg.seed,
        "n_episodes": n,
    }
    output_dir.mkdir(parents=True, exist_ok=True)
    if controller is not None:
        episodes = episode_traces(controller.traces, lengths_per_env, n, window, baseline)
        add_recovery_results(info, episodes, cfg, threshold, window, source, output_dir)
        if baseline is not None:
            info["recovery"]["baseline_digest"] = baseline_digest(baseline)
        if deadline_source == "checkpoint":
            info["recovery"]["deadline_source"] = "checkpoint (--recovery.deadline=auto)"
        if cfg.recovery.mode == "min_unc":
            info["recovery"]["candidate_noise"] = controller.candidate_noise
        if video_store is not None:
            info["recovery"]["videos"] = write_videos(
                video_store, controller, lengths_per_env, cfg, threshold
            )
    write_json_atomic(output_dir / EVAL_INFO_FILE, info)  # the done file: written last, whole
    return info


def add_recovery_results(
    info: dict,
    episodes: list[dict],
    cfg: IvmcEvalConfig,
    threshold: float | None,
    window: int,
    source: str,
    output_dir: Path,
) -> None:
    """Per-episode u and recovery events, the recovery summary, the traces file and the Fig. 3 plot."""
    successes = [bool(e["success"]) for e in info["per_episode"]]
    for record, episode in zip(info["per_episode"], episodes, strict=True):
        record["max_uncertainty"] = episode["max_uncertainty"]
        record["recoveries"] = episode["events"]
        record["recovery_steps"] = recovery_phase_summary(episode)
    save_traces(output_dir / TRACES_FILE, episodes, [e["seed"] for e in info["per_episode"]])
    scores = list(
        check_finite("The episodes' maximum uncertainty u", [e["max_uncertainty"] for e in episodes])
    )
    binned = success_by_uncertainty_bins(scores, successes)
    title = f"{cfg.env.task}, {cfg.policy.type} #fc={cfg.policy.num_fc_layers}, recovery={cfg.recovery.mode}"
    plot_success_by_uncertainty(binned, output_dir / FIG3_FILE, title)
    info["uncertainty_vs_success"] = {**binned, "plot": FIG3_FILE}
    info["recovery"] = {
        "mode": cfg.recovery.mode,
        "threshold": threshold,
        "threshold_source": source,
        "window": window,
        "settings": asdict(recovery_settings(cfg.recovery, cfg.env)),  # as they acted
        "num_recoveries": sum(len(e["events"]) for e in episodes),
        "episodes_with_recovery": sum(bool(e["events"]) for e in episodes),
        "traces": TRACES_FILE,
    }


def write_videos(
    store: RecoveryVideoStore,
    controller: IntrospectiveController,
    lengths_per_env: list[list[int]],
    cfg: IvmcEvalConfig,
    threshold: float | None,
) -> list[str]:
    """Write the kept recovery episodes as mp4s with their traces; return the paths."""
    paths = []
    batch_size = len(lengths_per_env)
    for (j, b), frames in sorted(store.kept.items(), key=lambda item: (item[0][1], item[0][0])):
        episode_index = b * batch_size + j
        if episode_index >= cfg.eval.n_episodes:
            continue
        length = lengths_per_env[j][b]
        episode = controller.traces[b].episode(j, length)
        path = Path(cfg.output_dir) / "recovery_videos" / f"episode_{episode_index:04d}.mp4"
        write_recovery_video(path, frames[:length], episode, float(threshold), cfg.env.fps)
        paths.append(str(path))
    return paths
