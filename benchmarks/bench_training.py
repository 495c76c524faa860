"""Training throughput of window against sequence training, in supervised steps per second, in one run.

One supervised step = one action label learned from: a K-frame window gives one (its last frame's
action), a chunk one per frame. Each mode runs LeRobot's own pieces as `lerobot-ivmc-train` does: the
policy's delta indices on the LeRobotDataset, the in-memory `FrameCache`, a shuffled DataLoader (LeRobot's
episode-aware sampler for chunks, so they start only where they fit), the policy's pre-processor, forward,
backward, gradient clipping and an Adam step. Modes run in interleaved rounds (so a busy machine slows all
of them alike) and the median round rate is reported. `--bf16` adds sequence training under bf16 autocast
(what `ACCELERATE_MIXED_PRECISION=bf16 lerobot-ivmc-train ...` runs). `--zero-chunk-memory` adds sequence
training with `chunk_memory="zero"`, to price the stored states of chunks shorter than the demos (the
default `"stored"` recomputes and keeps each frame's LSTM state).

The goal of the sequence training: at least 3x the window's supervised steps per second.

Usage:
    python benchmarks/bench_training.py --root <data>/pp_dart --repo-id local/pp_dart [--episodes 200]
        [--threads 2] [--rounds 3] [--steps-per-round 20] [--window-batch 32] [--sequence-batch 4]
        [--chunk-length 100] [--bf16] [--zero-chunk-memory]
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import time
from collections.abc import Iterator
from dataclasses import dataclass

import torch
from lerobot.datasets.factory import resolve_delta_timestamps
from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata
from lerobot.datasets.sampler import EpisodeAwareSampler
from lerobot.policies.factory import make_policy, make_pre_post_processors

from lerobot_ivmc.datasets.frame_cache import FrameCache
from lerobot_ivmc.hardware import cpu_has_native_bf16
from lerobot_ivmc.policies import BVMCConfig


@dataclass
class Mode:
    """One training setup to time."""

    name: str
    config: BVMCConfig
    batch_size: int
    bf16: bool = False


class Trainer:
    """The training step of `lerobot-train` for one mode, on an endless shuffled loader."""

    def __init__(self, mode: Mode, meta: LeRobotDatasetMetadata, root: str, episodes: list[int]):
        self.mode = mode
        dataset = LeRobotDataset(
            meta.repo_id,
            root=root,
            episodes=episodes,
            delta_timestamps=resolve_delta_timestamps(mode.config, meta),
        )
        self.policy = make_policy(mode.config, ds_meta=meta)
        self.policy.train()
        self.preprocessor, _ = make_pre_post_processors(mode.config, dataset_stats=meta.stats)
        self.optimizer = mode.config.get_optimizer_preset().build(self.policy.parameters())
        generator = torch.Generator().manual_seed(0)
        sampler = None
        if hasattr(mode.config, "drop_n_last_frames"):  # what lerobot-train does: chunks only where they fit
            sampler = EpisodeAwareSampler(
                meta.episodes["dataset_from_index"],
                meta.episodes["dataset_to_index"],
                episode_indices_to_use=episodes,
                drop_n_last_frames=mode.config.drop_n_last_frames,
                shuffle=True,
            )
        self.loader = torch.utils.data.DataLoader(
            FrameCache(dataset),
            batch_size=mode.batch_size,
            shuffle=sampler is None,
            sampler=sampler,
            generator=generator,
        )
        self.batches = self._endless()

    def _endless(self) -> Iterator[dict]:
        while True:
            yield from self.loader

    def autocast(self) -> contextlib.AbstractContextManager:
        """bf16 autocast for a bf16 mode (what `ACCELERATE_MIXED_PRECISION=bf16` gives), else nothing."""
        return torch.autocast("cpu", dtype=torch.bfloat16) if self.mode.bf16 else contextlib.nullcontext()

    def step(self) -> int:
        """One optimiser step; returns the supervised steps (labels) it learned from."""
        batch = self.preprocessor(next(self.batches))
        with self.autocast():
            loss, info = self.policy.forward(batch)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(self.policy.parameters(), self.mode.config.optimizer_grad_clip_norm)
        self.optimizer.step()
        self.optimizer.zero_grad()
        return int(info["supervised_steps"])


def time_round(trainer: Trainer, steps: int) -> tuple[float, float]:
    """(optimiser steps per second, supervised steps per second) over `steps` steps."""
    labels = 0
    start = time.perf_counter()
    for _ in range(steps):
        labels += trainer.step()
    elapsed = time.perf_counter() - start
    return steps / elapsed, labels / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--root", required=True, help="root of a demo dataset (lerobot-ivmc-collect)")
    parser.add_argument("--repo-id", required=True)
    parser.add_argument("--episodes", type=int, default=200, help="first N episodes (cache fill time)")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps-per-round", type=int, default=20)
    parser.add_argument("--warmup-steps", type=int, default=3)
    parser.add_argument("--window-batch", type=int, default=32)
    parser.add_argument("--sequence-batch", type=int, default=4)
    parser.add_argument("--chunk-length", type=int, default=100)
    parser.add_argument("--bf16", action="store_true", help="also time sequence training under bf16 autocast")
    parser.add_argument(
        "--zero-chunk-memory",
        action="store_true",
        help="also time sequence training whose chunks start from zero memory (chunk_memory='zero')",
    )
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)

    meta = LeRobotDatasetMetadata(args.repo_id, root=args.root)
    episodes = list(range(min(args.episodes, meta.total_episodes)))
    # The paper's network in both modes (no goal or frame position head), as the README's figures.
    paper_net = dict(goal_head=False, frame_position_head=False)
    sequence = dict(training_mode="sequence", chunk_length=args.chunk_length, **paper_net)
    modes = [
        Mode("window", BVMCConfig(device="cpu", training_mode="window", **paper_net), args.window_batch),
        Mode("sequence", BVMCConfig(device="cpu", **sequence), args.sequence_batch),
    ]
    if args.bf16:
        modes.append(Mode("sequence_bf16", BVMCConfig(device="cpu", **sequence), args.sequence_batch, True))
    if args.zero_chunk_memory:
        zero = BVMCConfig(device="cpu", chunk_memory="zero", **sequence)
        modes.append(Mode("sequence_zero_mem", zero, args.sequence_batch))
    trainers = [Trainer(mode, meta, args.root, episodes) for mode in modes]
    for trainer in trainers:
        for _ in range(args.warmup_steps):
            trainer.step()
    rates: dict[str, list[tuple[float, float]]] = {mode.name: [] for mode in modes}
    for _ in range(args.rounds):
        for trainer in trainers:
            rates[trainer.mode.name].append(time_round(trainer, args.steps_per_round))

    print(
        f"threads={args.threads} episodes={len(episodes)} rounds={args.rounds}x{args.steps_per_round} steps; "
        f"window batch {args.window_batch} (K={modes[0].config.n_obs_steps}), sequence batch "
        f"{args.sequence_batch} chunks of up to {args.chunk_length} frames; native bf16 on this CPU: "
        f"{cpu_has_native_bf16()}"
    )
    base = statistics.median(r[1] for r in rates["window"])
    print(f"{'mode':<15} {'optim steps/s':>14} {'supervised steps/s':>19} {'vs window':>10}")
    for name, values in rates.items():
        optim = statistics.median(r[0] for r in values)
        supervised = statistics.median(r[1] for r in values)
        print(f"{name:<15} {optim:>14.2f} {supervised:>19.1f} {supervised / base:>9.2f}x")


if __name__ == "__main__":
    main()
