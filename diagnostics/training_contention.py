"""The `lite` training step under bf16 autocast against fp32, interleaved in one process: how fast each
runs on this machine as it is (idle, or sharing its cores with another job), and under the OpenMP wait
policy given in the environment (which must be set before torch starts, so once per run).

LeRobot's pieces as `lerobot-ivmc-train` runs them (`benchmarks/bench_training.py`'s `Trainer`): the
`lite` preset's policy (sequence training, 2 demos a batch, goal and frame position heads), the first
`--episodes` demos of a collected dataset. Prints the median optimiser steps per second of each.

    python -m diagnostics.training_contention --root <study>/data --repo-id local/ivmc_pick_place
    OMP_WAIT_POLICY=PASSIVE python -m diagnostics.training_contention --root ... --repo-id ...
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import torch
from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata

from lerobot_ivmc.policies import BVMCConfig

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_training import Mode, Trainer  # noqa: E402


def lite_config() -> BVMCConfig:
    return BVMCConfig(
        device="cpu",
        training_mode="sequence",
        chunk_length=100,
        goal_head=True,
        frame_position_head=True,
        optimizer_lr=3e-4,
        num_fc_layers=1,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", required=True)
    parser.add_argument("--repo-id", required=True)
    parser.add_argument("--episodes", type=int, default=60)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--steps-per-round", type=int, default=4)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    meta = LeRobotDatasetMetadata(args.repo_id, root=args.root)
    episodes = list(range(min(args.episodes, meta.total_episodes)))
    trainers = {
        "bf16": Trainer(Mode("bf16", lite_config(), 2, bf16=True), meta, args.root, episodes),
        "fp32": Trainer(Mode("fp32", lite_config(), 2), meta, args.root, episodes),
    }
    for trainer in trainers.values():
        for _ in range(3):
            trainer.step()
    rates: dict[str, list[float]] = {name: [] for name in trainers}
    for _ in range(args.rounds):
        for name, trainer in trainers.items():
            start = time.perf_counter()
            for _ in range(args.steps_per_round):
                trainer.step()
            rates[name].append(args.steps_per_round / (time.perf_counter() - start))
    policy = os.environ.get("OMP_WAIT_POLICY", "default")
    medians = {name: statistics.median(values) for name, values in rates.items()}
    print(
        f"OMP_WAIT_POLICY={policy}, {args.threads} threads: "
        + ", ".join(f"{name} {rate:.2f} optimiser steps/s" for name, rate in medians.items())
        + f" (bf16 / fp32: {medians['bf16'] / medians['fp32']:.2f}x)"
    )


if __name__ == "__main__":
    main()
