"""`lerobot-ivmc-inspect`: one episode with the true positions next to the network's beliefs."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from helpers.clis import ENV_FLAGS, EPISODE_LENGTH
from helpers.policies import make_config

from lerobot_ivmc.envs import make_task_env
from lerobot_ivmc.policies import BVMCConfig, VMCConfig
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.policies.vmc.modeling_vmc import VMCPolicy


def inspect(checkpoint: Path, out: Path, *flags: str) -> dict:
    from lerobot_ivmc.scripts.lerobot_ivmc_inspect import inspect_main

    argv = ["lerobot-ivmc-inspect", f"--policy.path={checkpoint}", *ENV_FLAGS, f"--output_dir={out}", *flags]
    with mock.patch.object(sys, "argv", argv):
        return inspect_main()


def test_records_the_scene_of_the_seed_step_by_step_and_never_overwrites(tiny_bvmc: Path, tmp_path: Path):
    result = inspect(tiny_bvmc, tmp_path, "--env.split=test", "--episode_seed=3", "--print_every=0")
    record = result["per_step"]
    assert result["steps"] == EPISODE_LENGTH and len(record["grip"]) == EPISODE_LENGTH
    env = make_task_env("pick_place", split="test", image_size=64)
    env.reset(seed=3)
    np.testing.assert_allclose(record["object"][0], env.object_position)
    np.testing.assert_allclose(record["target"][0], env.target_position)
    np.testing.assert_allclose(record["grip"][0], env.grip_position)
    env.close()
    # The grip moves as the recorded actions say (up to 5 cm a step); beliefs are world positions (3,).
    moves = np.abs(np.diff(np.asarray(record["grip"]), axis=0))
    assert moves.max() <= 0.05 + 1e-3 and moves.sum() > 0
    assert np.asarray(record["believed_object"]).shape == (EPISODE_LENGTH, 3)
    assert all(u is not None and u >= 0 for u in record["uncertainty"])
    saved = tmp_path / "inspect_seed3.json"
    assert json.loads(saved.read_text())["milestones"] == result["milestones"]
    assert (tmp_path / "inspect_seed3.png").stat().st_size > 0
    before = saved.read_text()
    with pytest.raises(FileExistsError, match="another --output_dir"):
        inspect(tiny_bvmc, tmp_path, "--env.split=test", "--episode_seed=3")
    assert saved.read_text() == before


@pytest.mark.parametrize("kind", ["vmc", "bvmc_goal_head"])
def test_reads_vmc_and_the_goal_head(kind: str, tiny_bvmc: Path, tmp_path: Path):
    # A fresh network of the other kind with the tiny checkpoint's processors (same features and stats).
    checkpoint = tmp_path / kind
    if kind == "vmc":
        policy = VMCPolicy(make_config(VMCConfig))
    else:
        policy = BVMCPolicy(make_config(BVMCConfig, num_samples=8, training_mode="sequence", goal_head=True))
    policy.save_pretrained(checkpoint)
    for path in tiny_bvmc.glob("policy_*processor*"):
        (checkpoint / path.name).write_bytes(path.read_bytes())
    result = inspect(checkpoint, tmp_path / "out", "--episode_seed=1", "--print_every=5")
    record = result["per_step"]
    assert result["steps"] == EPISODE_LENGTH
    if kind == "vmc":
        assert record["uncertainty"] == [None] * EPISODE_LENGTH and "believed_goal" not in record
    else:
        assert np.asarray(record["believed_goal"]).shape == (EPISODE_LENGTH, 3)
        assert all(u >= 0 for u in record["uncertainty"])
    assert (tmp_path / "out" / "inspect_seed1.png").stat().st_size > 0
