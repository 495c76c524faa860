"""Throughput of `lerobot-ivmc-collect`: demos per minute and frames per second, with 1 and 2 workers.

Each run records `--num-episodes` expert demos into a fresh temporary LeRobotDataset, end to end (worker
start-up, rendering, staging, LeRobot's writer, finalize and publish), and projects the time for 1,000
demos linearly from it. The projection carries the start-up cost over, so it slightly overestimates.
The goal on a 2-core machine: 1,000 push demos at 64x64 in under 15 minutes.

    python benchmarks/bench_collect.py --task push --num-episodes 40 --image-size 64 --workers 1 2
"""

from __future__ import annotations

import argparse
import logging
import tempfile
from pathlib import Path

from lerobot_ivmc.datasets.collect import CollectConfig, collect_demos
from lerobot_ivmc.envs import TASKS

GOAL_EPISODES, GOAL_MINUTES = 1000, 15.0


def bench(task: str, num_episodes: int, image_size: int, num_workers: int) -> dict[str, float]:
    """Collect `num_episodes` demos into a temporary folder; return rates and the projected time."""
    with tempfile.TemporaryDirectory() as tmp:
        cfg = CollectConfig(
            task=task,
            num_episodes=num_episodes,
            root=Path(tmp) / f"ivmc_{task}",
            image_size=image_size,
            num_workers=num_workers,
            progress=False,
        )
        summary = collect_demos(cfg)
    elapsed = summary.elapsed_s
    return {
        "elapsed_s": elapsed,
        "demos_per_min": 60 * summary.num_episodes / elapsed,
        "frames_per_s": summary.num_frames / elapsed,
        "projected_1000_min": elapsed / summary.num_episodes * GOAL_EPISODES / 60,
        "failed": summary.failed_attempts,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--task", default="push", choices=TASKS)
    parser.add_argument("--num-episodes", type=int, default=40)
    parser.add_argument("--image-size", type=int, default=64)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)

    print(f"{args.task}, {args.num_episodes} demos of 100 frames at {args.image_size}x{args.image_size}")
    header = ("workers", "time s", "demos/min", "frames/s", "1000 demos (min)", "goal")
    print(" ".join(f"{name:>{width}}" for name, width in zip(header, (7, 8, 10, 9, 17, 5), strict=True)))
    for workers in args.workers:
        result = bench(args.task, args.num_episodes, args.image_size, workers)
        ok = "ok" if result["projected_1000_min"] < GOAL_MINUTES else "MISS"
        print(
            f"{workers:>7} {result['elapsed_s']:>8.1f} {result['demos_per_min']:>10.1f} "
            f"{result['frames_per_s']:>9.0f} {result['projected_1000_min']:>17.1f} {ok:>5}"
        )


if __name__ == "__main__":
    main()
