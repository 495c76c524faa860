"""End to end through the real CLIs: lerobot-ivmc-foresight, lerobot-ivmc-threshold and
lerobot-ivmc-eval with each recovery mode, on a tiny trained bvmc in the real env."""

from __future__ import annotations

import json
import re
import shutil
import sys
from pathlib import Path
from unittest import mock

import av
import numpy as np
import pytest
import torch
from helpers.clis import ENV_FLAGS, EPISODE_LENGTH, run_main

from lerobot_ivmc.evaluation.detection_report import DetectionConfig, detect
from lerobot_ivmc.evaluation.traces import load_traces
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.recovery.threshold import THRESHOLD_FILE, ThresholdRecord, argmax_threshold
from lerobot_ivmc.recovery.time_baseline import baseline_digest, episode_score, normalized_sums

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow


def evaluate(checkpoint: Path, out: Path, *flags: str, n_episodes: int = 2, batch_size: int = 2) -> dict:
    return run_main(
        "lerobot-ivmc-eval",
        f"--policy.path={checkpoint}",
        *ENV_FLAGS,
        f"--eval.n_episodes={n_episodes}",
        f"--eval.batch_size={batch_size}",
        "--seed=0",
        f"--output_dir={out}",
        *flags,
    )


def test_foresight_head_lives_in_a_new_checkpoint_and_round_trips(
    tiny_bvmc: Path, tiny_foresight: Path, tmp_path
):
    checkpoint = tiny_foresight / "pretrained_model"
    policy = BVMCPolicy.from_pretrained(checkpoint)
    assert policy.config.foresight_enabled and policy.foresight is not None
    policy.save_pretrained(tmp_path / "again")
    again = BVMCPolicy.from_pretrained(tmp_path / "again")
    for name, tensor in policy.foresight.state_dict().items():
        assert torch.equal(tensor, again.foresight.state_dict()[name])
    # The checkpoint it read is untouched: no head there.
    assert BVMCPolicy.from_pretrained(tiny_bvmc).foresight is None
    report = json.loads((checkpoint / "foresight_report.json").read_text())
    assert {"spearman_rho", "r2", "r2_log"} <= set(report["heldout"])
    assert report["action_ranking"]["num_states"] == 2
    assert (checkpoint / "policy_preprocessor.json").exists()


def test_distillation_resumes_a_killed_collection_without_duplicates(
    tiny_bvmc: Path, tiny_foresight, tmp_path
):
    out = tmp_path / "resumed"
    shutil.copytree(tiny_foresight / "distillation", out / "distillation")
    (out / "distillation" / "shard_00001.npz").unlink()  # as if killed while recording batch 1
    run_main(
        "lerobot-ivmc-foresight",
        f"--policy.path={tiny_bvmc}",
        *ENV_FLAGS,
        "--foresight.num_trajectories=4",
        "--foresight.epochs=2",
        "--foresight.ranking_states=0",
        "--eval.batch_size=2",
        "--eval.n_episodes=2",
        "--seed=0",
        f"--output_dir={out}",
    )
    for name in ("shard_00000.npz", "shard_00001.npz"):
        with np.load(tiny_foresight / "distillation" / name) as a, np.load(out / "distillation" / name) as b:
            for key in a.files:
                np.testing.assert_array_equal(a[key], b[key])
    # Other settings on the same folder are refused before anything is written.
    other = tmp_path / "other_settings"
    shutil.copytree(out / "distillation", other / "distillation")
    with pytest.raises(ValueError, match="other settings"):
        run_main(
            "lerobot-ivmc-foresight",
            f"--policy.path={tiny_bvmc}",
            *ENV_FLAGS,
            "--foresight.num_trajectories=6",
            "--eval.batch_size=2",
            "--eval.n_episodes=2",
            "--seed=0",
            f"--output_dir={other}",
        )
    assert not (other / "pretrained_model").exists()


def test_threshold_is_the_argmax_of_the_validation_episodes(
    tiny_foresight: Path, tiny_recovery_checkpoint: Path
):
    record = ThresholdRecord.load(tiny_recovery_checkpoint)
    assert record.task == "pick_place" and record.split == "val" and len(record.episodes) == 4
    expected, _ = argmax_threshold([e["u"] for e in record.episodes], [e["success"] for e in record.episodes])
    assert record.threshold == expected
    assert not (tiny_foresight / "pretrained_model" / THRESHOLD_FILE).exists()  # input untouched


@pytest.mark.parametrize("variant", ["none", "rand", "init", "min_unc", "anchor", "anchor_frame"])
def test_each_mode_runs_end_to_end(variant: str, tiny_recovery_checkpoint: Path, tmp_path: Path) -> None:
    """Every mode on a trained tiny bvmc in the real env; anchor also as pick_reach runs it (a look, the
    object and the goal read by the frame position head)."""
    out = tmp_path / variant
    mode = variant.removesuffix("_frame")
    flags = [f"--recovery.mode={mode}", "--recovery.max_videos=1"]
    flags.append("--recovery.anchor.steps=5" if mode == "anchor" else "--recovery.recovery_steps=5")
    if variant == "anchor_frame":
        flags += [
            "--recovery.anchor.look_steps=2",
            "--recovery.anchor.object=frame",
            "--recovery.anchor.goal=frame",
        ]
    if mode != "none":  # a zero threshold and short interval make sure recoveries happen in 30 steps
        flags += ["--recovery.threshold=0.0", "--recovery.initial_interval=2"]
    evaluate(tiny_recovery_checkpoint, out, *flags)
    info = json.loads((out / "eval_info.json").read_text())
    assert info["recovery"]["mode"] == mode
    episodes = info["per_episode"]
    assert len(episodes) == 2 and all("max_uncertainty" in e and "subtasks" in e for e in episodes)
    traces = load_traces(out / "uncertainty_traces.npz")
    assert [len(t["uncertainty"]) for t in traces] == [EPISODE_LENGTH] * 2  # tiny policy: no success
    assert (out / "uncertainty_vs_success.png").stat().st_size > 0
    if mode == "none":
        assert (
            info["recovery"]["num_recoveries"] == 0
            and info["recovery"]["threshold_source"] == "checkpoint (argmax)"
        )
    else:
        assert info["recovery"]["num_recoveries"] > 0
        assert all(event["mode"] == mode for e in episodes for event in e["recoveries"])
        settings = info["recovery"]["settings"]  # as they acted: anchor's resolved for pick_place's cube
        if mode == "anchor":
            frame = variant == "anchor_frame"
            expected = ("frame", "frame") if frame else ("memory", "memory")
            anchor = settings["anchor"]
            assert (anchor["object"], anchor["goal"]) == expected
            assert anchor["release"] is True and anchor["look_steps"] == (2 if frame else 0)
            assert any("look_steps" in event for e in episodes for event in e["recoveries"]) is frame
        videos = list((out / "recovery_videos").glob("*.mp4"))
        assert len(videos) == 1
        # One frame per step: the 64-px camera image the policy acted on, enlarged 4x, above the trace.
        with av.open(str(videos[0])) as container:
            frames = [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]
        assert len(frames) == EPISODE_LENGTH
        assert frames[0].shape[1] == 256 and frames[0].shape[0] > 256


@pytest.mark.parametrize("mode", ["none", "min_unc"])
def test_async_envs_give_the_same_episodes_as_one_process(
    mode: str, tiny_recovery_checkpoint: Path, tmp_path: Path
) -> None:
    flags = [f"--recovery.mode={mode}", "--recovery.max_videos=1", "--max_episodes_rendered=0"]
    if mode != "none":
        flags += ["--recovery.threshold=0.0", "--recovery.initial_interval=2", "--recovery.recovery_steps=5"]
    for name, use_async in (("sync", "false"), ("async", "true")):
        evaluate(tiny_recovery_checkpoint, tmp_path / name, *flags, f"--eval.use_async_envs={use_async}")
    sync, async_ = (json.loads((tmp_path / n / "eval_info.json").read_text()) for n in ("sync", "async"))
    for key in ("max_uncertainty", "recoveries", "subtasks", "sum_reward", "success", "seed"):
        assert [e[key] for e in sync["per_episode"]] == [e[key] for e in async_["per_episode"]]
    traces = (load_traces(tmp_path / n / "uncertainty_traces.npz") for n in ("sync", "async"))
    for x, y in zip(*traces, strict=True):
        np.testing.assert_array_equal(x["window_sum"], y["window_sum"])
    videos = [sorted(p.name for p in (tmp_path / n).rglob("*.mp4")) for n in ("sync", "async")]
    assert videos[0] == videos[1] == (["episode_0000.mp4"] if mode != "none" else [])


def test_same_seed_gives_identical_results(tiny_recovery_checkpoint: Path, tmp_path: Path) -> None:
    flags = ["--recovery.mode=min_unc", "--recovery.threshold=0.0", "--recovery.initial_interval=2"]
    flags += ["--recovery.max_videos=0"]
    for name in ("a", "b"):
        evaluate(tiny_recovery_checkpoint, tmp_path / name, *flags)
    a, b = (json.loads((tmp_path / n / "eval_info.json").read_text()) for n in "ab")
    for key in ("max_uncertainty", "recoveries", "subtasks", "sum_reward", "success"):
        assert [e[key] for e in a["per_episode"]] == [e[key] for e in b["per_episode"]]
    for x, y in zip(*(load_traces(tmp_path / n / "uncertainty_traces.npz") for n in "ab"), strict=True):
        np.testing.assert_array_equal(x["uncertainty"], y["uncertainty"])


def test_episode_streams_make_an_episode_independent_of_its_batch(
    tiny_recovery_checkpoint: Path, tmp_path: Path
) -> None:
    """With `--recovery.random_streams=episode` each scene's Monte Carlo samples are its own: the same
    episodes one at a time and two to a batch give the same uncertainties (the default draws a batch's masks
    together, so they differ)."""

    def traces(name: str, batch_size: int, streams: str) -> list[np.ndarray]:
        out = tmp_path / name
        flags = [f"--recovery.random_streams={streams}", "--recovery.max_videos=0"]
        evaluate(tiny_recovery_checkpoint, out, *flags, batch_size=batch_size)
        return [t["uncertainty"] for t in load_traces(out / "uncertainty_traces.npz")]

    for a, b in zip(traces("one", 1, "episode"), traces("two", 2, "episode"), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-5)
    one, two = traces("one_batch", 1, "batch"), traces("two_batch", 2, "batch")
    assert not np.allclose(one[1], two[1], rtol=1e-5)


def test_with_episode_streams_a_recovery_row_acts_as_the_row_without_it_until_it_recovers(
    tiny_recovery_checkpoint: Path, tmp_path: Path
) -> None:
    """The rescued / lost counts compare a recovery row with BVMC alone on the same scenes: with episode
    streams both draw the same samples in every batch until the recovery's first step."""
    common = ["--recovery.max_videos=0", "--max_episodes_rendered=0", "--recovery.random_streams=episode"]
    evaluate(tiny_recovery_checkpoint, tmp_path / "none", *common, n_episodes=4)
    recovery = ["--recovery.mode=rand", "--recovery.threshold=0.0", "--recovery.initial_interval=5"]
    recovery.append("--recovery.recovery_steps=5")
    evaluate(tiny_recovery_checkpoint, tmp_path / "rand", *common, *recovery, n_episodes=4)
    alone, recovered = (load_traces(tmp_path / n / "uncertainty_traces.npz") for n in ("none", "rand"))
    assert len(alone) == len(recovered) == 4
    for a, r in zip(alone, recovered, strict=True):
        first = int(np.flatnonzero(r["phase"] != 0)[0])  # the step its first recovery began
        np.testing.assert_array_equal(a["uncertainty"][: first + 1], r["uncertainty"][: first + 1])
        assert not np.array_equal(a["uncertainty"], r["uncertainty"])


def test_a_head_distilled_on_widened_actions_makes_min_unc_widen_its_candidates(
    tiny_bvmc: Path, tiny_recovery_checkpoint: Path, tmp_path: Path
) -> None:
    out = tmp_path / "noisy"
    flags = [
        f"--policy.path={tiny_bvmc}",
        *ENV_FLAGS,
        "--foresight.num_trajectories=2",
        "--foresight.epochs=1",
        "--foresight.ranking_states=1",
        "--foresight.ranking_every=5",
        "--eval.batch_size=2",
        "--eval.n_episodes=2",
        "--seed=0",
    ]
    report = run_main("lerobot-ivmc-foresight", *flags, "--foresight.action_noise=0.3", f"--output_dir={out}")
    assert report["spec"]["action_noise"] == 0.3 and report["action_ranking"]["candidate_noise"] == 0.3
    checkpoint = out / "pretrained_model"
    assert BVMCPolicy.from_pretrained(checkpoint).config.foresight_action_noise == 0.3
    # The executed actions were widened: the recorded ones scatter far more than the plain samples do.
    noisy = np.load(out / "distillation" / "shard_00000.npz")["action"][:, :3]
    plain = np.load(tiny_bvmc.parents[3] / "foresight" / "distillation" / "shard_00000.npz")["action"][:, :3]
    assert np.abs(np.diff(noisy, axis=0)).mean() > 2 * np.abs(np.diff(plain, axis=0)).mean()
    threshold = ThresholdRecord.load(tiny_recovery_checkpoint).threshold
    info = evaluate(
        checkpoint, tmp_path / "eval", "--recovery.mode=min_unc", f"--recovery.threshold={threshold}"
    )
    assert info["recovery"]["candidate_noise"] == 0.3
    # A resume with another noise would mix two kinds of records: refused, the shards left as they were.
    shutil.rmtree(checkpoint)
    before = sorted(p.name for p in (out / "distillation").iterdir())
    for other in ("0.1", "0.0"):
        with pytest.raises(ValueError, match="other settings.*'action_noise'"):
            run_main(
                "lerobot-ivmc-foresight", *flags, f"--foresight.action_noise={other}", f"--output_dir={out}"
            )
    assert sorted(p.name for p in (out / "distillation").iterdir()) == before
    # A head saved before the option existed (no `foresight_action_noise` in its config) ranks plain samples.
    older = tmp_path / "older"
    shutil.copytree(tiny_recovery_checkpoint, older)
    config = json.loads((older / "config.json").read_text())
    del config["foresight_action_noise"]
    (older / "config.json").write_text(json.dumps(config))
    info = evaluate(older, tmp_path / "older_eval", "--recovery.mode=min_unc")
    assert info["recovery"]["candidate_noise"] == 0.0


def test_a_deadline_read_from_the_threshold_record_fires_where_the_score_never_does(
    tiny_recovery_checkpoint: Path, tmp_path: Path
) -> None:
    """`--recovery.deadline=auto` takes the record's deadline (the longest validation success + 1); the
    tiny policy never succeeds, so its own record holds none and auto is refused; a copy given one fires
    retries at it, each event naming its cause."""
    record = ThresholdRecord.load(tiny_recovery_checkpoint)
    assert record.deadline is None  # no validation episode succeeded
    flags = ["--recovery.mode=retry", "--recovery.threshold=1e9", "--recovery.deadline=auto"]
    with pytest.raises(ValueError, match="holds none"):
        evaluate(tiny_recovery_checkpoint, tmp_path / "refused", *flags)
    given = tmp_path / "with_deadline"
    shutil.copytree(tiny_recovery_checkpoint, given)
    payload = json.loads((given / THRESHOLD_FILE).read_text()) | {"deadline": 12}
    (given / THRESHOLD_FILE).write_text(json.dumps(payload))
    info = evaluate(given, tmp_path / "auto", *flags, "--recovery.initial_interval=0")
    assert info["recovery"]["settings"]["deadline"] == 12
    assert info["recovery"]["deadline_source"].startswith("checkpoint")
    events = [event for e in info["per_episode"] for event in e["recoveries"]]
    assert events and all(event["cause"] == "deadline" for event in events)
    assert min(event["step"] for event in events) == 11  # the twelfth step of the policy


def test_bad_requests_say_what_to_do(
    tiny_bvmc: Path, tiny_foresight: Path, tiny_recovery_checkpoint, tmp_path
):
    cases = [
        (tiny_bvmc, ["--recovery.mode=min_unc", "--recovery.threshold=0.1"], "lerobot-ivmc-foresight"),
        (tiny_foresight / "pretrained_model", ["--recovery.mode=rand"], "lerobot-ivmc-threshold"),
        (
            tiny_recovery_checkpoint,
            ["--recovery.mode=rand", "--env.task=push"],
            "picked on task 'pick_place'",
        ),
        (tiny_recovery_checkpoint, ["--env.image_size=32"], "pass --env.image_size=64"),
    ]
    vmc = tmp_path / "vmc"
    shutil.copytree(tiny_bvmc, vmc)
    config = json.loads((vmc / "config.json").read_text())
    bvmc_only = ("dropout_init", "dropout_temperature", "length_scale", "dataset_size", "mc_sampling")
    bvmc_only += ("num_samples", "uncertainty_lambda", "foresight_enabled", "foresight_hidden_dim")
    bvmc_only += ("foresight_action_noise",)
    config = {k: v for k, v in config.items() if k not in bvmc_only} | {"type": "vmc"}
    (vmc / "config.json").write_text(json.dumps(config))
    cases.append((vmc, ["--recovery.mode=init", "--recovery.threshold=0.1"], "needs a bvmc checkpoint"))
    for i, (checkpoint, flags, message) in enumerate(cases):
        with pytest.raises(ValueError, match=re.escape(message)):
            evaluate(checkpoint, tmp_path / f"bad{i}", *flags)
        assert not (tmp_path / f"bad{i}" / "eval_info.json").exists()


def test_cli_ends_with_a_one_line_message(tiny_recovery_checkpoint: Path, tmp_path: Path, capsys) -> None:
    from lerobot_ivmc.scripts.lerobot_ivmc_eval import main

    argv = ["lerobot-ivmc-eval", f"--policy.path={tiny_recovery_checkpoint}", *ENV_FLAGS]
    argv += ["--recovery.mode=pray", "--seed=0", f"--output_dir={tmp_path}"]
    with mock.patch.object(sys, "argv", argv), pytest.raises(SystemExit) as exit_info:
        main()
    assert exit_info.value.code == 2
    last_line = capsys.readouterr().err.strip().splitlines()[-1]
    assert last_line.startswith(
        "error: --recovery.mode must be one of "
        "('none', 'rand', 'init', 'min_unc', 'anchor', 'retry', 'reach')"
    )


def test_threshold_method_round_trips_into_checkpoint_and_eval(
    tiny_recovery_checkpoint: Path, tmp_path: Path
):
    # The tiny policy never succeeds: a conformal threshold (calibrated on successes) is refused clearly.
    with pytest.raises(ValueError, match="needs at least 1 successful calibration episodes; got 0"):
        run_main(
            "lerobot-ivmc-threshold",
            f"--policy.path={tiny_recovery_checkpoint}",
            *ENV_FLAGS,
            "--env.split=val",
            "--eval.n_episodes=2",
            "--eval.batch_size=2",
            "--seed=0",
            "--method=conformal",
            "--alpha=0.5",
            f"--output_dir={tmp_path / 'conformal'}",
        )
    assert not (tmp_path / "conformal" / "pretrained_model").exists()
    checkpoint = tmp_path / "checkpoint"
    shutil.copytree(tiny_recovery_checkpoint, checkpoint)
    record = ThresholdRecord.load(checkpoint)
    ThresholdRecord(**{**record.__dict__, "method": "conformal", "alpha": 0.5}).save(checkpoint)
    info = evaluate(checkpoint, tmp_path / "eval", "--recovery.mode=rand", "--recovery.max_videos=0")
    assert info["recovery"]["threshold_source"] == "checkpoint (conformal, alpha=0.5)"
    assert info["recovery"]["threshold"] == record.threshold


def test_a_foresight_head_does_not_change_the_rollout(tiny_bvmc: Path, tiny_foresight: Path, tmp_path: Path):
    """Without recovery, the checkpoint with the head acts exactly as the one it was distilled from."""
    flags = ["--recovery.mode=none"]
    a = evaluate(tiny_bvmc, tmp_path / "without", *flags)
    b = evaluate(tiny_foresight / "pretrained_model", tmp_path / "with", *flags)
    assert [e["max_uncertainty"] for e in a["per_episode"]] == [
        e["max_uncertainty"] for e in b["per_episode"]
    ]


def test_detect_refuses_in_sample_runs_and_bounds_outside_zero_one(tiny_recovery_checkpoint: Path, tmp_path):
    record = ThresholdRecord.load(tiny_recovery_checkpoint)
    seeds = [e["seed"] for e in record.episodes]
    info = {
        "run": {"task": record.task, "split": record.split, "policy_path": str(tiny_recovery_checkpoint)},
        "recovery": {"mode": "none"},
        "per_episode": [{"seed": s, "max_uncertainty": 1.0, "success": True} for s in seeds],
    }
    (tmp_path / "eval_info.json").write_text(json.dumps(info))
    with pytest.raises(ValueError, match="metrics would be in-sample"):
        detect(DetectionConfig(eval_dir=tmp_path))
    with pytest.raises(ValueError, match=r"--alpha and --alphas are false-alarm bounds in \(0, 1\)"):
        detect(DetectionConfig(eval_dir=tmp_path, alpha=1.5))


def test_a_time_conditioned_threshold_drives_the_trigger_the_scores_and_detection(
    tiny_recovery_checkpoint: Path, tmp_path: Path
) -> None:
    """A record with a baseline: the trigger fires at the first step whose window sum over the baseline
    exceeds C, u is the time-conditioned score, and a run scored the paper's way is refused by detect."""
    common = ["--recovery.max_videos=0", "--max_episodes_rendered=0", "--recovery.random_streams=episode"]
    evaluate(tiny_recovery_checkpoint, tmp_path / "none", *common, n_episodes=4)
    alone = load_traces(tmp_path / "none" / "uncertainty_traces.npz")
    record = ThresholdRecord.load(tiny_recovery_checkpoint)
    # A baseline that rises along the episode: the same window sum scores less later on.
    baseline = np.median(np.concatenate([a["window_sum"] for a in alone])) * np.linspace(
        0.5, 1.5, EPISODE_LENGTH
    )
    checkpoint = tmp_path / "checkpoint"
    shutil.copytree(tiny_recovery_checkpoint, checkpoint)
    fields = {**record.__dict__, "threshold": 1.0, "baseline": baseline.tolist(), "baseline_quantile": 0.5}
    ThresholdRecord(**fields).save(checkpoint)
    recovery = ["--recovery.mode=rand", "--recovery.initial_interval=5", "--recovery.recovery_steps=5"]
    info = evaluate(checkpoint, tmp_path / "rand", *common, *recovery, n_episodes=4)
    assert info["recovery"]["threshold_source"] == "checkpoint (argmax), time-conditioned (quantile 0.5)"
    assert info["recovery"]["baseline_digest"] == baseline_digest(baseline)
    recovered = load_traces(tmp_path / "rand" / "uncertainty_traces.npz")
    fired = 0
    for a, r, episode in zip(alone, recovered, info["per_episode"], strict=True):
        scores = normalized_sums(a["window_sum"], baseline, record.window)
        above = [t for t in np.flatnonzero(scores > 1.0) if t > 5]
        steps = [event["step"] for event in episode["recoveries"]]
        assert steps[:1] == above[:1]  # the same episode until then: the same first firing step
        fired += bool(steps)
        assert episode["max_uncertainty"] == pytest.approx(
            episode_score(r["uncertainty"], record.window, baseline)
        )
    assert fired > 0
    with pytest.raises(ValueError, match="scored its episodes by the window-sum score"):
        detect(DetectionConfig(eval_dir=tmp_path / "none", threshold_path=checkpoint))


def test_auto_keeps_the_window_sum_where_too_few_validation_episodes_succeed(
    tiny_recovery_checkpoint: Path, tmp_path: Path
) -> None:
    """The tiny policy never succeeds: `--score=auto` keeps the paper's window sum and says why in the record;
    `--score=time_conditioned` is refused in one line."""
    flags = [*ENV_FLAGS, "--env.split=val", "--eval.n_episodes=2", "--eval.batch_size=2", "--seed=0"]
    run_main(
        "lerobot-ivmc-threshold",
        f"--policy.path={tiny_recovery_checkpoint}",
        *flags,
        "--score=auto",
        f"--output_dir={tmp_path / 'auto'}",
    )
    record = ThresholdRecord.load(tmp_path / "auto" / "pretrained_model")
    assert record.baseline is None and record.score_auroc == {"window_sum": None, "time_conditioned": None}
    with pytest.raises(ValueError, match="needs 5 successful validation episodes in each half"):
        run_main(
            "lerobot-ivmc-threshold",
            f"--policy.path={tiny_recovery_checkpoint}",
            *flags,
            "--score=time_conditioned",
            f"--output_dir={tmp_path / 'time'}",
        )
    assert not (tmp_path / "time" / "pretrained_model").exists()
