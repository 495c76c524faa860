"""`lerobot-ivmc-pipeline`: presets and overrides, bad input, and the smoke study end to end."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from lerobot_ivmc.hardware import cpu_has_native_bf16
from lerobot_ivmc.pipeline.stages import build_stages
from lerobot_ivmc.pipeline.study import parse_config
from lerobot_ivmc.recovery.threshold import argmax_threshold
from lerobot_ivmc.scripts.lerobot_ivmc_pipeline import main as pipeline_main

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

ROWS = ["vmc", "none", "rand", "init", "min_unc", "anchor"]


def pipeline(*args: str) -> subprocess.CompletedProcess:
    script = Path(sys.executable).with_name("lerobot-ivmc-pipeline")
    return subprocess.run([str(script), *args], capture_output=True, text=True, timeout=1200)


def test_presets_load_and_any_field_can_be_overridden(tmp_path: Path) -> None:
    cfg = parse_config(
        ["--task=pick_reach", "--preset=lite", f"--output_dir={tmp_path}", "--train.steps=123"]
    )
    assert (cfg.task, cfg.preset, cfg.train.steps) == ("pick_reach", "lite", 123)
    assert cfg.collect.dataset.num_episodes == 2000 and cfg.train.num_fc_layers == [1, 2]
    paper = parse_config(["--task=push", "--preset", "paper", "--foresight.foresight.num_trajectories=7"])
    assert paper.collect.dataset.num_episodes == 4000 and paper.fig3.n_episodes == 800
    assert paper.foresight.foresight.num_trajectories == 7
    assert paper.root == Path("outputs/pipeline/push_paper")
    stages = {s.name: s for s in build_stages(cfg)}
    assert "--steps=123" in stages["train_bvmc_fc2"].argv
    # lite's Fig. 3 reuses the BVMC test episodes; paper's has a stage of its own with 800 episodes.
    assert (
        "fig3_fc1" not in stages
        and "--eval_dir=" + str(stages["eval_bvmc_fc1_none"].output) in stages["detect_fc1"].argv
    )
    # A killed training continues from its last checkpoint with LeRobot's resume.
    train = stages["train_vmc_fc1"]
    assert train.resume_argv == [
        "lerobot-ivmc-train",
        f"--config_path={train.output}/checkpoints/last/pretrained_model/train_config.json",
        "--resume=true",
    ]
    assert train.resume_marker == train.output / "checkpoints/last/pretrained_model/train_config.json"
    # bf16 only where the CPU runs it natively (elsewhere it is emulated, and slower than fp32).
    bf16 = "bf16" if cpu_has_native_bf16() else "no"
    assert train.env == {"ACCELERATE_MIXED_PRECISION": bf16}
    # Each training is checked right after it: did the policy learn where the object is? Main-seed policies
    # stop the study above the limit; nothing reads the check, so its settings change no other stage.
    names = [s.name for s in build_stages(cfg)]
    assert names[1:5] == ["train_vmc_fc1", "check_vmc_fc1", "train_bvmc_fc1", "check_bvmc_fc1"]
    check_stage = stages["check_bvmc_fc1"]
    assert check_stage.depends == ["train_bvmc_fc1"]
    assert (
        f"--policy.path={stages['train_bvmc_fc1'].output}/checkpoints/last/pretrained_model"
        in check_stage.argv
    )
    assert {"--env.split=val", "--n_scenes=20", "--steps=30", "--max_object_error_cm=5.0"} <= set(
        check_stage.argv
    )
    assert not any(check_stage.name in s.depends for s in stages.values())
    paper_stages = {s.name: s for s in build_stages(paper)}
    assert "--eval.n_episodes=800" in paper_stages["fig3_fc2"].argv
    # Widened min_unc candidates reach the distillation; at 0 (the paper's samples) the flag is left out, so
    # studies started before the option keep their fingerprints.
    assert not any("action_noise" in a for a in stages["foresight_fc1"].argv)
    widened = parse_config(["--task=push", "--preset=lite", "--foresight.foresight.action_noise=0.3"])
    assert "--foresight.action_noise=0.3" in {s.name: s for s in build_stages(widened)}["foresight_fc1"].argv
    # The policies' augmentation and chunk memory: left out unless set (the policy's defaults apply, and the
    # training's settings, part of its fingerprint, hold their values).
    left_out = ("image_shift_pad", "chunk_memory")
    assert not any(f in a for a in train.argv for f in left_out)
    assert (train.settings["image_shift_pad"], train.settings["chunk_memory"]) == (4, "stored")
    # lite trains with the frame position head at the studies' 3e-4; paper with the paper's network.
    assert {"--policy.frame_position_head=true", "--policy.optimizer_lr=0.0003"} <= set(train.argv)
    assert {"--policy.frame_position_head=false", "--policy.optimizer_lr=0.0003"} <= set(
        paper_stages["train_vmc_fc1"].argv
    )
    assert train.settings["num_fc_layers"] == 1 and stages["train_bvmc_fc2"].settings["num_fc_layers"] == 2
    assert stages["train_bvmc_fc1"].settings["num_samples"] == 50  # bvmc's own fields too
    tuned = parse_config(
        [
            "--task=push",
            "--preset=lite",
            "--train.policy.image_shift_pad=0",
            "--train.policy.optimizer_lr=1e-4",
            "--train.policy.chunk_memory=zero",
            "--train.policy.frame_position_head=true",
        ]
    )
    for stage in build_stages(tuned):
        if stage.name.startswith("train_"):
            assert {
                "--policy.image_shift_pad=0",
                "--policy.optimizer_lr=0.0001",
                "--policy.chunk_memory=zero",
                "--policy.frame_position_head=true",
            } <= set(stage.argv)
    # Longer demos reach the collector, with whole-demo chunks to match; 100-step studies keep their commands.
    assert not any("episode_steps" in a for a in stages["collect"].argv)
    longer = parse_config(
        [
            "--task=push",
            "--preset=lite",
            "--collect.dataset.episode_steps=150",
            "--train.policy.chunk_length=150",
        ]
    )
    longer_stages = {s.name: s for s in build_stages(longer)}
    assert "--dataset.episode_steps=150" in longer_stages["collect"].argv
    assert "--policy.chunk_length=150" in longer_stages["train_bvmc_fc1"].argv


def test_extra_training_seeds_add_stages_and_leave_the_study_s_own_untouched(tmp_path: Path) -> None:
    base = ["--task=pick_place", "--preset=lite", f"--output_dir={tmp_path}"]
    # The main seed's stages are the same commands, so adding a seed to a study reruns none of them.
    two_fc = {s.name: s.argv for s in build_stages(parse_config([*base, "--train.num_fc_layers=[1,2]"]))}
    two_fc_seeded = build_stages(
        parse_config([*base, "--train.num_fc_layers=[1,2]", "--train.extra_seeds=[9]"])
    )
    assert {s.name: s.argv for s in two_fc_seeded if "_seed9" not in s.name} == two_fc
    base.append("--train.num_fc_layers=[1]")
    plain = build_stages(parse_config(base))
    seeded = build_stages(parse_config([*base, "--train.extra_seeds=[2000]"]))
    assert [(s.name, s.argv) for s in seeded[: len(plain)]] == [(s.name, s.argv) for s in plain]
    extra = {s.name: s for s in seeded[len(plain) :]}
    # Every training seed gets the whole chain: its own foresight head, threshold and recovery rows.
    assert list(extra) == [
        "train_vmc_fc1_seed2000",
        "check_vmc_fc1_seed2000",
        "train_bvmc_fc1_seed2000",
        "check_bvmc_fc1_seed2000",
        "foresight_fc1_seed2000",
        "threshold_fc1_seed2000",
        "eval_vmc_fc1_seed2000",
        "eval_bvmc_fc1_none_seed2000",
        "eval_bvmc_fc1_rand_seed2000",
        "eval_bvmc_fc1_init_seed2000",
        "eval_bvmc_fc1_min_unc_seed2000",
        "eval_bvmc_fc1_anchor_seed2000",
        "eval_bvmc_fc1_anchor_control_seed2000",
        "eval_bvmc_fc1_retry_seed2000",
        "eval_bvmc_fc1_reach_carry_seed2000",
        "eval_bvmc_fc1_reach_place_seed2000",
        "eval_bvmc_fc1_reach_carry_frame_seed2000",
        "eval_bvmc_fc1_reach_place_frame_seed2000",
        "choice_bvmc_fc1_rand_seed2000",
        "choice_bvmc_fc1_init_seed2000",
        "choice_bvmc_fc1_min_unc_seed2000",
        "choice_bvmc_fc1_retry_seed2000",
        "choice_bvmc_fc1_reach_carry_seed2000",
        "choice_bvmc_fc1_reach_place_seed2000",
        "choice_bvmc_fc1_reach_carry_frame_seed2000",
        "choice_bvmc_fc1_reach_place_frame_seed2000",
        "detect_fc1_seed2000",
    ]
    # An extra seed's policies are checked and reported, never stop the study.
    assert {"--max_object_error_cm=5.0", "--fail_above_limit=false"} <= set(
        extra["check_bvmc_fc1_seed2000"].argv
    )
    train = extra["train_bvmc_fc1_seed2000"]
    assert "--seed=2000" in train.argv and "--seed=1000" not in train.argv
    assert train.output == tmp_path.resolve() / "train" / "bvmc_fc1_seed2000"
    assert (
        f"--policy.path={train.output}/checkpoints/last/pretrained_model"
        in extra["foresight_fc1_seed2000"].argv
    )
    evaluation = extra["eval_bvmc_fc1_min_unc_seed2000"]

    # Evaluated like the Table I rows (same test scenes), with its own seed's threshold checkpoint.
    def scenes(argv: list[str]) -> list[str]:
        return [a for a in argv if a.startswith(("--seed=", "--eval.", "--env."))]

    main_row = {s.name: s for s in plain}["eval_bvmc_fc1_min_unc"]
    assert scenes(evaluation.argv) == scenes(main_row.argv)
    assert "--env.split=test" in scenes(evaluation.argv) and "--recovery.mode=min_unc" in evaluation.argv
    assert evaluation.depends == ["threshold_fc1_seed2000"]
    threshold = tmp_path.resolve() / "threshold" / "fc1_seed2000" / "pretrained_model"
    assert f"--policy.path={threshold}" in evaluation.argv
    assert extra["detect_fc1_seed2000"].depends == ["eval_bvmc_fc1_none_seed2000", "threshold_fc1_seed2000"]
    # anchor's control row: anchor's own command on the same scenes, with the trigger's threshold at 0.
    anchor, control = extra["eval_bvmc_fc1_anchor_seed2000"], extra["eval_bvmc_fc1_anchor_control_seed2000"]
    assert "--recovery.mode=anchor" in control.argv and "--recovery.mode=anchor_control" not in control.argv
    assert set(control.argv) - set(anchor.argv) == {
        "--recovery.threshold=0",
        f"--output_dir={tmp_path.resolve()}/eval/bvmc_fc1_anchor_control_seed2000",
    }
    assert control.settings == anchor.settings and control.depends == anchor.depends


def test_bad_input_is_refused_with_what_to_do(capsys: pytest.CaptureFixture) -> None:
    presets = r"\['lite', 'metaworld', 'metaworld_smoke', 'paper', 'smoke'\]"
    with pytest.raises(ValueError, match=rf"Unknown preset 'huge'.*{presets}"):
        parse_config(["--task=push", "--preset=huge"])
    with pytest.raises(ValueError, match="Give the task"):
        parse_config(["--preset=smoke"])
    with pytest.raises(SystemExit):
        parse_config(["--task=push", "--preset=smoke", "--train.stepz=5"])
    assert "--train.stepz" in capsys.readouterr().err
    # The console command ends each in one line with exit status 2 (run in this process but the first).
    bad_task = pipeline("--task=stack", "--preset=smoke")
    assert bad_task.returncode == 2 and "Unknown task 'stack'" in bad_task.stderr

    def refusal(*args: str) -> str:
        with pytest.raises(SystemExit) as ended:
            pipeline_main(list(args))
        assert ended.value.code == 2, args
        return capsys.readouterr().err

    assert "num_fc_layers" in refusal("--task=push", "--preset=smoke", "--train.num_fc_layers=[3]")
    for seeds in ("[1000]", "[5,5]"):  # the main seed again, or a seed twice: the same policies twice
        same_seed = refusal("--task=push", "--preset=smoke", f"--train.extra_seeds={seeds}")
        assert "--train.extra_seeds must differ" in same_seed
    negative = refusal("--task=push", "--preset=smoke", "--train.extra_seeds=[-1]")
    assert "Training seeds must be in" in negative
    negative_limit = refusal("--task=push", "--preset=smoke", "--perception.max_object_error_cm=-1")
    assert "max_object_error_cm must be >= 0" in negative_limit
    no_plain_bvmc = refusal(
        "--task=push", "--preset=smoke", "--train.extra_seeds=[7]", "--recovery_modes=[min_unc]"
    )
    assert "needs 'none' in --recovery_modes" in no_plain_bvmc
    knows_task = refusal("--task=push", "--preset=lite", "--recovery_choice=[retry,anchor]")
    assert "--recovery_choice chooses among distinct modes that know no task" in knows_task
    no_row = refusal("--task=push", "--preset=lite", "--recovery_choice=[retry,reach]")
    assert "add ['reach'] to --recovery_modes" in no_row
    no_goal_head = refusal("--task=push", "--preset=lite", "--train.policy.goal_head=false")
    assert "the rows ['anchor', 'anchor_control']" in no_goal_head
    # Values a late stage would refuse are refused before the study starts (not hours in).
    for override, message in (
        ("--threshold.method=conformall", "--threshold.method must be one of ('argmax', 'conformal')"),
        ("--threshold.alpha=1", "--threshold.alpha must be in (0, 1)"),
        ("--train.policy.training_mode=chunks", "--train.policy.training_mode must be one of"),
        ("--train.policy.chunk_length=101", "--train.policy.chunk_length must be in [1, 100]"),
        ("--train.policy.chunk_length=50", "needs whole demos: --train.policy.chunk_length=100"),
        ("--collect.dataset.episode_steps=250", "--collect.dataset.episode_steps must be in [100, 200]"),
        (
            "--collect.dataset.episode_steps=150",
            "--train.policy.chunk_length=150 (--collect.dataset.episode_steps)",
        ),
        ("--train.policy.image_shift_pad=-2", "image_shift_pad must be >= 0"),
        ("--train.policy.chunk_memory=carried", "--train.policy.chunk_memory must be one of"),
        ("--train.batch_size=0", "--train.batch_size must be positive"),
        ("--eval.batch_size=0", "--eval.batch_size must be positive"),
        ("--threshold.n_episodes=1", "--threshold.batch_size=2 is more than --threshold.n_episodes=1"),
        ("--eval.n_episodes=1", "--eval.batch_size=2 is more than --eval.n_episodes=1"),
        ("--fig3.n_episodes=1", "--fig3.batch_size=2 is more than --fig3.n_episodes=1"),
        ("--episode_length=0", "--episode_length must be positive"),
        ("--perception.steps=40", "--perception.steps=40 is longer than an episode (--episode_length=30)"),
        ("--threshold.method=conformal", "needs at least 9 successful validation episodes"),
        # Set by the study itself: an override would be ignored.
        ("--collect.env.task=pick_place", "differs from --task='push'"),
        ("--collect.dataset.root=/tmp/demos", "--collect.dataset.root is set by the study"),
        # Where the stages run.
        ("--executor.type=dask", "--executor.type must be one of ('local', 'ray')"),
        ("--executor.address=auto", "set the Ray cluster: add --executor.type=ray"),
        ("--executor.train_gpus=2", "--executor.train_gpus is the share of one GPU"),
        ("--train.device=tpu", "--train.device must be one of ('auto', 'cpu', 'cuda')"),
        ("--random_streams=scene", "--random_streams must be one of ('batch', 'episode')"),
    ):
        with pytest.raises(Exception) as refused:
            parse_config(["--task=push", "--preset=smoke", override])
        assert message in str(refused.value.__cause__ or refused.value), override


def run_until_stage_starts(stage: str, *args: str) -> None:
    """Run the pipeline and SIGKILL it (and its stage) as soon as `stage` starts."""
    script = Path(sys.executable).with_name("lerobot-ivmc-pipeline")
    out = Path(next(a for a in args if a.startswith("--output_dir=")).split("=", 1)[1])
    process = subprocess.Popen(
        [str(script), *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )
    record = out / "stages" / f"{stage}.json"
    deadline = time.monotonic() + 1200
    while not record.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=60)
    assert record.exists(), f"the study ended before {stage} started"


@pytest.mark.long
def test_smoke_study_runs_end_to_end_then_resumes_without_rerunning(tmp_path: Path) -> None:
    out = tmp_path / "push_smoke"
    # A study of #fc = 1 and 2 stopped as #fc = 2 starts keeps the finished #fc = 1 results.
    run_until_stage_starts(
        "train_vmc_fc2", "--task=push", "--preset=smoke", f"--output_dir={out}", "--train.num_fc_layers=[1,2]"
    )
    partial = json.loads((out / "results" / "push.json").read_text())
    assert partial["complete"] is False and {r["num_fc_layers"] for r in partial["rows"]} == {1}
    assert "#fc = 2 not finished yet" in (out / "results" / "table.md").read_text()

    # The #fc = 1 study in the same folder: every stage is done already.
    first = pipeline("--task=push", "--preset=smoke", f"--output_dir={out}")
    assert first.returncode == 0, first.stdout[-3000:] + first.stderr[-3000:]
    assert "running" not in first.stdout
    results = json.loads((out / "results" / "push.json").read_text())
    assert results["complete"] is True and results["rows"] == partial["rows"]
    assert [(r["num_fc_layers"], r["method"]) for r in results["rows"]] == [(1, m) for m in ROWS]
    for row in results["rows"]:
        assert set(row["subtasks"]) == {"reach", "push"}
        # Paired task outcomes on the same scenes against VMC and BVMC (each row against the others).
        others = {"vs_vmc", "vs_none"} - {f"vs_{row['method']}"}
        assert set(row["paired"]) == others
        for pair in row["paired"].values():
            counts = [pair[k] for k in ("both", "only_first", "only_second", "neither")]
            assert pair["milestone"] == "push" and sum(counts) == pair["episodes"] == 4
            assert 0 <= pair["mcnemar_exact_p"] <= 1
        assert all(
            v["n"] == 4 and 0 <= v["rate"] <= 100 and v["stderr"] >= 0 for v in row["subtasks"].values()
        )
    assert (out / "results" / "fig3_fc1.png").stat().st_size > 0
    assert results["per_fc"]["1"]["fig3"]["episodes"] == 4
    assert "auroc" in results["per_fc"]["1"]["detection"]
    # The threshold travels with its validation episodes, so a reader can re-pick it by program.
    threshold = results["per_fc"]["1"]["threshold"]
    assert threshold["method"] == "argmax" and threshold["split"] == "val"
    picked, _ = argmax_threshold(
        [e["u"] for e in threshold["episodes"]], [e["success"] for e in threshold["episodes"]]
    )
    assert picked == threshold["threshold"]
    table = (out / "results" / "table.md").read_text()
    assert all(
        label in table
        for label in ("| VMC |", "| BVMC |", "BVMC + rand", "BVMC + init", "BVMC + min unc", "vs BVMC")
    )
    assert set(results["stage_wall_s"]) >= {"collect", "train_vmc_fc1", "threshold_fc1", "detect_fc1"}
    # Each policy's perception check is reported (smoke only reports: 4-step policies never learn it).
    assert [(r["model"], r["train_seed"], r["passed"]) for r in results["perception"]] == [
        ("VMC", 1000, None),
        ("BVMC", 1000, None),
    ]
    for row in results["perception"]:
        assert row["scenes"] == 2 and row["split"] == "val" and row["max_object_error_cm"] == 0
        assert row["acting"]["object_cm"] > 0 and len(row["acting"]["per_scene_object_cm"]) == 2
    assert "Perception check" in table
    assert first.stdout.count("done earlier") == len(results["stage_wall_s"]), first.stdout

    before = sorted((p, p.stat().st_mtime_ns) for p in out.rglob("*"))
    other = pipeline("--task=pick_place", "--preset=smoke", f"--output_dir={out}")
    assert other.returncode == 2 and "holds the study" in other.stderr
    assert sorted((p, p.stat().st_mtime_ns) for p in out.rglob("*")) == before, "the folder is left untouched"

    # A dry run says what adding a second training seed would run, and runs nothing.
    dry = pipeline(
        "--task=push", "--preset=smoke", f"--output_dir={out}", "--train.extra_seeds=[7]", "--dry_run=true"
    )
    assert dry.returncode == 0, dry.stdout[-3000:] + dry.stderr[-3000:]
    total = len(results["stage_wall_s"]) + 13
    assert f"13 of {total} stages would run" in dry.stdout and dry.stdout.count(": new") == 13, dry.stdout
    assert sorted((p, p.stat().st_mtime_ns) for p in out.rglob("*")) == before, "the folder is left untouched"

    # A second training seed added to the finished study trains and evaluates only its own policies.
    seeded = pipeline("--task=push", "--preset=smoke", f"--output_dir={out}", "--train.extra_seeds=[7]")
    assert seeded.returncode == 0, seeded.stdout[-3000:] + seeded.stderr[-3000:]
    assert seeded.stdout.count("done earlier") == len(results["stage_wall_s"]), seeded.stdout
    assert seeded.stdout.count(": running") == 13, seeded.stdout  # its whole chain
    with_seed = json.loads((out / "results" / "push.json").read_text())
    assert with_seed["complete"] is True and with_seed["rows"] == results["rows"]
    # What another study's seeds must share to be pooled with these (`lerobot-ivmc-pool-seeds`).
    assert with_seed["setup"]["test_scenes"] == {
        "split": "test",
        "seed": 0,
        "n_episodes": 4,
        "episode_length": 30,
    }
    spread = with_seed["training_seeds"]
    assert [(r["model"], r["train_seed"]) for r in spread["rows"]] == [
        ("VMC", 1000),
        ("VMC", 7),
        ("BVMC", 1000),
        ("BVMC", 7),
    ]
    # The main seed's rows are the Table I rows themselves (VMC, and BVMC without recovery).
    assert spread["rows"][0]["subtasks"] == results["rows"][0]["subtasks"]
    assert spread["rows"][2]["subtasks"] == results["rows"][1]["subtasks"]

    def method(row: dict) -> str:
        return row.get("method", "vmc" if row["model"] == "VMC" else "none")

    assert [entry["method"] for entry in spread["summary"]] == ROWS
    for entry in spread["summary"]:
        rates = [
            r["subtasks"]["push"]["rate"]
            for r in spread["rows"] + spread["recovery_rows"]
            if (method(r), r["num_fc_layers"]) == (entry["method"], entry["num_fc_layers"])
        ]
        assert entry["train_seeds"] == [1000, 7] and entry["subtasks"]["push"]["rates"] == rates
        assert entry["subtasks"]["push"]["mean"] == pytest.approx(sum(rates) / 2)
        assert entry["subtasks"]["push"]["std"] == pytest.approx(abs(rates[0] - rates[1]) / 2**0.5)
    assert "mean +- sd over 2 seeds" in (out / "results" / "table.md").read_text()
    # Each recovery row per seed, with its rescue against that seed's own BVMC, and pooled over the seeds.
    assert [(r["method"], r["train_seed"]) for r in spread["recovery_rows"]] == [
        (mode, seed) for mode in ("rand", "init", "min_unc", "anchor") for seed in (1000, 7)
    ]
    main_rescue = {r["method"]: r["rescue"] for r in with_seed["rows"] if "rescue" in r}
    for pooled in spread["pooled_rescue"]:
        per_seed = [r["rescue"] for r in spread["recovery_rows"] if r["method"] == pooled["method"]]
        assert per_seed[0] == main_rescue[pooled["method"]]
        assert pooled["train_seeds"] == [1000, 7]
        assert pooled["failures"] == sum(r["failures"] for r in per_seed)
        assert pooled["rescued"] - pooled["lost"] == sum(r["rescued"] - r["lost"] for r in per_seed)
        assert 0 <= pooled["exact_p"] <= 1
    assert [(r["model"], r["train_seed"]) for r in with_seed["perception"]] == [
        ("VMC", 1000),
        ("VMC", 7),
        ("BVMC", 1000),
        ("BVMC", 7),
    ]

    # A limit the policies miss stops the study at the first check, before anything after it runs; the
    # finished stages stay, and going back reruns only that check.
    strict = pipeline(
        "--task=push", "--preset=smoke", f"--output_dir={out}", "--perception.max_object_error_cm=0.01"
    )
    assert strict.returncode == 1, strict.stdout[-3000:] + strict.stderr[-3000:]
    assert (
        "Stage check_vmc_fc1 failed" in strict.stderr and "did not learn where the object is" in strict.stderr
    )
    assert strict.stdout.count(": running") == 1 and "check_bvmc_fc1" not in strict.stdout, strict.stdout
    assert json.loads((out / "results" / "push.json").read_text()) == with_seed
    again = pipeline(
        "--task=push", "--preset=smoke", f"--output_dir={out}", "--perception.max_object_error_cm=0.01"
    )
    assert again.returncode == 1 and "Stage check_vmc_fc1 failed" in again.stderr, "a failed check is redone"
    back = pipeline("--task=push", "--preset=smoke", f"--output_dir={out}", "--train.extra_seeds=[7]")
    assert back.returncode == 0, back.stdout[-3000:] + back.stderr[-3000:]
    assert back.stdout.count(": running") == 1 and "check_vmc_fc1: running" in back.stdout, back.stdout

    # The same study without VMC (`--train.vmc=false`): BVMC's stages are the whole study's, so nothing
    # runs, and the results hold BVMC's rows alone, as they were.
    bvmc_only = pipeline(
        "--task=push", "--preset=smoke", f"--output_dir={out}", "--train.extra_seeds=[7]", "--train.vmc=false"
    )
    assert bvmc_only.returncode == 0, bvmc_only.stdout[-3000:] + bvmc_only.stderr[-3000:]
    assert ": running" not in bvmc_only.stdout and "train_vmc" not in bvmc_only.stdout, bvmc_only.stdout
    without_vmc = json.loads((out / "results" / "push.json").read_text())
    assert [r["method"] for r in without_vmc["rows"]] == ROWS[1:]
    assert all(set(r["paired"]) <= {"vs_none"} for r in without_vmc["rows"])
    assert without_vmc["training_seeds"]["pooled_rescue"] == spread["pooled_rescue"]
    assert [r["model"] for r in without_vmc["perception"]] == ["BVMC", "BVMC"]
    assert "| VMC |" not in (out / "results" / "table.md").read_text()
