"""`--recovery_choice`: the row "chosen" picks, on validation scenes only, the mode that knows no task."""

from __future__ import annotations

import json
from pathlib import Path

from lerobot_ivmc.pipeline.config import CHOICE_ROWS, STUDY_ROWS, TRIGGER_VARIANTS
from lerobot_ivmc.pipeline.recovery_choice import choose_mode
from lerobot_ivmc.pipeline.results import table_rows, training_seed_rows
from lerobot_ivmc.pipeline.seed_pool import spread_over_seeds
from lerobot_ivmc.pipeline.stages import build_stages
from lerobot_ivmc.pipeline.study import parse_config
from lerobot_ivmc.pipeline.tables import TRIGGER_LABELS, pooled_rescue_table, row_label


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
    candidates = ("rand", "init", "min_unc", "retry", "reach", "reach_carry_frame", "reach_place_frame")
    assert choices == [f"choice_bvmc_fc1_{m}" for m in candidates]
    threshold = stages["threshold_fc1"]

    def scenes(argv: list[str]) -> list[str]:
        return sorted(a for a in argv if a.startswith(("--seed=", "--eval.", "--env.", "--recovery.random")))

    retry = stages["choice_bvmc_fc1_retry"]
    assert scenes(retry.argv) == scenes(threshold.argv) and "--env.split=val" in retry.argv
    assert f"--policy.path={threshold.output}/pretrained_model" in retry.argv
    assert "--recovery.mode=retry" in retry.argv and retry.depends == [threshold.name]
    # The same mode's settings as its test row, so the choice is of what the test row runs.
    assert retry.settings == stages["eval_bvmc_fc1_retry"].settings
    # A variant row (the lite preset's reach_place) runs its mode with its own flags, as its test row does.
    lite = {s.name: s for s in build_stages(parse_config(["--task=pick_place", f"--output_dir={tmp_path}"]))}
    place, row = lite["choice_bvmc_fc1_reach_place"], lite["eval_bvmc_fc1_reach_place"]
    assert "--recovery.mode=reach" in place.argv and place.settings == row.settings
    assert {"--recovery.reach.carry=true", "--recovery.reach.release=true"} <= set(place.argv)
    assert {a for a in row.argv if a.startswith("--recovery.")} <= set(place.argv)
    # The chain ends after its choices, so the results are written with them.
    assert set(choices) <= set(stages["detect_fc1"].after)
    # Without the flag a study has no choice stage (the studies recorded before it keep their stages).
    plain = parse_config(["--task=door-open-v3", "--preset=metaworld", "--recovery_choice=[]"])
    assert not [s for s in build_stages(plain) if s.name.startswith("choice_")]


def eval_info(split: str, outcomes: list[bool], threshold: float = 1.0) -> dict:
    """An `eval_info.json` of door-open-v3 over scenes 0..n-1 with these successes."""
    n = len(outcomes)
    rate = 100.0 * sum(outcomes) / n
    return {
        "run": {"task": "door-open-v3", "split": split},
        "per_episode": [
            {"seed": i, "success": ok, "subtasks": {"success": ok}, "max_uncertainty": 0.0 if ok else 2.0}
            for i, ok in enumerate(outcomes)
        ],
        "aggregated_subtasks": {"success": {"pc": rate, "stderr": 1.0, "n": n}},
        "recovery": {"threshold": threshold, "num_recoveries": 0, "episodes_with_recovery": 0},
    }


def seed_rows(cfg, stages: list, plain: list[bool], validation: dict, test: dict) -> list[dict]:
    """Write every threshold, choice and test run of seeds 1000 and 2000 (BVMC's outcomes `plain`; init's
    and retry's per seed in `validation` and `test`) and return the seeds' recovery rows."""
    for stage in stages:
        name, out = stage.name, stage.output
        seed = 2000 if name.endswith("_seed2000") else 1000
        if name.startswith("threshold_fc1"):
            info = eval_info("val", plain)
        elif name.startswith("choice_bvmc_fc1_"):
            info = eval_info("val", validation[seed][0 if "_init" in name else 1])
        elif name.startswith("eval_"):
            mode = next((m for m in ("init", "retry") if f"_{m}" in name), None)
            info = eval_info("test", test[mode, seed] if mode else plain)
        else:
            continue
        out.mkdir(parents=True, exist_ok=True)
        (out / "eval_info.json").write_text(json.dumps(info))
    ended = {f"detect_fc1{sfx}" for sfx in ("", "_seed2000")}
    return training_seed_rows(cfg, stages, [1], ended)[1]


def test_each_seed_s_chosen_row_is_its_choice_s_test_row_and_pools_over_the_seeds(tmp_path: Path) -> None:
    """Seed 1000's validation favours init, seed 2000's retry: each seed's "chosen" row carries its own
    choice's test episodes, and the pooled rescue sums those, not one mode's."""
    cfg = parse_config(
        [
            "--task=door-open-v3",
            "--preset=metaworld",
            f"--output_dir={tmp_path}",
            "--recovery_choice=[init,retry]",
            "--train.extra_seeds=[2000]",
        ]
    )
    stages = build_stages(cfg)
    fail4 = [False] * 4 + [True] * 6  # scenes 0-3 failed without recovery
    # validation: (init, retry) outcomes per seed; test: each mode's outcomes per seed
    validation = {
        1000: ([True] * 3 + [False] + [True] * 6, [True] + [False] * 3 + [True] * 6),
        2000: ([False] * 4 + [True] * 6, [True] * 2 + [False] * 2 + [True] * 6),
    }
    test = {
        ("init", 1000): [True, True, False, False] + [True] * 6,
        ("retry", 1000): [True] * 3 + [False] + [True] * 6,  # (never chosen: seed 1000 chooses init)
        ("init", 2000): [False] * 4 + [True] * 6,
        ("retry", 2000): [True] + [False] * 3 + [True] * 6,
    }
    recovery_rows = seed_rows(cfg, stages, fail4, validation, test)
    chosen = {row["train_seed"]: row for row in recovery_rows if row["method"] == "chosen"}
    assert {seed: row["choice"]["chosen_mode"] for seed, row in chosen.items()} == {
        1000: "init",
        2000: "retry",
    }
    assert chosen[1000]["rescue"]["rescued"] == 2 and chosen[2000]["rescue"]["rescued"] == 1
    _, pooled = spread_over_seeds([], recovery_rows)
    pooled_chosen = next(p for p in pooled if p["method"] == "chosen")
    assert (pooled_chosen["failures"], pooled_chosen["rescued"], pooled_chosen["lost"]) == (8, 3, 0)


def test_none_is_chosen_where_every_mode_loses_on_validation_and_reports_bvmc_s_own_test_row(
    tmp_path: Path,
) -> None:
    """Seed 1000's modes both lose more validation successes than they rescue: "none" (0 / 0) is chosen and
    its row is BVMC's own test episodes; seed 2000's retry rescues and is chosen. "none" runs no stage."""
    cfg = parse_config(
        [
            "--task=door-open-v3",
            "--preset=metaworld",
            f"--output_dir={tmp_path}",
            "--recovery_choice=[init,retry,none]",
            "--train.extra_seeds=[2000]",
        ]
    )
    stages = build_stages(cfg)
    assert not [s for s in stages if s.name.startswith("choice_bvmc_fc1_none")]
    fail4 = [False] * 4 + [True] * 6
    validation = {
        1000: ([True] + [False] * 5 + [True] * 4, [False] * 6 + [True] * 4),  # init 1 / 2, retry 0 / 2
        2000: ([False] * 4 + [True] * 6, [True] * 2 + [False] * 2 + [True] * 6),  # retry 2 / 0
    }
    test = {("init", s): [True] * 10 for s in (1000, 2000)} | {
        ("retry", s): [True] * 10 for s in (1000, 2000)
    }
    recovery_rows = seed_rows(cfg, stages, fail4, validation, test)
    chosen = {row["train_seed"]: row for row in recovery_rows if row["method"] == "chosen"}
    assert (
        chosen[1000]["choice"]["chosen_mode"] == "none" and chosen[2000]["choice"]["chosen_mode"] == "retry"
    )
    assert chosen[1000]["choice"]["validation"]["none"]["rescued"] == 0
    assert chosen[1000]["subtasks"]["success"]["rate"] == 60.0  # BVMC's own test row, not a mode's 100%
    assert (chosen[1000]["rescue"]["rescued"], chosen[1000]["rescue"]["lost"]) == (0, 0)
    _, pooled = spread_over_seeds([], recovery_rows)
    pooled_chosen = next(p for p in pooled if p["method"] == "chosen")
    assert (pooled_chosen["failures"], pooled_chosen["rescued"], pooled_chosen["lost"]) == (8, 4, 0)


def test_a_trigger_row_runs_its_mode_with_the_trigger_s_flags_on_validation_and_test(tmp_path: Path) -> None:
    cfg = parse_config(
        [
            "--task=hand-insert-v3",
            "--preset=metaworld",
            f"--output_dir={tmp_path}",
            "--recovery_modes=[none,init,init_deadline_only,reach_carry_frame_grasp_miss]",
            "--recovery_choice=[none,init,init_deadline_only,reach_carry_frame_grasp_miss]",
        ]
    )
    stages = {stage.name: stage for stage in build_stages(cfg)}
    late = stages["choice_bvmc_fc1_init_deadline_only"]
    assert {"--recovery.mode=init", "--recovery.threshold=1e9", "--recovery.deadline=auto"} <= set(late.argv)
    assert late.settings == stages["eval_bvmc_fc1_init_deadline_only"].settings
    grasp = stages["eval_bvmc_fc1_reach_carry_frame_grasp_miss"]
    assert {"--recovery.mode=reach", "--recovery.reach.object=frame", "--recovery.grasp_miss=30"} <= set(
        grasp.argv
    )
    assert "--recovery.threshold=1e9" not in grasp.argv  # the score still fires


def test_choices_that_cannot_be_made_say_what_to_do(capsys) -> None:
    import pytest

    from lerobot_ivmc.scripts.lerobot_ivmc_pipeline import main as pipeline_main

    def refusal(*args: str) -> str:
        with pytest.raises(SystemExit) as ended:
            pipeline_main(["--task=door-open-v3", "--preset=metaworld", *args])
        assert ended.value.code == 2, args
        return capsys.readouterr().err

    assert "nothing to choose" in refusal("--recovery_choice=[none]")
    assert "unknown ['init_soon']" in refusal("--recovery_modes=[none,init_soon]", "--recovery_choice=[]")


def test_trigger_rows_of_a_study_are_tabled_as_their_row_with_their_trigger(tmp_path: Path) -> None:
    """`--recovery_modes` with a `<row>_<trigger>` row: Table I and the pooled rescue label it as its row with
    its trigger, right after its row, and pool it over the seeds like any row."""
    cfg = parse_config(
        [
            "--task=door-open-v3",
            "--preset=metaworld",
            f"--output_dir={tmp_path}",
            "--recovery_modes=[none,retry_grasp_miss,retry]",
            "--recovery_choice=[retry,retry_grasp_miss]",
            "--train.extra_seeds=[2000]",
        ]
    )
    stages = build_stages(cfg)
    fail4 = [False] * 4 + [True] * 6
    validation = {seed: ([True] * 10, [True] * 10) for seed in (1000, 2000)}
    test = {("retry", seed): [True] * 3 + [False] + [True] * 6 for seed in (1000, 2000)}
    recovery_rows = seed_rows(cfg, stages, fail4, validation, test)
    labels = {row["method"]: row["label"] for row in table_rows(cfg, stages, [1])}
    assert labels["retry_grasp_miss"] == f"{labels['retry']}, with the missed grasp"
    assert set(TRIGGER_LABELS) == set(TRIGGER_VARIANTS)  # every trigger of a study has its label
    assert all(row_label(row) for row in (*STUDY_ROWS, *CHOICE_ROWS))  # and every row
    _, pooled = spread_over_seeds([], recovery_rows)
    methods = [entry["method"] for entry in pooled]
    assert methods.index("retry_grasp_miss") == methods.index("retry") + 1
    grasp = pooled[methods.index("retry_grasp_miss")]
    assert (grasp["failures"], grasp["rescued"], grasp["lost"]) == (8, 6, 0)
    assert f"| {labels['retry_grasp_miss']} | 1 | 1000, 2000 |" in pooled_rescue_table(pooled)
