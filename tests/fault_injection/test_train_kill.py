"""Fault injection: `lerobot-ivmc-train` SIGKILLed after a checkpoint resumes from it and finishes the run."""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers.policies import TINY_REPO_ID, build_expert_dataset

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

STEPS = 100_000  # never reached: the run is killed after its first checkpoint, however fast the machine
MORE_STEPS = 10  # the resumed run's schedule ends this many steps after the checkpoint it resumes from


def _train(out: Path, dataset: Path, *extra: str) -> list[str]:
    script = Path(sys.executable).with_name("lerobot-ivmc-train")
    return [
        str(script if script.exists() else shutil.which("lerobot-ivmc-train")),
        "--policy.type=bvmc", f"--dataset.repo_id={TINY_REPO_ID}", f"--dataset.root={dataset}",
        "--policy.device=cpu", "--policy.push_to_hub=false", "--wandb.enable=false", "--eval_freq=0",
        f"--steps={STEPS}", "--save_freq=5", "--batch_size=2", "--num_workers=0", "--log_freq=1",
        f"--output_dir={out}", *extra,
    ]  # fmt: skip


# Window training, and the pipeline's recipe: whole-episode sequences under bf16 autocast.
@pytest.mark.parametrize(
    "extra, env",
    [
        (("--policy.training_mode=window",), {}),
        (
            ("--policy.chunk_length=20",),  # the defaults: whole demos, goal and frame position heads
            {"ACCELERATE_MIXED_PRECISION": "bf16"},
        ),
    ],
    ids=["window", "sequence-bf16"],
)
def test_killed_training_resumes_from_its_last_checkpoint(tmp_path: Path, extra: tuple, env: dict) -> None:
    dataset = build_expert_dataset(tmp_path / "data", num_episodes=1, max_steps=20)
    out = tmp_path / "train"
    env = {**os.environ, **env}
    process = subprocess.Popen(
        _train(out, dataset, *extra), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env
    )
    # LeRobot points `last` at a checkpoint once it is fully written; kill after that, as a resume needs it.
    first = out / "checkpoints" / "last" / "pretrained_model" / "train_config.json"
    deadline = time.monotonic() + 300
    while not first.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert first.exists(), "the run died before its first checkpoint"
    resumed_from = json.loads(
        (out / "checkpoints" / "last" / "training_state" / "training_step.json").read_text()
    )
    end = resumed_from["step"] + MORE_STEPS

    # The resumed run keeps the saved config; only its schedule is shortened so that it ends.
    config = out / "checkpoints" / "last" / "pretrained_model" / "train_config.json"
    result = subprocess.run(
        [_train(out, dataset)[0], f"--config_path={config}", "--resume=true", f"--steps={end}"],
        capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-3000:]
    final = out / "checkpoints" / f"{end:06d}"
    assert (final / "pretrained_model" / "model.safetensors").exists()
    assert json.loads((final / "training_state" / "training_step.json").read_text())["step"] == end
