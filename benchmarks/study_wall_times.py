"""What a recorded study would take on more cores: its stage graph rebuilt from the results JSON's stage
names, each stage at its recorded wall time (measured on 2 cores), scheduled by the ray executor's rule
(a stage starts once what it waits for has finished and its CPUs are free; trainings 2 CPUs, the collector
its 2 workers, the others 1).

Prints per study: the sum of stage times (the local executor's elapsed time, measured), the critical path
(unlimited workers), and the elapsed time simulated on N CPUs. These are estimates that assume every stage
runs as fast beside others as it did alone on 2 cores (memory bandwidth and the collector's single writer
aside); the ratios are within one run.

Usage:
    python benchmarks/study_wall_times.py docs/results/archive/pick_place.json [...] [--cpus 2 16]
"""

from __future__ import annotations

import argparse
import heapq
import json
from pathlib import Path

from lerobot_ivmc.pipeline.config import DEFAULT_MODES
from lerobot_ivmc.pipeline.critical_path import critical_path
from lerobot_ivmc.pipeline.stages import Stage, build_stages
from lerobot_ivmc.pipeline.study import parse_config


def recorded_study(results: dict) -> tuple[list[Stage], dict[str, float]]:
    """The stages of the study whose results JSON is `results` (its #fc values, extra seeds and recovery
    rows read from its stage names) and their recorded wall times."""
    wall = results["stage_wall_s"]
    fcs = sorted({int(name.split("_fc")[1][0]) for name in wall if name.startswith("train_")})
    seeds = sorted({int(name.split("_seed")[1]) for name in wall if "_seed" in name})
    modes = [m for m in DEFAULT_MODES if any(name.startswith(f"eval_bvmc_fc{fcs[0]}_{m}") for name in wall)]
    cfg = parse_config(
        [
            f"--task={results['task']}",
            f"--preset={results['preset']}",
            f"--train.num_fc_layers=[{','.join(map(str, fcs))}]",
            f"--train.extra_seeds=[{','.join(map(str, seeds))}]",
            f"--recovery_modes=[{','.join(modes)}]",
            "--output_dir=/nonexistent",
        ]
    )
    stages = [stage for stage in build_stages(cfg) if stage.name in wall]
    for stage in stages:  # waits for stages the recorded study did not have are dropped
        stage.depends = [name for name in stage.depends if name in wall]
        stage.after = [name for name in stage.after if name in wall]
    return stages, wall


def simulated_elapsed(stages: list[Stage], wall: dict[str, float], cpus: int) -> float:
    """Elapsed time with `cpus` CPUs: each stage starts, in the list's order, once what it waits for has
    finished and its CPUs (at most `cpus`) are free."""
    clock, free, finished = 0.0, float(cpus), set()
    running: list[tuple[float, str, float]] = []
    waiting = list(stages)
    while waiting or running:
        for stage in list(waiting):
            need = min(stage.resources.cpus, cpus)
            if finished.issuperset(stage.prerequisites) and need <= free:
                free -= need
                heapq.heappush(running, (clock + wall[stage.name], stage.name, need))
                waiting.remove(stage)
        clock, name, need = heapq.heappop(running)
        free += need
        finished.add(name)
    return clock


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="+", type=Path)
    parser.add_argument("--cpus", nargs="+", type=int, default=[2, 16])
    args = parser.parse_args()
    header = "| study | stages | sum of stage times | critical path |" + "".join(
        f" {n} CPUs (simulated) |" for n in args.cpus
    )
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for path in args.results:
        results = json.loads(path.read_text())
        stages, wall = recorded_study(results)
        total = sum(wall[s.name] for s in stages)
        path_s, _ = critical_path(stages, wall)
        cells = [f"{total / 3600:.2f} h", f"{path_s / 3600:.2f} h ({total / path_s:.1f}x)"]
        for n in args.cpus:
            elapsed = simulated_elapsed(stages, wall, n)
            cells.append(f"{elapsed / 3600:.2f} h ({total / elapsed:.1f}x)")
        print(f"| {path.stem} | {len(stages)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
