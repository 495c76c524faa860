"""The recovery chosen on validation scenes (`--recovery_choice`): no single mode that knows no task rescues
on every task (retry on the Fetch tasks, init on door-open-v3), so each chain chooses among them as it
chooses its threshold, on validation scenes only, and the row "chosen" reports the chosen mode's test
episodes. The rule: most validation failures rescued net of the successes lost; ties go to fewer lost, then
to the mode listed first. "none" among the candidates (no recovery, 0 / 0) keeps recovery off where every
mode loses more than it rescues. Over training seeds, the row "chosen over the seeds" applies the same rule
once to the candidates' validation rescue summed over the seeds (`seed_pool.chosen_over_seeds`)."""

from __future__ import annotations

from lerobot_ivmc.evaluation.compare import load_run, rescue_record
from lerobot_ivmc.pipeline.config import PipelineConfig
from lerobot_ivmc.pipeline.stage_names import choice_stage_name, threshold_stage_name
from lerobot_ivmc.pipeline.stages import Stage, stage_output

CHOSEN = "chosen"
CHOSEN_OVER_SEEDS = "chosen_over_seeds"


def choose_mode(validation: dict[str, dict]) -> str:
    """The rule on each candidate's validation rescue record (`rescue_record`), in the listed order."""
    order = list(validation)

    def merit(mode: str) -> tuple[int, int, int]:
        record = validation[mode]
        return record["rescued"] - record["lost"], -record["lost"], -order.index(mode)

    return max(order, key=merit)


def chain_choice(cfg: PipelineConfig, stages: list[Stage], fc: int, train_seed: int | None) -> dict:
    """One chain's choice: each candidate's rescue of the threshold's validation failures, and the mode
    chosen (`train_seed` None: the main seed)."""
    plain = load_run(stage_output(stages, threshold_stage_name(fc, train_seed)))
    success = list(plain["aggregated_subtasks"])[-1]
    validation = {}
    for mode in cfg.recovery_choice:
        if mode == "none":
            validation[mode] = no_recovery_record(plain, success)
            continue
        run = load_run(stage_output(stages, choice_stage_name(fc, mode, train_seed)))
        validation[mode] = rescue_record(plain, run, success)
    return {"chosen_mode": choose_mode(validation), "validation": validation}


def no_recovery_record(plain: dict, success: str) -> dict:
    """The rescue record of "none" on the run without recovery `plain`: nothing rescued, nothing lost."""
    failures = sum(not e["subtasks"][success] for e in plain["per_episode"])
    return {
        "failures": failures,
        "flagged": None,
        "rescued": 0,
        "lost": 0,
        "rescue_rate": 0.0 if failures else None,
        "mcnemar_exact_p": 1.0,
    }
