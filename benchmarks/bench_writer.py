"""The collector's writer: LeRobot's `save_episode` with its own row-by-row image embedding against the
collector's batched one (`datasets/assembler.py`), on the same staged expert episodes, in one run.

The episodes are recorded once (not timed), then assembled into a fresh LeRobotDataset with each
embedding, interleaved over `--rounds`; prints the median seconds per demo of each and their ratio, and
checks that both datasets hold the same table.

    python benchmarks/bench_writer.py --task pick_place --episodes 20 --rounds 3
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import tempfile
import time
from pathlib import Path

import pyarrow.parquet as pq

from lerobot_ivmc.datasets import expert_attempts, staging
from lerobot_ivmc.datasets.assembler import EpisodeAssembler, batched_image_embedding, quiet_datasets
from lerobot_ivmc.datasets.collect import recorder_args
from lerobot_ivmc.datasets.collect_config import CollectConfig


def assemble(cfg: CollectConfig, episodes: list[staging.StagedEpisode], root: Path, batched: bool) -> float:
    """Seconds per demo to append `episodes` to a new dataset in `root` (finalized)."""
    assembler = EpisodeAssembler(cfg, root)
    start = time.perf_counter()
    with quiet_datasets(), batched_image_embedding() if batched else contextlib.nullcontext():
        for episode in episodes:
            assembler.append(episode)
    assembler.dataset.finalize()
    return (time.perf_counter() - start) / len(episodes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="pick_place")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cfg = CollectConfig(task=args.task, num_episodes=args.episodes, root=tmp / "unused")
        (tmp / "staged").mkdir()
        recorder = expert_attempts.Recorder(*recorder_args(cfg, tmp / "staged"))
        successes, _ = staging.scan_attempts(tmp / "staged")
        attempt = 0
        while len(successes) < args.episodes:
            recorder.record(attempt)
            attempt += 1
            successes, _ = staging.scan_attempts(tmp / "staged")
        recorder.close()
        episodes = [staging.read_episode(successes[a]) for a in sorted(successes)]
        times: dict[bool, list[float]] = {False: [], True: []}
        tables = {}
        for round_index in range(args.rounds):
            for batched in (False, True):
                root = tmp / f"round{round_index}_{'batched' if batched else 'rows'}"
                times[batched].append(assemble(cfg, episodes, root, batched))
                tables[batched] = pq.read_table(sorted(root.glob("data/*/*.parquet"))[0])
    rows, batched = statistics.median(times[False]), statistics.median(times[True])
    same = tables[False].equals(tables[True])
    print(f"{args.episodes} {args.task} demos, median of {args.rounds} interleaved rounds:")
    print(f"  LeRobot's row-by-row embedding: {rows:.3f} s a demo")
    print(f"  batched embedding:              {batched:.3f} s a demo ({rows / batched:.2f}x)")
    print(f"  same table: {same}")


if __name__ == "__main__":
    main()
