"""`lerobot-ivmc-collect`: LeRobot loads the datasets, replay is exact, kills resume, push is LeRobot's."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
import torch
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from lerobot_ivmc.datasets import (
    ACTION_KEY,
    ENV_STATE_KEY,
    IMAGE_KEY,
    SCENE_OBJECT_CELL_KEY,
    SCENE_SEED_KEY,
    SCENE_TARGET_CELL_KEY,
    STATE_KEY,
    demo_features,
    expert_attempts,
    staging,
)
from lerobot_ivmc.datasets.collect import CollectConfig, collect_demos, push_dataset
from lerobot_ivmc.datasets.collect_root import resume_hint
from lerobot_ivmc.datasets.collection_record import dataset_render_style
from lerobot_ivmc.datasets.staging import CollectionError
from lerobot_ivmc.envs import DEMO_EPISODE_STEPS, TASK_ENVS, TASKS, make_task_env
from lerobot_ivmc.envs.scenes import Scene
from lerobot_ivmc.scripts.lerobot_ivmc_collect import main, parse_config

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

IMAGE_SIZE = 32


def _config(root: Path, **overrides) -> CollectConfig:
    kwargs = {"task": "push", "num_episodes": 2, "image_size": IMAGE_SIZE, "num_workers": 0}
    return CollectConfig(root=root, **{**kwargs, "progress": False, **overrides})


def _episode_arrays(dataset: LeRobotDataset, episode_index: int) -> dict[str, np.ndarray]:
    """All frames of one episode as numpy arrays (images back in uint8 HWC)."""
    episode = dataset.meta.episodes[episode_index]
    frames = [dataset[i] for i in range(episode["dataset_from_index"], episode["dataset_to_index"])]
    arrays = {key: np.stack([frame[key].numpy() for frame in frames]) for key in frames[0] if key != "task"}
    arrays[IMAGE_KEY] = np.round(arrays[IMAGE_KEY].transpose(0, 2, 3, 1) * 255).astype(np.uint8)
    arrays["task"] = [frame["task"] for frame in frames]
    return arrays


@pytest.fixture(scope="module", params=TASKS)
def collected(request, tmp_path_factory) -> CollectConfig:
    """Three demos per task, recorded in-process at 32x32."""
    root = tmp_path_factory.mktemp("demos") / f"ivmc_{request.param}"
    cfg = _config(root, task=request.param, num_episodes=3)
    summary = collect_demos(cfg)
    assert summary.num_episodes == 3 and summary.num_frames == 3 * DEMO_EPISODE_STEPS
    return cfg


def test_dataset_loads_with_lerobot_and_follows_the_spec(collected):
    dataset = LeRobotDataset(collected.repo_id, root=collected.root)
    assert dataset.fps == 25
    assert dataset.num_episodes == 3 and dataset.num_frames == 3 * DEMO_EPISODE_STEPS
    assert list(dataset.meta.episodes["length"]) == [DEMO_EPISODE_STEPS] * 3
    for key, feature in demo_features(IMAGE_SIZE, use_video=False).items():
        stored = dataset.meta.features[key]
        assert (stored["dtype"], tuple(stored["shape"]), stored["names"]) == (
            feature["dtype"],
            feature["shape"],
            feature["names"],
        )
    frame = dataset[0]
    assert frame[IMAGE_KEY].shape == (3, IMAGE_SIZE, IMAGE_SIZE)
    assert frame[STATE_KEY].shape == (9,) and frame[ENV_STATE_KEY].shape == (6,)
    assert frame[ACTION_KEY].shape == (4,)
    # LeRobot stores shape-(1,) features as scalar columns: they load as 0-d tensors.
    assert frame[SCENE_SEED_KEY].ndim == 0 and frame[SCENE_SEED_KEY].dtype == torch.int64
    assert frame["task"] == TASK_ENVS[collected.task].task_description
    assert set(dataset.meta.stats) >= {IMAGE_KEY, STATE_KEY, ACTION_KEY}  # LeRobot's normalisation stats
    assert not (collected.root / staging.WORK_DIR).exists() and not (collected.root / "images").exists()


def test_episodes_come_from_their_split_and_replay_open_loop(collected):
    dataset = LeRobotDataset(collected.repo_id, root=collected.root)
    train = make_task_env(collected.task, image_size=IMAGE_SIZE, split="train", terminate_on_success=False)
    held_out = {s for split in ("val", "test") for s in make_task_env(collected.task, split=split).scenes}
    seeds = []
    for episode_index in range(dataset.num_episodes):
        recorded = _episode_arrays(dataset, episode_index)
        assert (np.diff(recorded["frame_index"]) == 1).all() and recorded["frame_index"][0] == 0
        seed = int(recorded[SCENE_SEED_KEY][0])
        assert (recorded[SCENE_SEED_KEY] == seed).all()
        seeds.append(seed)
        scene = Scene(int(recorded[SCENE_OBJECT_CELL_KEY][0]), int(recorded[SCENE_TARGET_CELL_KEY][0]))
        assert scene in train.scenes and scene not in held_out

        # Frame t holds the observation action t was chosen from: replaying the actions reproduces them.
        observation, _ = train.reset(seed=seed)
        assert Scene(train.scene.object_cell, train.scene.target_cell) == scene
        for t in range(DEMO_EPISODE_STEPS):
            np.testing.assert_allclose(recorded[STATE_KEY][t], observation["agent_pos"], atol=1e-6)
            np.testing.assert_allclose(
                recorded[ENV_STATE_KEY][t], observation["environment_state"], atol=1e-6
            )
            np.testing.assert_array_equal(recorded[IMAGE_KEY][t], observation["pixels"]["front"])
            observation, _, _, _, info = train.step(recorded[ACTION_KEY][t])
        assert info["is_success"]
        assert set(np.unique(recorded[ACTION_KEY][:, 3])) <= {-1.0, 0.0, 1.0}
    assert len(set(seeds)) == len(seeds)
    train.close()


def test_noisy_demos_label_the_expert_action_and_record_the_noisy_states(tmp_path):
    """DART: the robot executes label + noise; replaying exactly that reproduces the recorded states."""
    for name in ("noisy", "clean", "again"):
        (tmp_path / name).mkdir()
    recorder = expert_attempts.Recorder(
        "pick_place", IMAGE_SIZE, "train", 0, tmp_path / "noisy", action_noise=0.15
    )
    clean = expert_attempts.Recorder("pick_place", IMAGE_SIZE, "train", 0, tmp_path / "clean")
    assert recorder.record(0) == (0, True) and clean.record(0) == (0, True)
    noisy = staging.read_episode(staging.attempt_path(tmp_path / "noisy", 0, "npz"))
    plain = staging.read_episode(staging.attempt_path(tmp_path / "clean", 0, "npz"))
    assert noisy.scene_seed == plain.scene_seed
    assert np.abs(noisy.state - plain.state).max() > 1e-3  # the noise moved the robot

    noise = expert_attempts.ActionNoise(0.15, noisy.scene_seed)
    env = make_task_env("pick_place", image_size=IMAGE_SIZE, terminate_on_success=False)
    observation, _ = env.reset(seed=noisy.scene_seed)
    for t in range(DEMO_EPISODE_STEPS):
        np.testing.assert_allclose(noisy.state[t], observation["agent_pos"], atol=1e-6)
        assert np.abs(noisy.action[t, :3]).max() <= 0.6 + 1e-6  # the expert's speed limit, no noise on top
        observation, _, _, _, info = env.step(noise(noisy.action[t]))
    assert info["is_success"]
    env.close()
    recorder.close()
    clean.close()

    again = expert_attempts.Recorder(
        "pick_place", IMAGE_SIZE, "train", 0, tmp_path / "again", action_noise=0.15
    )
    again.record(0)
    repeat = staging.read_episode(staging.attempt_path(tmp_path / "again", 0, "npz"))
    np.testing.assert_array_equal(repeat.state, noisy.state)
    again.close()


def test_longer_demos_hold_the_final_pose_to_the_last_frame(tmp_path, capsys):
    """`--dataset.episode_steps=150`: every demo lasts 150 frames, the task still done on the last one, the
    expert's labels after its last waypoint steering back against the noise (no drift labelled still)."""
    root = tmp_path / "long"
    assert (
        main(
            [
                "--env.task=pick_reach",
                "--env.image_size=32",
                "--dataset.num_episodes=2",
                "--dataset.episode_steps=150",
                f"--dataset.root={root}",
                "--num_workers=0",
                "--action_noise=0.15",
                "--progress=false",
            ]
        )
        == 0
    )
    dataset = LeRobotDataset("local/ivmc_pick_reach", root=root)
    assert dataset.meta.total_frames == 2 * 150 and list(dataset.meta.episodes["length"]) == [150, 150]
    for episode in range(2):
        arrays = _episode_arrays(dataset, episode)
        late = arrays[ACTION_KEY][DEMO_EPISODE_STEPS:, :3]
        assert np.abs(late).max() > 0, "the noise is corrected after the demo's usual end"
        ee = arrays[ENV_STATE_KEY][:, :3]
        # Held: the last 50 frames stay within a few cm of where frame 100 was.
        assert np.linalg.norm(ee[DEMO_EPISODE_STEPS:] - ee[DEMO_EPISODE_STEPS], axis=1).max() < 0.05
    for bad in (99, 201):
        with pytest.raises(ValueError, match=r"episode_steps must be in \[100, 200\]"):
            _config(tmp_path / "bad", episode_steps=bad)


def test_noisy_demos_of_the_expert_before_the_hold_are_kept_apart(tmp_path):
    """A noisy dataset (or unfinished collection) recorded before the expert held its final pose is never
    extended with demos of the new expert; the refusal says why and what to do."""
    cfg = _config(tmp_path / "noisy", action_noise=0.1, num_episodes=1)
    collect_demos(cfg)
    info_path = cfg.root / staging.COLLECTION_INFO_PATH
    info = staging.read_json(info_path)
    del info["spec"]["expert_after_last_waypoint"]  # as the expert of before the hold wrote it
    staging.write_json(info_path, info)
    with pytest.raises(ValueError, match="recorded before the expert held its final pose.*--dataset.root"):
        collect_demos(cfg)
    old_spec = {**cfg.spec(), "episode_steps": 150}
    del old_spec["expert_after_last_waypoint"]
    hint = resume_hint(cfg, old_spec)
    assert "no command of this version records" in hint and str(cfg.root / staging.WORK_DIR) in hint
    assert "--dataset.episode_steps=150" in resume_hint(cfg, {**cfg.spec(), "episode_steps": 150})


@pytest.mark.parametrize("action_noise", [-0.1, 1.5])
def test_action_noise_outside_its_range_is_refused(tmp_path, action_noise):
    with pytest.raises(ValueError, match="action_noise"):
        _config(tmp_path / "data", action_noise=action_noise)


def test_the_dataset_records_its_render_style(collected, tmp_path):
    assert dataset_render_style(collected.root) == collected.render_style == "fast"
    # The Fetch XML's look keeps the spec of the datasets made before render styles, and reads back as it.
    legacy = _config(tmp_path / "legacy", task=collected.task, num_episodes=1, render_style="fetch")
    assert "render_style" not in legacy.spec()
    collect_demos(legacy)
    assert dataset_render_style(legacy.root) == "fetch"
    fetch_frames = _episode_arrays(LeRobotDataset(legacy.repo_id, root=legacy.root), 0)[IMAGE_KEY]
    fast_frames = _episode_arrays(LeRobotDataset(collected.repo_id, root=collected.root), 0)[IMAGE_KEY]
    assert not np.array_equal(fetch_frames, fast_frames[: len(fetch_frames)]), "the style changes the frames"


def test_same_arguments_reuse_a_finished_dataset(collected):
    data_file = next((collected.root / "data").rglob("*.parquet"))
    mtime = data_file.stat().st_mtime_ns
    summary = collect_demos(collected)
    assert summary.already_complete and summary.num_episodes == 3
    assert data_file.stat().st_mtime_ns == mtime


def test_another_spec_is_refused_and_nothing_is_touched(collected):
    before = sorted(p.relative_to(collected.root) for p in collected.root.rglob("*"))
    other_task = next(task for task in TASKS if task != collected.task)
    cases = [
        (_config(collected.root, task=other_task, num_episodes=3), "task"),
        (_config(collected.root, task=collected.task, num_episodes=3, image_size=48), "feature"),
        (_config(collected.root, task=collected.task, num_episodes=3, video=True), "feature"),
        (_config(collected.root, task=collected.task, num_episodes=3, split="val"), "split"),
        (_config(collected.root, task=collected.task, num_episodes=3, render_style="fetch"), "render_style"),
        (_config(collected.root, task=collected.task, num_episodes=3, action_noise=0.1), "action_noise"),
        (_config(collected.root, task=collected.task, num_episodes=3, episode_steps=150), "episode_steps"),
        (_config(collected.root, task=collected.task, num_episodes=5), "already holds 3"),
    ]
    for cfg, message in cases:
        with pytest.raises(ValueError, match=message):
            collect_demos(cfg)
    assert sorted(p.relative_to(collected.root) for p in collected.root.rglob("*")) == before


@pytest.mark.parametrize("num_episodes", [0, -3])
def test_non_positive_episode_count_is_refused(tmp_path, num_episodes, capsys):
    with pytest.raises(ValueError, match="num_episodes"):
        _config(tmp_path / "ds", num_episodes=num_episodes)
    with pytest.raises(SystemExit) as exit_info:
        main(
            ["--env.task=push", f"--dataset.num_episodes={num_episodes}", f"--dataset.root={tmp_path / 'ds'}"]
        )
    assert exit_info.value.code == 2 and "num_episodes" in capsys.readouterr().err
    assert not (tmp_path / "ds").exists()


def test_foreign_folders_are_refused(tmp_path):
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    with pytest.raises(ValueError, match="not empty"):
        collect_demos(_config(foreign))
    assert (foreign / "notes.txt").read_text() == "keep me"

    unfinished = tmp_path / "unfinished"
    (unfinished / staging.WORK_DIR).mkdir(parents=True)
    staging.write_json(unfinished / staging.WORK_DIR / staging.SPEC_FILE, _config(unfinished).spec())
    with pytest.raises(ValueError, match="unfinished collection of another spec.*task: stored 'push'"):
        collect_demos(_config(unfinished, task="pick_place"))


def test_push_to_hub_uses_lerobot_push(tmp_path):
    root = tmp_path / "ivmc_push"
    with pytest.raises(ValueError, match="hub repo id"):
        _config(root, push_to_hub=True)
    collect_demos(_config(root, num_episodes=1))
    with (
        mock.patch("lerobot.datasets.lerobot_dataset.HfApi") as hf_api,
        mock.patch("lerobot.datasets.lerobot_dataset.create_lerobot_dataset_card") as make_card,
    ):
        argv = ["--env.task=push", "--dataset.num_episodes=1", f"--dataset.root={root}"]
        argv += [f"--env.image_size={IMAGE_SIZE}", "--dataset.repo_id=someone/ivmc_push"]
        assert main([*argv, "--dataset.push_to_hub=true", "--progress=false"]) == 0
    api = hf_api.return_value
    api.create_repo.assert_called_once_with(
        repo_id="someone/ivmc_push", private=False, repo_type="dataset", exist_ok=True
    )
    upload = api.upload_folder.call_args.kwargs
    assert upload["repo_id"] == "someone/ivmc_push" and upload["repo_type"] == "dataset"
    assert Path(upload["folder_path"]) == root and "images/" in upload["ignore_patterns"]
    assert make_card.call_args.kwargs["dataset_info"]["total_episodes"] == 1
    make_card.return_value.push_to_hub.assert_called_once()
    api.create_tag.assert_called_once()


@pytest.mark.filterwarnings("ignore:The video decoding and encoding capabilities of torchvision")
def test_video_storage(tmp_path):
    cfg = _config(tmp_path / "video", num_episodes=1, video=True)
    collect_demos(cfg)
    dataset = LeRobotDataset(cfg.repo_id, root=cfg.root, video_backend="pyav")
    assert dataset.meta.features[IMAGE_KEY]["dtype"] == "video"
    assert dataset[DEMO_EPISODE_STEPS - 1][IMAGE_KEY].shape == (3, IMAGE_SIZE, IMAGE_SIZE)


def _staged(root: Path) -> int:
    episodes = root / staging.WORK_DIR / staging.EPISODES_DIR
    return len(list(episodes.glob("*.npz"))) if episodes.exists() else 0


def _start(args: list[str]) -> subprocess.Popen:
    # Its own session, so a signal reaches the collector and its workers together, as Ctrl-C or a
    # job kill would. SIGINT restored to its default: a test run launched as a background job of a
    # non-interactive shell inherits SIGINT ignored, and the collector would then never see the Ctrl-C.
    cmd = [sys.executable, "-m", "lerobot_ivmc.scripts.lerobot_ivmc_collect", *args]
    return subprocess.Popen(
        cmd,
        start_new_session=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _interrupt_when(process: subprocess.Popen, ready, sig: signal.Signals, timeout: float = 120) -> int:
    deadline = time.monotonic() + timeout
    while not ready() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert process.poll() is None, f"finished before the interruption: {process.communicate()[0].decode()}"
    os.killpg(process.pid, sig)
    return process.wait(timeout=60)


def test_killed_collection_resumes_to_exactly_n_episodes(tmp_path):
    # n leaves room for a late first kill on a busy machine: the resumed run must still have episodes to
    # record when it is interrupted.
    root, n = tmp_path / "ivmc_push", 8
    args = ["--env.task=push", f"--dataset.num_episodes={n}", f"--dataset.root={root}"]
    args += [f"--env.image_size={IMAGE_SIZE}", "--num_workers=2", "--seed=7", "--progress=false"]

    # SIGKILL mid-collection: workers die mid-episode, LeRobot's parquet writers are never closed.
    assert _interrupt_when(_start(args), lambda: _staged(root) >= 2, signal.SIGKILL) == -signal.SIGKILL
    assert not (root / "meta").exists() and (root / staging.WORK_DIR / staging.BUILD_DIR).exists()
    # Ctrl-C of the resumed run once it has staged more: a clean stop, resumable too.
    staged = _staged(root)
    assert staged + 1 < n, f"the first run was killed too late ({staged} of {n} staged)"
    assert _interrupt_when(_start(args), lambda: _staged(root) >= staged + 1, signal.SIGINT) == 130
    finished = subprocess.run(
        [sys.executable, "-m", "lerobot_ivmc.scripts.lerobot_ivmc_collect", *args],
        capture_output=True,
        text=True,
    )
    assert finished.returncode == 0, finished.stdout + finished.stderr

    dataset = LeRobotDataset("local/ivmc_push", root=root)
    assert dataset.num_episodes == n and dataset.num_frames == n * DEMO_EPISODE_STEPS
    assert sorted(dataset.hf_dataset.unique("episode_index")) == list(range(n))
    assert list(dataset.meta.episodes["length"]) == [DEMO_EPISODE_STEPS] * n
    assert not (root / staging.WORK_DIR).exists()

    # Exactly the episodes an uninterrupted collection with the same arguments gives.
    reference = _config(tmp_path / "reference", num_episodes=n, seed=7)
    assert collect_demos(reference).episode_seeds == [
        ep["scene_seed"] for ep in staging.read_json(root / staging.COLLECTION_INFO_PATH)["episodes"]
    ]
    expected = LeRobotDataset(reference.repo_id, root=reference.root)
    for key in (ACTION_KEY, STATE_KEY, SCENE_SEED_KEY):
        np.testing.assert_array_equal(np.stack(dataset.hf_dataset[key]), np.stack(expected.hf_dataset[key]))


def test_the_command_line_is_lerobot_s_draccus_flags(tmp_path, capsys):
    root = tmp_path / "ivmc_pick_place"
    dotted = parse_config(
        ["--env.task=pick_place", "--dataset.num_episodes=5", f"--dataset.root={root}"]
        + ["--dataset.repo_id=me/pp", "--env.split=val", "--env.image_size=32", "--dataset.video=true"]
        + ["--num_workers=1", "--seed", "3", "--action_noise=0.1", "--progress=false"]
    )
    assert dotted == CollectConfig(
        task="pick_place",
        num_episodes=5,
        root=root,
        repo_id="me/pp",
        split="val",
        image_size=32,
        video=True,
        num_workers=1,
        seed=3,
        action_noise=0.1,
        progress=False,
    )
    with pytest.raises(SystemExit) as help_exit:
        main(["--help"])
    usage = capsys.readouterr().out
    assert help_exit.value.code == 0 and usage.startswith("usage: lerobot-ivmc-collect")
    assert all(flag in usage for flag in ("--env.task", "--dataset.num_episodes", "--dataset.root", "--seed"))
    for argv, message in (
        (["--env.task=push", "--dataset.num_episodes=1", "--dataset.bogus=1"], "unrecognized arguments"),
        (["--env.task=push", f"--dataset.root={root}"], "--dataset.num_episodes=N"),
        (["--env.task=push", "--dataset.num_episodes=many"], "`dataset.num_episodes`: Couldn't parse"),
    ):
        with pytest.raises(SystemExit) as refused:
            parse_config(argv)
        assert refused.value.code == 2 and message in capsys.readouterr().err


def test_the_short_flags_of_earlier_versions_are_refused_naming_their_replacements(tmp_path, capsys):
    """One line, exit status 2 as argparse's, no traceback; each old flag used is named with its new one."""
    root = tmp_path / "ds"
    argv = ["--task", "pick_place", "--num-episodes=10", "--root", str(root), "--seed", "3"]
    with pytest.raises(SystemExit) as refused:
        main([*argv, "--image-size", "32", "--video", "--no-progress", "--num-workers", "0"])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and len(err.strip().splitlines()) == 1, err
    assert err.startswith(
        "lerobot-ivmc-collect takes LeRobot's flags: use --env.task=pick_place instead of --task pick_place, "
        f"--dataset.num_episodes=10 instead of --num-episodes=10, --dataset.root={root} instead of "
        f"--root {root}, --env.image_size=32 instead of --image-size 32, --dataset.video=true "
        "instead of --video, --progress=false instead of --no-progress, --num_workers=0 instead of "
        "--num-workers 0 (lerobot-ivmc-collect --help lists them)."
    )
    assert not root.exists()
    for old, new in (
        ("--split", "--env.split"),
        ("--render-style", "--env.render_style"),
        ("--repo-id", "--dataset.repo_id"),
        ("--episode-steps", "--dataset.episode_steps"),
        ("--action-noise", "--action_noise"),
    ):
        with pytest.raises(SystemExit):
            main(["--env.task=push", "--dataset.num_episodes=1", old, "x"])
        assert f"use {new}=x instead of {old} x (" in capsys.readouterr().err
    for switch, new in (
        ("--push-to-hub", "--dataset.push_to_hub=true"),
        ("--private", "--dataset.private=true"),
    ):
        with pytest.raises(SystemExit):
            main(["--env.task=push", "--dataset.num_episodes=1", switch])
        assert f"use {new} instead of {switch} (" in capsys.readouterr().err


def test_a_push_that_cannot_reach_the_hub_says_the_dataset_is_kept_and_how_to_push_it(collected):
    """Offline (or without a token), `--dataset.push_to_hub=true` ends in one message, not chained
    tracebacks; the finished dataset stays, and the same command later only pushes."""
    from requests.exceptions import ConnectionError as NoNetwork

    with mock.patch.object(
        LeRobotDataset, "push_to_hub", side_effect=NoNetwork("Max retries exceeded\nmore")
    ):
        with pytest.raises(
            CollectionError,
            match=r"is complete, but pushing it to .* failed \(ConnectionError: "
            r"Max retries exceeded\)\. Nothing is lost: rerun the same command",
        ):
            push_dataset(collected.root, collected.repo_id)
    assert LeRobotDataset(collected.repo_id, root=collected.root).num_episodes == 3
