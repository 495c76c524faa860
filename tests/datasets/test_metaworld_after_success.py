"""What MetaWorld's scripted policy does once its task is done (`--expert_after_success`): it holds still
by default, or acts on to the demo's end; the choice is in the collection's spec, so demos of the two never
mix, and the Fetch expert, which only holds, refuses the other in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from lerobot_ivmc.datasets.collect import collect_demos
from lerobot_ivmc.datasets.collect_config import CollectConfig

TASK = "door-open-v3"


def config(root: Path, after_success: str) -> CollectConfig:
    return CollectConfig(
        task=TASK,
        num_episodes=1,
        root=root,
        repo_id="local/door",
        num_workers=0,
        action_noise=0.1,
        expert_after_success=after_success,
        progress=False,
    )


def test_the_fetch_expert_refuses_to_act_on_once_done(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"expert_after_success must be one of \('hold',\) for push"):
        CollectConfig(task="push", num_episodes=1, root=tmp_path, expert_after_success="act")


def test_an_acting_expert_moves_to_the_last_frame_and_its_demos_never_mix_with_held_ones(
    tmp_path: Path,
) -> None:
    root = tmp_path / "acting"
    cfg = config(root, "act")
    assert (
        cfg.spec()["expert_after_success"] == "act"
        and config(root, "hold").spec()["expert_after_success"] == "hold"
    )
    collect_demos(cfg)
    dataset = LeRobotDataset("local/door", root=root)
    actions = np.stack([dataset[i]["action"].numpy() for i in range(len(dataset))])
    # Held, the last frames' xyz would be exactly zero; acting on, the policy keeps pulling the door.
    assert np.abs(actions[-10:, :3]).max() > 0.05
    with pytest.raises(ValueError, match="another spec"):
        collect_demos(config(root, "hold"))
