"""Env throughput with and without rendering, and the scripted experts' success rate per task.

python benchmarks/bench_env.py                 # 100 expert episodes per task
python benchmarks/bench_env.py --episodes 500  # the README's figure
"""

import argparse
import time

import numpy as np

from lerobot_ivmc.envs import TASKS, make_task_env
from lerobot_ivmc.scripts.run_experts import ExpertRunConfig, run_task


def steps_per_second(obs_type: str, image_size: int, n_steps: int = 300) -> float:
    env = make_task_env("pick_place", obs_type=obs_type, image_size=image_size, terminate_on_success=False)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, size=(n_steps, 4)).astype(np.float32)
    start = time.perf_counter()
    for action in actions:
        env.step(action)
    elapsed = time.perf_counter() - start
    env.close()
    return n_steps / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=100, help="expert episodes per task")
    args = parser.parse_args()

    print("env steps per second (one env, one process, 25 Hz control, 20 physics substeps):")
    no_render = steps_per_second("state", 64)
    for size in (64, 128):
        rate = steps_per_second("pixels_agent_pos", size)
        print(f"  rendering {size}x{size}: {rate:7.1f} steps/s  ({rate / no_render:.2f}x of physics only)")
    print(f"  physics only       : {no_render:7.1f} steps/s")

    print(f"expert success over {args.episodes} train scenes per task (seeds 0..{args.episodes - 1}):")
    for task in TASKS:
        start = time.perf_counter()
        rates = run_task(ExpertRunConfig(tasks=[task], n_episodes=args.episodes, n_videos=0), task)
        line = "  ".join(f"{name} {rate:6.1%}" for name, rate in rates.items())
        print(f"  {task:<11} {line}   ({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
