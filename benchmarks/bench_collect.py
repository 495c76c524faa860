"""Throughput of `lerobot-ivmc-collect`: demos per minute and frames per second, with 1 and 2 workers.

Each run records `--dataset.num_episodes` expert demos into a fresh temporary LeRobotDataset, end to end
(worker start-up, rendering, staging, LeRobot's writer, finalize and publish), and projects the time for
1,000 demos linearly from it. The projection carries the start-up cost over, so it slightly overestimates.
The goal on a 2-core machine: 1,000 push demos at 64x64 in under 15 minutes. The flags are the collector's
own (`--env.*`, `--dataset.*`; the root is a temporary folder) plus `--workers`, the worker counts to time:

    python benchmarks/bench_collect.py --env.task=push --dataset.num_episodes=40 --env.image_size=64 \\
        --workers=[1,2]

With `--compare_before=true` each worker count is timed twice, interleaved, and the ratio printed: before
the throughput work (the "fetch" render style, LeRobot's row-by-row image embedding in its writer) and
today (`--env.render_style`, default "fast", and the collector's batched embedding).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from unittest import mock

import draccus

from lerobot_ivmc.datasets import collect
from lerobot_ivmc.datasets.collect import collect_demos
from lerobot_ivmc.datasets.record_config import DemoDatasetConfig, DemoEnvConfig, RecordDemosConfig

GOAL_EPISODES, GOAL_MINUTES = 1000, 15.0


@dataclass
class BenchCollectConfig:
    """What to collect, as `lerobot-ivmc-collect`'s `--env.*` and `--dataset.*`, and with how many workers.

    Args:
        env: scenes and camera (default: push at 64x64).
        dataset: how many demos each run records (default 40); `root` is a temporary folder.
        workers: the `--num_workers` values to time, one run each.
        seed: base seed of the attempts' scene seeds.
        compare_before: also time the collection as it was before the throughput work, and print ratios.
    """

    env: DemoEnvConfig = field(default_factory=DemoEnvConfig)
    dataset: DemoDatasetConfig = field(default_factory=DemoDatasetConfig)
    workers: list[int] = field(default_factory=lambda: [1, 2])
    seed: int = 0
    compare_before: bool = False

    def __post_init__(self) -> None:
        # The benchmark's defaults, where the collector has none (set here: draccus builds a nested section
        # a flag names from its class's defaults, not from a default factory).
        self.env.task = self.env.task or "push"
        self.dataset.num_episodes = self.dataset.num_episodes or 40


def bench(cfg: BenchCollectConfig, num_workers: int, before: bool = False) -> dict[str, float]:
    """Collect the demos of `cfg` with `num_workers` in a temporary folder; return rates and projection.
    `before`: the "fetch" style and LeRobot's own row-by-row image embedding in the writer."""
    env = dataclasses.replace(cfg.env, render_style="fetch") if before else cfg.env
    row_by_row = mock.patch.object(collect, "batched_image_embedding", contextlib.nullcontext)
    with tempfile.TemporaryDirectory() as tmp, row_by_row if before else contextlib.nullcontext():
        dataset = dataclasses.replace(cfg.dataset, root=Path(tmp) / f"ivmc_{cfg.env.task}")
        record = RecordDemosConfig(
            env=env, dataset=dataset, num_workers=num_workers, seed=cfg.seed, progress=False
        )
        summary = collect_demos(record.to_collect_config())
    elapsed = summary.elapsed_s
    return {
        "elapsed_s": elapsed,
        "demos_per_min": 60 * summary.num_episodes / elapsed,
        "frames_per_s": summary.num_frames / elapsed,
        "projected_1000_min": elapsed / summary.num_episodes * GOAL_EPISODES / 60,
        "failed": summary.failed_attempts,
    }


def main() -> None:
    cfg = draccus.parse(config_class=BenchCollectConfig)
    logging.basicConfig(level=logging.WARNING)

    size, steps = cfg.env.image_size, cfg.dataset.episode_steps
    print(f"{cfg.env.task}, {cfg.dataset.num_episodes} demos of {steps} frames at {size}x{size}")
    header = ("workers", "time s", "demos/min", "frames/s", "1000 demos (min)", "goal")
    print(" ".join(f"{name:>{width}}" for name, width in zip(header, (7, 8, 10, 9, 17, 5), strict=True)))
    for workers in cfg.workers:
        result = bench(cfg, workers)
        ok = "ok" if result["projected_1000_min"] < GOAL_MINUTES else "MISS"
        print(
            f"{workers:>7} {result['elapsed_s']:>8.1f} {result['demos_per_min']:>10.1f} "
            f"{result['frames_per_s']:>9.0f} {result['projected_1000_min']:>17.1f} {ok:>5}"
        )
        if cfg.compare_before:
            old = bench(cfg, workers, before=True)
            print(
                f"{'before':>7} {old['elapsed_s']:>8.1f} {old['demos_per_min']:>10.1f} "
                f"{old['frames_per_s']:>9.0f} {old['projected_1000_min']:>17.1f}   "
                f"today {old['elapsed_s'] / result['elapsed_s']:.2f}x before"
            )


if __name__ == "__main__":
    main()
