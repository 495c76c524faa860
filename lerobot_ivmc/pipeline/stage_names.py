"""The names of a study's stages, spelt once: the runner's records and logs, the results, the data-budget
rule and the tests find stages by them."""

from __future__ import annotations

from lerobot_ivmc.pipeline.config import PipelineConfig

# Every stage's name, spelt once: the runner's records and logs, the results and the rule find stages by them.
COLLECT_STAGE = "collect"


def seed_suffix(train_seed: int | None) -> str:
    """The name suffix of an extra training seed's stages and folders (none for the main seed)."""
    return "" if train_seed is None else f"_seed{train_seed}"


def chain_folder(fc: int, train_seed: int | None = None) -> str:
    """`fc1`, or `fc1_seed2000` for an extra training seed: the folder of a chain's stages."""
    return f"fc{fc}{seed_suffix(train_seed)}"


def train_stage_name(policy_type: str, fc: int, train_seed: int | None = None) -> str:
    return f"train_{policy_type}_{chain_folder(fc, train_seed)}"


def foresight_stage_name(fc: int, train_seed: int | None = None) -> str:
    return f"foresight_{chain_folder(fc, train_seed)}"


def threshold_stage_name(fc: int, train_seed: int | None = None) -> str:
    return f"threshold_{chain_folder(fc, train_seed)}"


def detect_stage_name(fc: int, train_seed: int | None = None) -> str:
    return f"detect_{chain_folder(fc, train_seed)}"


def perception_stage_name(training: str) -> str:
    """`check_vmc_fc1` for `train_vmc_fc1` (and `check_bvmc_fc1_seed2000` for `train_bvmc_fc1_seed2000`)."""
    return "check_" + training.removeprefix("train_")


def eval_stage_name(policy_type: str, fc: int, mode: str | None, train_seed: int | None = None) -> str:
    """`eval_vmc_fc1`, `eval_bvmc_fc1_min_unc`, ... (`eval_bvmc_fc1_min_unc_seed2000` of an extra seed)."""
    return f"eval_{policy_type}_fc{fc}" + (f"_{mode}" if mode else "") + seed_suffix(train_seed)


def choice_stage_name(fc: int, mode: str, train_seed: int | None = None) -> str:
    """`choice_bvmc_fc1_retry` (`..._seed2000` of an extra seed): a `--recovery_choice` mode on validation
    scenes."""
    return f"choice_bvmc_fc{fc}_{mode}" + seed_suffix(train_seed)


def fig3_stage_name(cfg: PipelineConfig, fc: int, train_seed: int | None = None) -> str:
    """The stage whose episodes give Fig. 3 and the detection metrics: BVMC without recovery on test
    scenes; the Table I row itself when it has as many episodes, else a stage of its own."""
    same = "none" in cfg.recovery_modes and (cfg.fig3.n_episodes, cfg.fig3.batch_size) == (
        cfg.eval.n_episodes,
        cfg.eval.batch_size,
    )
    if same:
        return eval_stage_name("bvmc", fc, "none", train_seed)
    return f"fig3_{chain_folder(fc, train_seed)}"
