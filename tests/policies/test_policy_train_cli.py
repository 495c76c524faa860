"""End to end: the real `lerobot-train` (and `lerobot-ivmc-train`) trains both policies on a tiny expert
dataset; the checkpoint loads with LeRobot's own loaders and acts in the env through `lerobot-eval`'s
rollout."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
import torch
from helpers.clis import console_script, tiny_training_flags
from lerobot.envs.factory import make_env, make_env_pre_post_processors
from lerobot.policies.factory import get_policy_class, make_pre_post_processors
from lerobot.scripts.lerobot_eval import rollout

from lerobot_ivmc.datasets.staging import COLLECTION_INFO_PATH
from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

STEPS = 5


WINDOW = ("--policy.training_mode=window",)
# The defaults before sequence training became the default: window training, the paper's network.
PAPER_WINDOW = (*WINDOW, "--policy.goal_head=false", "--policy.frame_position_head=false")
# The defaults (sequence training on whole demos, goal and frame position heads) on the 30-frame demos.
WHOLE_DEMOS = ("--policy.chunk_length=30",)
# Chunks shorter than the demos (stored chunk memory); the goal head needs whole demos.
SHORT_CHUNKS = ("--policy.chunk_length=10", "--policy.goal_head=false")


def train_command(
    command: str, policy_type: str, dataset: Path, out: Path, steps: int, *extra: str
) -> list[str]:
    """A `lerobot-train`-style command on the tiny dataset, local and offline, saving at the last step."""
    return [console_script(command), *tiny_training_flags(policy_type, dataset, out, steps), *extra]


@pytest.mark.parametrize(
    "command, policy_type, extra",
    [
        ("lerobot-train", "vmc", WINDOW),
        ("lerobot-train", "bvmc", WINDOW),
        ("lerobot-ivmc-train", "bvmc", WINDOW),
        ("lerobot-train", "vmc", WHOLE_DEMOS),
        ("lerobot-ivmc-train", "bvmc", WHOLE_DEMOS),
        ("lerobot-ivmc-train", "bvmc", SHORT_CHUNKS),
    ],
)
def test_train_then_load_and_act(
    command: str, policy_type: str, extra: tuple[str, ...], tiny_dataset: Path, tmp_path: Path
) -> None:
    out = tmp_path / "train"
    cmd = train_command(
        command, policy_type, tiny_dataset, out, STEPS, "--batch_size=4", "--log_freq=1", *extra
    )
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    checkpoint = out / "checkpoints" / f"{STEPS:06d}" / "pretrained_model"
    assert (checkpoint / "model.safetensors").exists()
    # The learning rate decays over the run (cosine schedule), and the scheduler state is saved to resume.
    assert (checkpoint.parent / "training_state" / "scheduler_state.json").exists()

    policy = get_policy_class(policy_type).from_pretrained(checkpoint)
    assert policy.config.type == policy_type
    # A sequence-trained policy rolls out with the carried memory it was trained with.
    assert policy.config.rollout_memory == ("window" if extra == WINDOW else "trajectory")
    assert policy.config.goal_head == (extra == WHOLE_DEMOS)
    if policy_type == "bvmc":
        assert policy.config.dataset_size == 60, "N for the regularisers comes from the dataset"
        policy.config.num_samples = 5
    preprocessor, postprocessor = make_pre_post_processors(policy.config, pretrained_path=str(checkpoint))

    env_cfg = IvmcEnv(task="pick_place", image_size=64, episode_length=4)
    envs = make_env(env_cfg, n_envs=1)
    env = next(iter(envs["ivmc"].values()))
    env_pre, env_post = make_env_pre_post_processors(env_cfg, policy.config)
    try:
        info = rollout(env, policy, env_pre, env_post, preprocessor, postprocessor, seeds=[0])
    finally:
        env.close()
    actions = info["action"]
    assert actions.shape == (1, 4, 4)
    assert torch.isfinite(actions).all()
    assert set(actions[..., 3].flatten().tolist()) <= {-1.0, 0.0, 1.0}


@pytest.mark.parametrize("extra", [WINDOW, WHOLE_DEMOS])
def test_regulariser_n_counts_only_the_episodes_trained_on(
    extra: tuple[str, ...], tiny_dataset: Path, tmp_path: Path
) -> None:
    """Also: sequence chunks of an episode subset come from that subset (LeRobot's episode-aware sampler
    yields absolute frame indices, which `lerobot-ivmc-train`'s cache maps to its rows)."""
    out = tmp_path / "train"
    cmd = train_command(
        "lerobot-ivmc-train", "bvmc", tiny_dataset, out, 1, "--batch_size=2", "--dataset.episodes=[1]", *extra
    )
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    policy = get_policy_class("bvmc").from_pretrained(out / "checkpoints" / "000001" / "pretrained_model")
    assert policy.config.dataset_size == 30, "one 30-frame episode trained on, of the dataset's 60 frames"


def test_a_run_saved_before_the_defaults_switch_resumes_with_its_own_training_mode(
    tiny_dataset: Path, tmp_path: Path
) -> None:
    """A window run whose saved configs lack the fields added since (as every run before the switch did)
    resumes as window training under `lerobot-ivmc-train`, although today's defaults say sequence."""
    out = tmp_path / "train"
    first = train_command("lerobot-ivmc-train", "bvmc", tiny_dataset, out, 2, "--batch_size=2", *PAPER_WINDOW)
    result = subprocess.run(first, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    checkpoint = out / "checkpoints" / "last" / "pretrained_model"
    for path, section in ((checkpoint / "config.json", None), (checkpoint / "train_config.json", "policy")):
        saved = json.loads(path.read_text())
        for name in ("training_mode", "goal_head", "frame_position_head"):
            del (saved[section] if section else saved)[name]
        path.write_text(json.dumps(saved))
    resume = [
        console_script("lerobot-ivmc-train"),
        f"--config_path={checkpoint / 'train_config.json'}",
        "--resume=true",
        "--steps=4",
        "--save_freq=4",
    ]
    result = subprocess.run(resume, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    # Its samples were built as windows: the config was completed before the dataset, and before LeRobot
    # logged it, so the log shows what the run trains with.
    output = result.stdout + result.stderr
    assert "predates sequence training as the default: it runs with its own training_mode=window" in output
    assert "'training_mode': 'window'" in output and "'training_mode': 'sequence'" not in output
    resumed = json.loads((out / "checkpoints" / "000004" / "pretrained_model" / "config.json").read_text())
    assert (resumed["training_mode"], resumed["goal_head"], resumed["frame_position_head"]) == (
        "window",
        False,
        False,
    )


def test_the_checkpoint_records_the_render_style_of_its_dataset(tiny_dataset: Path, tmp_path: Path) -> None:
    """A dataset collected before render styles (its record names none) has the Fetch XML's look:
    `lerobot-ivmc-train` records that in the checkpoint, and refuses a `--policy.render_style` against it."""
    dataset = tmp_path / "legacy_dataset"
    shutil.copytree(tiny_dataset, dataset)
    (dataset / COLLECTION_INFO_PATH).write_text(json.dumps({"spec": {"task": "pick_place"}}))
    out = tmp_path / "train"
    cmd = train_command("lerobot-ivmc-train", "vmc", dataset, out, 1, "--batch_size=2", *WHOLE_DEMOS)
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    saved = json.loads((out / "checkpoints" / "000001" / "pretrained_model" / "config.json").read_text())
    assert saved["render_style"] == "fetch"
    assert saved["trained_task"] == "pick_place"  # so an env of another task is refused

    cmd = train_command(
        "lerobot-ivmc-train", "vmc", dataset, tmp_path / "refused", 1, "--policy.render_style=fast"
    )
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2
    last_line = result.stderr.strip().splitlines()[-1]
    assert last_line.startswith("error: The dataset's frames are drawn in the 'fetch' render style, but ")
    assert not (tmp_path / "refused" / "checkpoints").exists()


@pytest.mark.parametrize(
    "case, expected",
    [
        ("missing_root", "holds no LeRobot dataset (no meta/info.json)"),
        ("zero_steps", "--steps must be positive, got 0."),
        ("three_fc", "num_fc_layers (#fc) must be 1 or 2 as in the paper, got 3."),
    ],
)
def test_bad_training_input_ends_on_one_line(case: str, expected: str, tiny_dataset: Path, tmp_path: Path):
    dataset = tmp_path / "nowhere" if case == "missing_root" else tiny_dataset
    steps = 0 if case == "zero_steps" else 1
    extra = ("--policy.num_fc_layers=3",) if case == "three_fc" else ()
    cmd = train_command("lerobot-ivmc-train", "vmc", dataset, tmp_path / "out", steps, *extra)
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2, result.stderr[-2000:]
    assert "Traceback" not in result.stderr
    assert result.stderr.strip().splitlines()[-1].startswith("error: ") and expected in result.stderr
