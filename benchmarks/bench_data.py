"""Sample and batch throughput of K-frame windows: LeRobotDataset vs FrameCache, measured in one run.

Example:
    python benchmarks/bench_data.py --root data/ivmc_pick_place --repo-id local/ivmc_pick_place
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from lerobot_ivmc.datasets import DEMO_FPS, ENV_STATE_KEY, IMAGE_KEY, STATE_KEY
from lerobot_ivmc.datasets.frame_cache import FrameCache


def samples_per_second(dataset: torch.utils.data.Dataset, indices: np.ndarray, batch_size: int) -> float:
    """Samples per second through a single-process DataLoader that collates batches of the given indices."""
    loader = torch.utils.data.DataLoader(
        torch.utils.data.Subset(dataset, indices.tolist()), batch_size=batch_size, num_workers=0
    )
    start = time.perf_counter()
    for _ in loader:
        pass
    return len(indices) / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--root", required=True, help="dataset root (an image dataset)")
    parser.add_argument("--repo-id", required=True)
    parser.add_argument("--k", type=int, default=4, help="frames of history per sample")
    parser.add_argument("--samples", type=int, default=1024)
    parser.add_argument("--batch-size", type=int, default=32)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    torch.set_num_threads(1)

    delta = {
        key: [k / DEMO_FPS for k in range(1 - args.k, 1)] for key in (IMAGE_KEY, STATE_KEY, ENV_STATE_KEY)
    }
    dataset = LeRobotDataset(args.repo_id, root=args.root, delta_timestamps=delta)
    start = time.perf_counter()
    cache = FrameCache(LeRobotDataset(args.repo_id, root=args.root, delta_timestamps=delta))
    fill_s = time.perf_counter() - start
    indices = np.random.default_rng(args.seed).choice(len(dataset), size=args.samples, replace=False)

    plain = samples_per_second(dataset, indices, args.batch_size)
    cached = samples_per_second(cache, indices, args.batch_size)
    image_gib = sum(cache.columns[key].numel() for key in cache.image_keys) / 2**30
    print(f"dataset: {len(dataset)} frames, {args.k}-frame windows, batch {args.batch_size}, 1 thread")
    print(f"FrameCache fill: {fill_s:.1f} s, {image_gib:.2f} GiB of uint8 images")
    print(f"LeRobotDataset: {plain:8.1f} samples/s  ({1e3 / plain:.2f} ms/sample)")
    print(f"FrameCache:     {cached:8.1f} samples/s  ({1e3 / cached:.3f} ms/sample)")
    print(f"speed-up: {cached / plain:.1f}x")


if __name__ == "__main__":
    main()
