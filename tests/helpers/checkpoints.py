"""Fixtures: a tiny bvmc trained by the real CLIs, with foresight and threshold (registered in
`tests/conftest.py` for every test folder)."""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers.clis import ENV_FLAGS, run_cli, run_main, tiny_training_flags
from helpers.policies import build_expert_dataset


@pytest.fixture(scope="session")
def tiny_bvmc(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A bvmc checkpoint trained for 5 steps by lerobot-ivmc-train on a 2-episode dataset."""
    root = tmp_path_factory.mktemp("recovery")
    dataset = build_expert_dataset(root / "data")
    out = root / "train"
    run_cli(
        "lerobot-ivmc-train",
        *tiny_training_flags("bvmc", dataset, out, steps=5),
        "--policy.num_samples=8",
        "--policy.chunk_length=30",  # the defaults (sequence training, both heads) on the 30-frame demos
        "--batch_size=4",
    )
    return out / "checkpoints" / "000005" / "pretrained_model"


@pytest.fixture(scope="session")
def tiny_foresight(tiny_bvmc: Path) -> Path:
    """The output folder of lerobot-ivmc-foresight on `tiny_bvmc` (4 episodes, 2 epochs, 2 ranked states)."""
    out = tiny_bvmc.parents[3] / "foresight"
    run_main(
        "lerobot-ivmc-foresight",
        f"--policy.path={tiny_bvmc}",
        *ENV_FLAGS,
        "--foresight.num_trajectories=4",
        "--foresight.epochs=2",
        "--foresight.ranking_states=2",
        "--foresight.ranking_every=5",
        "--eval.batch_size=2",
        "--eval.n_episodes=2",
        "--seed=0",
        f"--output_dir={out}",
    )
    return out


@pytest.fixture(scope="session")
def tiny_recovery_checkpoint(tiny_foresight: Path) -> Path:
    """`tiny_foresight`'s checkpoint with a threshold picked by lerobot-ivmc-threshold on 4 val episodes."""
    out = tiny_foresight.parent / "threshold"
    run_main(
        "lerobot-ivmc-threshold",
        f"--policy.path={tiny_foresight / 'pretrained_model'}",
        *ENV_FLAGS,
        "--env.split=val",
        "--eval.n_episodes=4",
        "--eval.batch_size=2",
        "--seed=0",
        f"--output_dir={out}",
    )
    return out / "pretrained_model"
