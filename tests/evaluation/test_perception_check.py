"""`lerobot-ivmc-perception`: the object-position estimate of a policy against the truth, and the limit that
stops a pipeline on a policy that never learned where the object is.

The policies here are built to believe a fixed object position (decoder weights zero, the object's bias
chosen), so the errors the command must report are known from the simulator alone.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
import torch
from helpers.clis import ENV_FLAGS, console_script
from helpers.policies import make_config
from safetensors.torch import load_file

from lerobot_ivmc.envs import make_task_env
from lerobot_ivmc.experts import make_expert
from lerobot_ivmc.policies import VMCConfig
from lerobot_ivmc.policies.vmc.modeling_vmc import VMCPolicy

OBJECT_OUTPUTS = slice(9, 12)  # decoder: delta EE (3) | gripper logits (3) | EE (3) | object (3)


def env_state_stats(checkpoint: Path) -> tuple[np.ndarray, np.ndarray]:
    stats = load_file(next(checkpoint.glob("policy_preprocessor_*normalizer_processor.safetensors")))
    return stats["observation.environment_state.mean"].numpy(), stats[
        "observation.environment_state.std"
    ].numpy()


def fixed_belief_policy(tiny_bvmc: Path, out: Path, believed_object: np.ndarray) -> Path:
    """A vmc checkpoint (with the tiny checkpoint's processors) that never moves the arm (zero delta; gripper
    logits all 0, so the command of class 0), always believes the object is at `believed_object` and the grip
    at the mean of the training frames."""
    policy = VMCPolicy(make_config(VMCConfig))
    mean, std = env_state_stats(tiny_bvmc)
    with torch.no_grad():
        policy.net.decoder.weight.zero_()
        policy.net.decoder.bias.zero_()
        normalised = (believed_object - mean[3:6]) / (std[3:6] + 1e-8)
        policy.net.decoder.bias[OBJECT_OUTPUTS] = torch.as_tensor(normalised, dtype=torch.float32)
    policy.save_pretrained(out)
    for path in tiny_bvmc.glob("policy_*processor*"):
        (out / path.name).write_bytes(path.read_bytes())
    return out


def initial_object(seed: int) -> np.ndarray:
    env = make_task_env("pick_place", split="val", image_size=64)
    env.reset(seed=seed)
    position = env.object_position
    env.close()
    return position


def expert_track(seed: int, steps: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The grip and object positions before each of the expert's first `steps` actions on a val scene."""
    env = make_task_env("pick_place", split="val", image_size=64)
    expert = make_expert(env)
    env.reset(seed=seed)
    expert.reset()
    track = []
    for _ in range(steps):
        track.append((env.grip_position, env.object_position))
        env.step(expert.act())
    env.close()
    return track


def check(checkpoint: Path, out: Path, *flags: str) -> dict:
    from lerobot_ivmc.scripts.lerobot_ivmc_perception import perception_main

    argv = [
        "lerobot-ivmc-perception",
        f"--policy.path={checkpoint}",
        *ENV_FLAGS,
        "--env.split=val",
        f"--output_dir={out}",
        *flags,
    ]
    with mock.patch.object(sys, "argv", argv):
        return perception_main()


def test_errors_are_measured_against_the_true_positions(tiny_bvmc: Path, tmp_path: Path):
    steps, believed = 25, initial_object(0)
    checkpoint = fixed_belief_policy(tiny_bvmc, tmp_path / "policy", believed)
    believed_grip = env_state_stats(checkpoint)[0][:3]
    record = check(checkpoint, tmp_path / "out", "--n_scenes=3", f"--steps={steps}", "--seed=0")
    assert record["scene_seeds"] == [0, 1, 2] and record["passed"] is None  # no limit: nothing judged
    for scene in range(3):
        # Watching, the grip moves at every step: each estimate is compared with the state it was made in.
        track = expert_track(scene, steps)
        watching = record["watching_expert"]
        for part, believed_position, index in (("grip", believed_grip, 0), ("object", believed, 1)):
            errors = [np.linalg.norm(believed_position - positions[index]) for positions in track]
            assert watching[f"per_scene_{part}_cm"][scene] == pytest.approx(
                100 * statistics.median(errors), abs=0.05
            )
        # Acting, this policy never moves the arm: the object stays where it was spawned.
        acting = 100 * np.linalg.norm(believed - initial_object(scene))
        assert record["acting"]["per_scene_object_cm"][scene] == pytest.approx(acting, abs=0.05)
    assert record["acting"]["per_scene_object_cm"][0] == pytest.approx(0, abs=0.05)
    assert record["acting"]["object_cm"] == pytest.approx(
        statistics.median(record["acting"]["per_scene_object_cm"]), abs=1e-3
    )
    assert json.loads((tmp_path / "out" / "perception.json").read_text()) == record
    with pytest.raises(FileExistsError, match="another --output_dir"):
        check(checkpoint, tmp_path / "out", "--n_scenes=1")


def test_the_limit_fails_a_policy_that_misjudges_the_object_and_passes_one_that_does_not(
    tiny_bvmc: Path, tmp_path: Path
):
    wrong = fixed_belief_policy(tiny_bvmc, tmp_path / "wrong", initial_object(0) + [0.0, 0.10, 0.0])
    right = fixed_belief_policy(tiny_bvmc, tmp_path / "right", initial_object(0))
    flags = [
        *ENV_FLAGS,
        "--env.split=val",
        "--seed=0",
        "--n_scenes=1",
        "--steps=5",
        "--max_object_error_cm=5",
    ]
    script = console_script("lerobot-ivmc-perception")
    failed = subprocess.run(
        [script, f"--policy.path={wrong}", *flags, f"--output_dir={tmp_path / 'a'}"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert failed.returncode == 1, failed.stderr[-2000:]
    record = json.loads((tmp_path / "a" / "perception.json").read_text())
    assert record["passed"] is False and record["acting"]["object_cm"] == pytest.approx(10.0, abs=0.05)
    message = " ".join(failed.stderr.split())
    assert "did not learn where the object is" in message
    assert f"off by a median {record['acting']['object_cm']:.1f} cm" in message
    assert "--perception.max_object_error_cm=0" in message  # says how to go on anyway
    passed = check(right, tmp_path / "b", *flags[len(ENV_FLAGS) + 1 :])
    assert (
        passed["passed"] is True
        and passed["acting"]["object_cm"] < 0.05
        and passed["max_object_error_cm"] == 5
    )


def test_bad_input_is_refused(tiny_bvmc: Path, tmp_path: Path):
    with pytest.raises(ValueError, match="--max_object_error_cm must be >= 0"):
        check(tiny_bvmc, tmp_path / "a", "--max_object_error_cm=-1")
    with pytest.raises(ValueError, match="must be positive"):
        check(tiny_bvmc, tmp_path / "b", "--n_scenes=0")
    with pytest.raises(ValueError, match="must be positive"):
        check(tiny_bvmc, tmp_path / "b", "--steps=0")
    with pytest.raises(ValueError, match="longer than an episode"):
        check(tiny_bvmc, tmp_path / "b", "--steps=31")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
