"""A bvmc's recovery threshold travels with the checkpoint: saved with it, loaded from a folder or a hub
repo (here a local hub cache, offline), and dropped once the policy trains."""

from __future__ import annotations

from pathlib import Path

import huggingface_hub.constants
import pytest
from helpers.policies import THRESHOLD_RECORD, make_batch, make_config

from lerobot_ivmc.policies import BVMCConfig
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.recovery.threshold import THRESHOLD_FILE, ThresholdRecord


def saved_checkpoint(folder: Path) -> Path:
    policy = BVMCPolicy(make_config(BVMCConfig, num_samples=8))
    policy.save_pretrained(folder)
    THRESHOLD_RECORD.save(folder)
    return folder


def as_hub_cache(folder: Path, cache: Path, repo_id: str) -> None:
    """Lay `folder` out as huggingface_hub's cache of `repo_id` at revision main."""
    repo = cache / f"models--{repo_id.replace('/', '--')}"
    commit = "0" * 40
    snapshot = repo / "snapshots" / commit
    snapshot.mkdir(parents=True)
    for file in folder.iterdir():
        (snapshot / file.name).write_bytes(file.read_bytes())
    (repo / "refs").mkdir()
    (repo / "refs" / "main").write_text(commit)


def test_threshold_is_saved_loaded_and_pushed_with_the_checkpoint(tmp_path: Path, monkeypatch) -> None:
    local = saved_checkpoint(tmp_path / "local")
    policy = BVMCPolicy.from_pretrained(local)
    assert policy.threshold_record == THRESHOLD_RECORD
    resaved = tmp_path / "resaved"  # what push_to_hub uploads: a save_pretrained folder
    policy.save_pretrained(resaved)
    assert ThresholdRecord.load(resaved) == THRESHOLD_RECORD

    cache = tmp_path / "hub"
    as_hub_cache(resaved, cache, "someone/bvmc-pick-place")
    monkeypatch.setattr(huggingface_hub.constants, "HF_HUB_OFFLINE", True)
    monkeypatch.setattr(huggingface_hub.constants, "HF_HUB_CACHE", str(cache))
    assert ThresholdRecord.load("someone/bvmc-pick-place") == THRESHOLD_RECORD
    from_hub = BVMCPolicy.from_pretrained("someone/bvmc-pick-place")
    assert from_hub.threshold_record == THRESHOLD_RECORD
    assert ThresholdRecord.load("someone/not-cached") is None


def test_a_policy_that_trains_drops_its_threshold(tmp_path: Path) -> None:
    policy = BVMCPolicy.from_pretrained(saved_checkpoint(tmp_path / "local"))
    policy.train()
    policy.forward(make_batch())
    trained = tmp_path / "trained"
    policy.save_pretrained(trained)
    assert not (trained / THRESHOLD_FILE).exists()


@pytest.mark.parametrize("name", ["not a repo id!", "/no/such/folder"])
def test_no_threshold_where_there_is_no_checkpoint(name: str) -> None:
    assert ThresholdRecord.load(name) is None
