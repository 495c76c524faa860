"""A MetaWorld task's study through `lerobot-ivmc-pipeline`: its stages, and the smoke preset end to end."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from lerobot_ivmc.pipeline.stages import build_stages
from lerobot_ivmc.scripts.lerobot_ivmc_pipeline import main as pipeline_main
from lerobot_ivmc.scripts.lerobot_ivmc_pipeline import parse_config

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

TASK = "drawer-open-v3"


def test_a_metaworld_study_runs_its_stages_on_meta_world_without_the_fetch_only_ones(tmp_path: Path) -> None:
    cfg = parse_config([f"--task={TASK}", "--preset=metaworld", f"--output_dir={tmp_path}"])
    stages = {stage.name: stage for stage in build_stages(cfg)}
    assert not [name for name in stages if name.startswith("check_")]  # the Fetch perception check
    assert not [name for name in stages if name.endswith("_anchor")]
    collect = stages["collect"].argv
    assert f"--env.task={TASK}" in collect and "--env.render_style=flat" in collect
    assert "--action_noise=0.1" in collect and not [a for a in collect if "episode_steps" in a]
    for name in ("foresight_fc1", "threshold_fc1", "eval_bvmc_fc1_min_unc", "eval_vmc_fc1"):
        assert (
            "--env.type=meta_world" in stages[name].argv and "--env.episode_length=300" in stages[name].argv
        )
    assert "--foresight.ranking_states=0" in stages["foresight_fc1"].argv


def test_a_metaworld_study_refuses_the_anchor_row_and_the_fetch_demo_lengths_are_not_imposed(
    capsys: pytest.CaptureFixture,
) -> None:
    def refusal(*args: str) -> str:
        with pytest.raises(SystemExit) as ended:
            pipeline_main([f"--task={TASK}", "--preset=metaworld", *args])
        assert ended.value.code == 2, args
        return capsys.readouterr().err.strip().splitlines()[-1]

    assert "anchor is a planner for the Fetch tasks" in refusal("--recovery_modes=[none,anchor]")
    assert "anchor is a planner for the Fetch tasks" in refusal("--recovery_modes=[none,anchor_control]")
    assert "chunk_length" in refusal("--train.policy.chunk_length=400")
    cfg = parse_config(
        [
            f"--task={TASK}",
            "--preset=metaworld",
            "--collect.dataset.episode_steps=250",
            "--train.policy.chunk_length=250",
        ]
    )
    assert cfg.collect.dataset.episode_steps == 250


@pytest.mark.long
def test_the_metaworld_smoke_study_runs_end_to_end(tmp_path: Path) -> None:
    script = Path(sys.executable).with_name("lerobot-ivmc-pipeline")
    out = tmp_path / "study"
    result = subprocess.run(
        [str(script), "--task=pick-place-v3", "--preset=metaworld_smoke", f"--output_dir={out}"],
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    results = json.loads((out / "results" / "pick-place-v3.json").read_text())
    assert results["complete"]
    assert [row["method"] for row in results["rows"]] == [
        "vmc",
        "none",
        "rand",
        "init",
        "min_unc",
        "retry",
        "reach",
        "reach_carry_frame",
        "chosen",
    ]
    assert all(list(row["subtasks"]) == ["success"] for row in results["rows"])
    # The row "chosen" is the test row of the candidate that rescued most on validation scenes.
    chosen = results["rows"][-1]
    assert list(chosen["choice"]["validation"]) == ["init", "retry", "reach_carry_frame"]
    source = next(row for row in results["rows"] if row["method"] == chosen["choice"]["chosen_mode"])
    assert chosen["subtasks"] == source["subtasks"] and chosen["rescue"] == source["rescue"]
    assert (out / "choice" / "fc1" / "retry" / "eval_info.json").exists()
    record = out / "threshold" / "fc1" / "pretrained_model" / "recovery_threshold.json"
    assert json.loads(record.read_text())["task"] == "pick-place-v3"
    assert (out / "results" / "fig3_fc1.png").exists()
