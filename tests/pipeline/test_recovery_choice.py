"""`--recovery_choice`: the row "chosen" picks, on validation scenes only, the mode that knows no task."""

from __future__ import annotations

from pathlib import Path

from lerobot_ivmc.pipeline.recovery_choice import choose_mode
from lerobot_ivmc.pipeline.stages import build_stages
from lerobot_ivmc.pipeline.study import parse_config


def record(rescued: int, lost: int) -> dict:
    return {"failures": 20, "flagged": 20, "rescued": rescued, "lost": lost}


def test_the_mode_rescuing_most_net_of_its_losses_is_chosen_then_fewer_lost_then_the_listed_order() -> None:
    assert choose_mode({"init": record(9, 0), "retry": record(12, 5), "rand": record(1, 0)}) == "init"
    assert choose_mode({"init": record(6, 2), "retry": record(4, 0)}) == "retry"  # net 4 each: fewer lost
    assert choose_mode({"init": record(3, 0), "retry": record(3, 0)}) == "init"
    assert choose_mode({"retry": record(3, 0), "init": record(3, 0)}) == "retry"


def test_each_candidate_runs_on_the_threshold_s_validation_scenes_with_its_checkpoint(tmp_path: Path) -> None:
    cfg = parse_config(["--task=door-open-v3", "--preset=metaworld", f"--output_dir={tmp_path}"])
    stages = {stage.name: stage for stage in build_stages(cfg)}
    choices = [name for name in stages if name.startswith("choice_")]
    assert choices == [f"choice_bvmc_fc1_{m}" for m in ("rand", "init", "min_unc", "retry", "reach")]
    threshold = stages["threshold_fc1"]

    def scenes(argv: list[str]) -> list[str]:
        return sorted(a for a in argv if a.startswith(("--seed=", "--eval.", "--env.", "--recovery.random")))

    retry = stages["choice_bvmc_fc1_retry"]
    assert scenes(retry.argv) == scenes(threshold.argv) and "--env.split=val" in retry.argv
    assert f"--policy.path={threshold.output}/pretrained_model" in retry.argv
    assert "--recovery.mode=retry" in retry.argv and retry.depends == [threshold.name]
    # The same mode's settings as its test row, so the choice is of what the test row runs.
    assert retry.settings == stages["eval_bvmc_fc1_retry"].settings
    # The chain ends after its choices, so the results are written with them.
    assert set(choices) <= set(stages["detect_fc1"].after)
    # Without the flag a study has no choice stage (the studies recorded before it keep their stages).
    plain = parse_config(["--task=door-open-v3", "--preset=metaworld", "--recovery_choice=[]"])
    assert not [s for s in build_stages(plain) if s.name.startswith("choice_")]
