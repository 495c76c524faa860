"""A study's stage fingerprints stay what they were: a changed fingerprint redoes the stage and everything
after it (hours of training at `lite`), so only a change of what a stage computes may change one."""

from __future__ import annotations

import functools

import pytest

from lerobot_ivmc.pipeline import stages as stages_module
from lerobot_ivmc.pipeline.runner import fingerprint
from lerobot_ivmc.pipeline.stages import build_stages
from lerobot_ivmc.pipeline.study import parse_config
from lerobot_ivmc.recovery.strategy_settings import AnchorSettings, ReachSettings, RetrySettings

# The fingerprints of `lerobot-ivmc-pipeline --task=pick_place --preset=lite --train.num_fc_layers=[1]
# --output_dir=/studies/pick_place_lite` on a CPU with native bf16, as the code of 72da9bb (the running
# lite studies') computed them. Change one only with a change of what its stage computes, knowing that every
# study begun before redoes that stage and all after it. The anchor row's holds anchor's settings since its
# goal became the mean over 30 least uncertain steps (10 before: cbf89424e54df36d; 55714eb8c7b67ad7 until
# the look and the object's head became task-dependent; 37b916f0044e917a until the row's settings were
# recorded as resolved for the task, when pick_reach's defaults changed and pick_place's did not: a study
# begun before redoes its anchor rows once, a minute each, to the same result).
LITE_PICK_PLACE = {
    "collect": "a530cb8fe6fe2304",
    "train_vmc_fc1": "efc6c777afa13adb",
    "check_vmc_fc1": "071d17ca6b782830",
    "train_bvmc_fc1": "0157db68a2fe98f7",
    "check_bvmc_fc1": "4c45cbf05b3a874c",
    "foresight_fc1": "ca7723ea15159635",
    "threshold_fc1": "87c9fc82071d5c9e",
    "eval_vmc_fc1": "5b6d79dc12a01906",
    "eval_bvmc_fc1_none": "c64b667510a064bf",
    "eval_bvmc_fc1_rand": "0deae0bfbeed1352",
    "eval_bvmc_fc1_init": "cae409a12d99787b",
    "eval_bvmc_fc1_min_unc": "6945b9b7098c08c7",
    "eval_bvmc_fc1_anchor": "a69edf285a40f946",
    "detect_fc1": "6e7b0a3c610b79c0",
}
# The command those fingerprints are of.
LITE_PICK_PLACE_ARGS = [
    "--task=pick_place",
    "--preset=lite",
    "--output_dir=/studies/pick_place_lite",
    "--train.num_fc_layers=[1]",
]


def test_studies_begun_earlier_keep_their_stage_fingerprints(monkeypatch: pytest.MonkeyPatch) -> None:
    """Also: a policy field the training takes from its dataset (`trained_task`, added after those studies
    began) is not a setting of the training stage; its input, the collect stage, is in the fingerprint."""
    monkeypatch.setattr(stages_module, "cpu_has_native_bf16", lambda: True)
    cfg = parse_config(LITE_PICK_PLACE_ARGS)
    found: dict[str, str] = {}
    for stage in build_stages(cfg):
        found[stage.name] = fingerprint(stage, found)
    # The retry row, anchor's control row, reach's carry rows and the choice's validation runs joined the lite
    # preset after these studies began: a study resumed runs them, and redoes nothing else.
    assert {name: found[name] for name in LITE_PICK_PLACE} == LITE_PICK_PLACE
    carries = ("reach_carry", "reach_place", "reach_carry_frame", "reach_place_frame")
    choices = {f"choice_bvmc_fc1_{mode}" for mode in ("rand", "init", "min_unc", "retry", *carries)}
    rows = {f"eval_bvmc_fc1_{row}" for row in ("retry", "anchor_control", *carries)}
    assert found.keys() - LITE_PICK_PLACE.keys() == rows | choices
    train = next(stage for stage in build_stages(cfg) if stage.name == "train_bvmc_fc1")
    assert "trained_task" not in train.settings and train.settings["render_style"] == "fast"


def stage_fingerprints(cfg) -> dict[str, str]:
    """Every stage's fingerprint in a study of `cfg`, by stage name."""
    found: dict[str, str] = {}
    for stage in build_stages(cfg):
        found[stage.name] = fingerprint(stage, found)
    return found


def test_a_changed_anchor_default_redoes_the_anchor_rows_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """anchor's defaults are chosen on validation scenes and may change: the rows that ran with the old ones
    must not count as done, and no other stage may be redone for it."""
    monkeypatch.setattr(stages_module, "cpu_has_native_bf16", lambda: True)
    cfg = parse_config(["--task=push", "--preset=lite", "--output_dir=/studies/push_lite"])

    before = stage_fingerprints(cfg)
    monkeypatch.setattr(stages_module, "AnchorSettings", functools.partial(AnchorSettings, look_steps=3))
    after = stage_fingerprints(cfg)
    changed = sorted(name for name in before if before[name] != after[name])
    assert changed == [f"eval_bvmc_fc{fc}_{row}" for fc in (1, 2) for row in ("anchor", "anchor_control")]


@pytest.mark.parametrize(
    ("task", "frame_head", "flags"),
    [
        ("push", "false", ["--recovery.anchor.object=memory"]),
        ("push", "true", []),
        ("pick_place", "false", []),
        ("pick_reach", "false", ["--recovery.anchor.object=memory", "--recovery.anchor.goal=memory"]),
        ("pick_reach", "true", []),
    ],
)
def test_an_anchor_row_reads_the_memory_heads_where_the_policy_lacks_the_frame_head(
    task: str, frame_head: str, flags: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """anchor reads a pushed object, and pick_reach's stick and goal, from the frame position head by
    default: a study whose policies lack it runs its anchor rows on the memory's heads (and only those rows
    and its control row say so)."""
    monkeypatch.setattr(stages_module, "cpu_has_native_bf16", lambda: True)
    cfg = parse_config(
        [
            f"--task={task}",
            "--preset=lite",
            "--output_dir=/s",
            f"--train.policy.frame_position_head={frame_head}",
        ]
    )
    for stage in build_stages(cfg):
        memory_flags = [arg for arg in stage.argv if arg.endswith("=memory")]
        anchor_row = stage.name.endswith(("_anchor", "_anchor_control"))
        assert memory_flags == (flags if anchor_row else []), stage.name


def test_episode_streams_redo_the_bvmc_rollouts_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """`--random_streams=episode` reaches every stage that rolls the bvmc out under the recovery controller
    (threshold, the BVMC rows, the Fig. 3 episodes after them), and only those change their fingerprints:
    the trainings, checks, foresight and VMC's row stay done."""
    monkeypatch.setattr(stages_module, "cpu_has_native_bf16", lambda: True)
    args = LITE_PICK_PLACE_ARGS
    found: dict[str, str] = {}
    for stage in build_stages(parse_config([*args, "--random_streams=episode"])):
        found[stage.name] = fingerprint(stage, found)
        assert ("--recovery.random_streams=episode" in stage.argv) == (
            stage.name.startswith(("threshold", "eval_bvmc", "fig3", "choice_bvmc"))
        ), stage.name
    changed = sorted(name for name in LITE_PICK_PLACE if found[name] != LITE_PICK_PLACE[name])
    assert changed == [
        "detect_fc1",
        "eval_bvmc_fc1_anchor",
        "eval_bvmc_fc1_init",
        "eval_bvmc_fc1_min_unc",
        "eval_bvmc_fc1_none",
        "eval_bvmc_fc1_rand",
        "threshold_fc1",
    ]


@pytest.mark.parametrize(
    ("settings", "changed_default", "rows"),
    [
        ("ReachSettings", {"grasp_tries": 5}, ["reach", "reach_carry_frame", "reach_place_frame"]),
        ("RetrySettings", {"steps": 30}, ["retry"]),
    ],
)
def test_a_changed_default_of_a_generic_strategy_redoes_its_rows_only(
    settings: str, changed_default: dict, rows: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """reach's and retry's defaults are chosen on validation scenes too: a changed one redoes the rows of
    its mode only (reach's carry rows too; each its test row and its validation run for the row
    "chosen")."""
    cfg = parse_config(["--task=pick-place-v3", "--preset=metaworld", "--output_dir=/studies/pp"])
    classes = {"ReachSettings": ReachSettings, "RetrySettings": RetrySettings}

    before = stage_fingerprints(cfg)
    monkeypatch.setattr(stages_module, settings, functools.partial(classes[settings], **changed_default))
    after = stage_fingerprints(cfg)
    changed = sorted(name for name in before if before[name] != after[name])
    assert changed == sorted(f"{stage}_bvmc_fc1_{row}" for stage in ("choice", "eval") for row in rows)


def test_a_continuous_gripper_study_retrains_from_the_same_demos(monkeypatch: pytest.MonkeyPatch) -> None:
    """`--train.policy.gripper_head=continuous` reaches both trainings, which redo (and all after them),
    while the demos stay collected; left out, the studies begun before keep every fingerprint (above)."""
    monkeypatch.setattr(stages_module, "cpu_has_native_bf16", lambda: True)
    args = LITE_PICK_PLACE_ARGS
    cfg = parse_config([*args, "--train.policy.gripper_head=continuous"])
    trainings = [stage for stage in build_stages(cfg) if stage.name.startswith("train_")]
    assert all("--policy.gripper_head=continuous" in stage.argv for stage in trainings)
    found = stage_fingerprints(cfg)
    assert found["collect"] == LITE_PICK_PLACE["collect"]
    assert not [
        name for name in LITE_PICK_PLACE if name != "collect" and found[name] == LITE_PICK_PLACE[name]
    ]


def test_a_time_conditioned_threshold_redoes_the_threshold_and_what_reads_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`--threshold.score=time_conditioned` reaches the threshold stage alone; the trainings, foresight and
    VMC's row stay done, and every BVMC row (whose trigger reads the threshold) is redone."""
    monkeypatch.setattr(stages_module, "cpu_has_native_bf16", lambda: True)
    found: dict[str, str] = {}
    for stage in build_stages(parse_config([*LITE_PICK_PLACE_ARGS, "--threshold.score=time_conditioned"])):
        found[stage.name] = fingerprint(stage, found)
        assert ("--score=time_conditioned" in stage.argv) == stage.name.startswith("threshold"), stage.name
    changed = sorted(name for name in LITE_PICK_PLACE if found[name] != LITE_PICK_PLACE[name])
    assert changed == sorted(
        name for name in LITE_PICK_PLACE if name.startswith(("threshold", "eval_bvmc", "detect"))
    )


def test_a_study_without_vmc_is_the_whole_study_less_vmc_s_stages(monkeypatch: pytest.MonkeyPatch) -> None:
    """`--train.vmc=false` drops VMC's training, check and row, of every training seed, and leaves each
    other stage as the whole study has it: adding VMC later redoes nothing done without it."""
    monkeypatch.setattr(stages_module, "cpu_has_native_bf16", lambda: True)
    args = [*LITE_PICK_PLACE_ARGS, "--train.extra_seeds=[2000]"]
    whole = stage_fingerprints(parse_config(args))
    without = stage_fingerprints(parse_config([*args, "--train.vmc=false"]))
    vmc = [name for name in whole if name.startswith(("train_vmc", "check_vmc", "eval_vmc"))]
    assert len(vmc) == 6
    assert without == {name: found for name, found in whole.items() if name not in vmc}


def test_reach_s_push_leaves_the_recorded_reach_rows_fingerprints() -> None:
    """reach's push came after the MetaWorld studies' reach rows ran: its fields at their defaults are not
    among the settings those rows' fingerprints hold (a push row's argv holds its own flag)."""
    recorded = [
        "belief",
        "belief_steps",
        "grasp",
        "grasp_tries",
        "hover",
        "search_radius",
        "settle_steps",
        "steps",
    ]
    assert sorted(stages_module.strategy_settings("reach", None)["reach"]) == recorded


def test_demos_acting_on_once_done_are_collected_again_and_everything_after() -> None:
    """`--collect.expert_after_success=act` (MetaWorld's scripted policy acting on once done) reaches the
    collector and redoes every stage; the held default adds no flag (the studies above keep theirs)."""
    args = ["--task=door-open-v3", "--preset=metaworld", "--output_dir=/studies/door", "--train.vmc=false"]
    held, acting = (
        {s.name: s for s in build_stages(parse_config(a))}
        for a in (args, [*args, "--collect.expert_after_success=act"])
    )
    assert "--expert_after_success=act" in acting["collect"].argv
    assert not any("expert_after_success" in arg for arg in held["collect"].argv)
    found_held: dict[str, str] = {}
    found_acting: dict[str, str] = {}
    for name in held:
        found_held[name] = fingerprint(held[name], found_held)
        found_acting[name] = fingerprint(acting[name], found_acting)
        assert found_held[name] != found_acting[name], name
