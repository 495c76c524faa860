"""MetaWorld demos from MetaWorld's scripted policies through `lerobot-ivmc-collect`, in the layout of the
hub's `lerobot/metaworld_mt50`, and `vmc` / `bvmc` trained on them by LeRobot's own commands."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path
from unittest import mock

import numpy as np
import pyarrow.parquet as pq
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.collect import collect_demos
from lerobot_ivmc.datasets.collect_config import CollectConfig

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

TASK = "push-v3"
HUB_KEYS = ("observation.image", "observation.state", "observation.environment_state", "action")


def console_script(name: str) -> str:
    return str(Path(sys.executable).with_name(name))


def collect(root: Path, image_size: int = 64, episodes: int = 2) -> CollectConfig:
    cfg = CollectConfig(
        task=TASK,
        num_episodes=episodes,
        root=root,
        repo_id=f"local/{TASK}",
        image_size=image_size,
        num_workers=0,
        action_noise=0.1,
        progress=False,
    )
    collect_demos(cfg)
    return cfg


def train_command(command: str, root: Path, out: Path, *flags: str, steps: int = 2) -> list[str]:
    """`command` (lerobot-train or lerobot-ivmc-train) on the demos in `root`, `steps` steps, into `out`."""
    return [
        console_script(command),
        "--policy.device=cpu",
        f"--dataset.repo_id=local/{TASK}",
        f"--dataset.root={root}",
        f"--steps={steps}",
        f"--save_freq={steps}",
        "--num_workers=0",
        "--eval_freq=0",
        "--policy.push_to_hub=false",
        "--wandb.enable=false",
        "--policy.chunk_length=150",
        f"--output_dir={out}",
        *flags,
    ]


@pytest.fixture(scope="module")
def demos(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("metaworld") / "demos"
    collect(root)
    return root


def test_demos_load_with_lerobot_in_the_hub_layout(demos: Path) -> None:
    dataset = LeRobotDataset(f"local/{TASK}", root=demos)
    assert dataset.fps == 80 and dataset.num_episodes == 2 and dataset.meta.robot_type == "sawyer"
    frame = dataset[0]
    assert set(HUB_KEYS) <= set(frame)
    assert frame["observation.image"].shape == (3, 64, 64)
    assert frame["observation.state"].shape == (4,) and frame["observation.environment_state"].shape == (39,)
    actions = np.stack([dataset[i]["action"].numpy() for i in range(0, len(dataset), 7)])
    assert actions.shape[1] == 4 and np.abs(actions).max() <= 1.0  # clipped to the action space
    assert frame["task"] == "Push the puck to a goal"
    assert dataset.meta.episodes["length"][0] == 150


def test_once_the_task_is_done_the_scripted_policy_holds_still(demos: Path) -> None:
    """MetaWorld's scripted policy keeps acting once done (and so undid about 1 in 10 noisy push-v3 demos);
    the recorder holds instead: from some frame on, no motion and one grab effort, the hand settling where
    it was sent and the puck with it."""
    dataset = LeRobotDataset(f"local/{TASK}", root=demos)
    for episode in range(dataset.num_episodes):
        start, end = (
            int(dataset.meta.episodes[key][episode]) for key in ("dataset_from_index", "dataset_to_index")
        )
        frames = [dataset[i] for i in range(start, end)]
        actions = np.stack([frame["action"].numpy() for frame in frames])
        state = np.stack([frame["observation.environment_state"].numpy() for frame in frames])
        moving = np.flatnonzero(np.abs(actions[:, :3]).max(axis=1) > 0)
        held_from = int(moving[-1]) + 1
        assert 0 < held_from < len(frames) - 10, "the demo holds for its last frames, after the policy acted"
        assert len(np.unique(actions[held_from:, 3])) == 1
        # the hand (entries 0-2) settles where it was sent, the puck (4-6) with it: under 0.5 mm a frame at
        # the end (acting, the hand moves up to a centimetre a frame)
        last_steps = np.diff(state[-10:, [0, 1, 2, 4, 5, 6]], axis=0)
        assert np.abs(last_steps).max() < 5e-4


def test_demos_of_before_the_hold_are_kept_apart(demos: Path, tmp_path: Path) -> None:
    """A MetaWorld dataset recorded while the policy kept acting once done is never extended with held
    demos; the refusal says why and what to do."""
    old = tmp_path / "old"
    shutil.copytree(demos, old)
    info_path = old / staging.COLLECTION_INFO_PATH
    info = staging.read_json(info_path)
    del info["spec"]["expert_after_success"]  # as the recorder of before the hold wrote it
    staging.write_json(info_path, info)
    with pytest.raises(ValueError, match="before the scripted policy held still.*new --dataset.root"):
        collect(old)


def test_the_same_arguments_give_byte_identical_demos(demos: Path, tmp_path: Path) -> None:
    again = tmp_path / "again"
    collect(again)
    for path in sorted((demos / "data").glob("*/*.parquet")):
        first = pq.read_table(path).drop(["observation.image"])
        second = pq.read_table(again / path.relative_to(demos)).drop(["observation.image"])
        assert first.equals(second)
    images = [pq.read_table(p, columns=["observation.image"]) for p in (demos / "data").glob("*/*.parquet")]
    images_again = [
        pq.read_table(again / p.relative_to(demos), columns=["observation.image"])
        for p in (demos / "data").glob("*/*.parquet")
    ]
    assert all(a.equals(b) for a, b in zip(images, images_again, strict=True))


def test_stock_lerobot_train_and_eval_run_bvmc_on_metaworld(demos: Path, tmp_path: Path) -> None:
    out = tmp_path / "train"
    train = train_command(
        "lerobot-train",
        demos,
        out,
        "--policy.type=bvmc",
        "--batch_size=2",
        "--policy.aux_state_indices=[0,1,2,4,5,6]",
        "--policy.render_style=flat",
    )
    result = subprocess.run(train, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    checkpoint = out / "checkpoints" / "last" / "pretrained_model"
    evaluate = [
        console_script("lerobot-eval"),
        f"--policy.path={checkpoint}",
        "--env.type=meta_world",
        f"--env.task={TASK}",
        "--env.episode_length=5",
        "--eval.n_episodes=1",
        "--eval.batch_size=1",
        f"--output_dir={tmp_path / 'eval'}",
    ]
    result = subprocess.run(evaluate, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    assert (tmp_path / "eval" / "eval_info.json").exists()
    # lerobot-ivmc-inspect reads the trained network's beliefs next to MetaWorld's true positions.
    from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv
    from lerobot_ivmc.scripts.lerobot_ivmc_inspect import inspect_main

    inspect = [
        "lerobot-ivmc-inspect",
        f"--policy.path={checkpoint}",
        "--env.type=meta_world",
        f"--env.task={TASK}",
        "--env.episode_length=4",
        "--env.split=val",
        "--episode_seed=2",
        "--print_every=0",
        f"--output_dir={tmp_path / 'inspect'}",
    ]
    with mock.patch.object(sys, "argv", inspect):
        record = inspect_main()
    env = SeededMetaworldEnv(TASK, split="val")
    env.reset(seed=2)
    np.testing.assert_allclose(record["per_step"]["object"][0], env.object_position)
    np.testing.assert_allclose(record["per_step"]["target"][0], env.target_position)
    np.testing.assert_allclose(record["per_step"]["grip"][0], env.grip_position)
    env.close()
    assert record["steps"] == 4 and np.asarray(record["per_step"]["believed_object"]).shape == (4, 3)


def test_stock_lerobot_train_runs_bvmc_on_480_px_hub_layout_frames_resized_for_the_network(
    tmp_path: Path,
) -> None:
    hub_like = tmp_path / "hub_like"
    collect(hub_like, image_size=480, episodes=1)
    image = LeRobotDataset(f"local/{TASK}", root=hub_like).meta.features["observation.image"]
    assert tuple(image["shape"]) == (480, 480, 3)
    out = tmp_path / "train"
    train = train_command(
        "lerobot-train", hub_like, out, "--policy.type=bvmc", "--batch_size=1", "--policy.image_size=64"
    )
    result = subprocess.run(train, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    checkpoint = out / "checkpoints" / "last" / "pretrained_model"
    from lerobot_ivmc.policies import BVMCPolicy

    policy = BVMCPolicy.from_pretrained(checkpoint)
    assert policy.net.map_size == (4, 4)  # built for 64-px frames: 64 -> 32 -> 16 -> 8 -> 4
    steps = json.loads((checkpoint / "policy_preprocessor.json").read_text())["steps"]
    assert {"registry_name": "ivmc_resize_images", "config": {"size": 64, "keys": ["observation.image"]}} in [
        {k: step.get(k) for k in ("registry_name", "config")} for step in steps
    ]


def test_a_render_style_other_than_the_checkpoints_is_refused(demos: Path, tmp_path: Path) -> None:
    out = tmp_path / "train"
    train = train_command("lerobot-ivmc-train", demos, out, "--policy.type=vmc", "--batch_size=2", steps=1)
    result = subprocess.run(train, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    checkpoint = out / "checkpoints" / "last" / "pretrained_model"
    config = json.loads((checkpoint / "config.json").read_text())
    assert config["render_style"] == "flat" and config["trained_task"] == TASK
    assert config["aux_state_indices"] == [0, 1, 2, 4, 5, 6]  # the hand and the object, from the dataset
    evaluate = [
        console_script("lerobot-ivmc-eval"),
        f"--policy.path={checkpoint}",
        "--env.type=meta_world",
        f"--env.task={TASK}",
        "--env.render_style=fast",
        "--eval.n_episodes=1",
        "--eval.batch_size=1",
        "--seed=0",
        f"--output_dir={tmp_path / 'eval'}",
    ]
    result = subprocess.run(evaluate, capture_output=True, text=True, timeout=600)
    assert result.returncode != 0
    lines = [line for line in result.stderr.strip().splitlines() if "render style" in line]
    assert lines and "pass --env.render_style=flat" in lines[-1]


def test_collecting_an_unknown_task_is_refused_in_one_line(tmp_path: Path) -> None:
    result = subprocess.run(
        [console_script("lerobot-ivmc-collect"), "--env.task=push-v9", "--dataset.num_episodes=1"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert result.returncode == 2
    assert "Unknown task 'push-v9'" in result.stderr.strip().splitlines()[-1]
