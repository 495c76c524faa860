"""Cost of recovery: one min_unc step against one normal Bayesian VMC step, and eval episodes per minute.

Per-step latency (batch of one rollout, 64x64 frame, S Monte Carlo samples, median over interleaved rounds):
  bvmc step        `sample`: CNN + LSTM once, the head S times as one batched pass, mean and uncertainty
                   (what the controller runs at every normal step);
  min_unc step     the same plus the foresight head over the S candidate actions and their argmin;
  controller step  the controller's whole `select_action` in normal operation with the min_unc FIFO
                   (memory snapshot per step) against the bare `sample`.
The goal: a min_unc step costs at most 1.2x a normal step.

With `--policy-path` (a bvmc checkpoint with a foresight head and a threshold) it also runs
`lerobot-ivmc-eval` for `--episodes` test episodes with recovery none and min_unc and prints episodes per
minute of each.

Usage:
    python benchmarks/bench_recovery.py [--threads 1] [--rounds 20] [--calls 20]
        [--policy-path <checkpoint> --task pick_place --episodes 20 --batch-size 10]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

import torch
from bench_policy import IMAGE_KEY, make_policy, time_interleaved
from lerobot.utils.constants import OBS_ENV_STATE, OBS_STATE

from lerobot_ivmc.envs.fetch_env import EMBODIMENT as FETCH_EMBODIMENT
from lerobot_ivmc.policies import BVMCConfig, BVMCPolicy
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.controller import IntrospectiveController


def step_latency(rounds: int, calls: int, image_size: int) -> dict[str, tuple[float, float]]:
    policy = make_policy(BVMCPolicy, BVMCConfig, image_size, "window")
    policy.attach_foresight()
    batch = {
        IMAGE_KEY: torch.rand(1, 3, image_size, image_size),
        OBS_STATE: torch.randn(1, 9),
        OBS_ENV_STATE: torch.randn(1, 6),
    }
    controller = IntrospectiveController(
        policy,
        RecoveryConfig(mode="min_unc"),
        1e9,
        20,
        (torch.zeros(6), torch.ones(6)),
        embodiment=FETCH_EMBODIMENT,
    )
    controller.reset()
    policy.reset()
    policy.sample(batch)
    memory = policy.get_memory()

    def bvmc_step():
        policy.set_memory(memory)
        return policy.sample(batch)

    def min_unc_step():
        policy.set_memory(memory)
        prediction = policy.sample(batch)
        return controller._min_unc_action(prediction, 0)

    def controller_step():
        policy.set_memory(memory)
        return controller.select_action(batch)

    with torch.no_grad():
        return time_interleaved(
            {"bvmc step": bvmc_step, "min_unc step": min_unc_step, "controller step": controller_step},
            rounds,
            calls,
        )


def episodes_per_minute(policy_path: str, task: str, episodes: int, batch_size: int) -> dict[str, float]:
    from lerobot_ivmc.scripts.lerobot_ivmc_eval import eval_main

    rates = {}
    with tempfile.TemporaryDirectory() as out:
        for mode in ("none", "min_unc"):
            argv = [
                "lerobot-ivmc-eval",
                f"--policy.path={policy_path}",
                "--env.type=ivmc",
                f"--env.task={task}",
                f"--eval.n_episodes={episodes}",
                f"--eval.batch_size={batch_size}",
                "--seed=0",
                f"--recovery.mode={mode}",
                "--recovery.max_videos=0",
                f"--output_dir={Path(out) / mode}",
            ]
            start = time.perf_counter()
            with mock.patch.object(sys, "argv", argv):
                info = eval_main()
            rates[mode] = episodes / (time.perf_counter() - start) * 60
            rates[f"{mode} recoveries"] = info["recovery"]["num_recoveries"]
    return rates


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=20)
    parser.add_argument("--calls", type=int, default=20)
    parser.add_argument("--image-size", type=int, default=64)
    parser.add_argument("--policy-path")
    parser.add_argument("--task", default="pick_place")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--batch-size", type=int, default=10)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)

    timings = step_latency(args.rounds, args.calls, args.image_size)
    base = timings["bvmc step"][0]
    print(
        f"Per-step latency, batch 1, S={BVMCConfig().num_samples}, {args.threads} thread(s), median (best):"
    )
    for name, (median, best) in timings.items():
        print(f"  {name:<16} {median * 1e3:7.3f} ms ({best * 1e3:.3f})  {median / base:5.2f}x bvmc step")
    if args.policy_path:
        rates = episodes_per_minute(args.policy_path, args.task, args.episodes, args.batch_size)
        print(f"Eval on {args.episodes} {args.task} test episodes, batch {args.batch_size}:")
        for mode in ("none", "min_unc"):
            print(f"  {mode:<8} {rates[mode]:6.1f} episodes/min ({rates[f'{mode} recoveries']} recoveries)")


if __name__ == "__main__":
    main()
