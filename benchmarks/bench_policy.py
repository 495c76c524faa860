"""CPU latency of one control step for VMC and Bayesian VMC, and training throughput.

Per-step latency (batch of one rollout, 64x64 frame):
  vmc            one deterministic step (`select_action`);
  bvmc batched   one step with S Monte Carlo samples: CNN + LSTM once, the head as one batched pass, plus
                 the mean action and the uncertainty (`sample`);
  bvmc naive     S full passes (CNN + LSTM + head, each from the same LSTM memory), plus the same reductions.
The paper's goal for this repository: bvmc batched costs at most 1.2x a vmc step.

Training throughput: forward + backward + Adam step on K-frame windows, in samples/s and frames/s
(frames = samples x K images through the CNN). Data loading is not included.

Usage:
    python benchmarks/bench_policy.py [--rounds 30] [--calls 20] [--num-samples 50] [--batch-size 32]
        [--threads N]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import torch
from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from lerobot_ivmc.policies import BVMCConfig, BVMCPolicy, VMCConfig, VMCPolicy
from lerobot_ivmc.policies.bvmc.modeling_bvmc import make_prediction
from lerobot_ivmc.policies.vmc.configuration_vmc import ROLLOUT_MEMORY_MODES

IMAGE_KEY = "observation.images.front"


def make_policy(
    cls: type[VMCPolicy], config_cls: type[VMCConfig], image_size: int, rollout_memory: str
) -> VMCPolicy:
    inputs = {
        IMAGE_KEY: PolicyFeature(type=FeatureType.VISUAL, shape=(3, image_size, image_size)),
        OBS_STATE: PolicyFeature(type=FeatureType.STATE, shape=(9,)),
        OBS_ENV_STATE: PolicyFeature(type=FeatureType.ENV, shape=(6,)),
    }
    outputs = {ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(4,))}
    extra = {"dataset_size": 100_000} if config_cls is BVMCConfig else {}
    config = config_cls(
        device="cpu",
        input_features=inputs,
        output_features=outputs,
        rollout_memory=rollout_memory,
        # Window training (its K = 4 training batches below) and the paper's network, as the README's figures.
        training_mode="window",
        goal_head=False,
        frame_position_head=False,
        **extra,
    )
    return cls(config).eval()


def time_per_call(fn: Callable[[], object], steps: int, warmup: int = 10) -> float:
    """Median seconds per call over `steps` calls."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(steps):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def time_interleaved(
    fns: dict[str, Callable[[], object]], rounds: int, calls: int
) -> dict[str, tuple[float, float]]:
    """(median, best) over rounds of the mean seconds per call; variants alternate so drift hits all alike.

    The best round is the least disturbed by other load on the machine.
    """
    for fn in fns.values():
        for _ in range(calls):
            fn()
    per_round: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(rounds):
        for name, fn in fns.items():
            start = time.perf_counter()
            for _ in range(calls):
                fn()
            per_round[name].append((time.perf_counter() - start) / calls)
    return {name: (statistics.median(values), min(values)) for name, values in per_round.items()}


def naive_step(policy: BVMCPolicy, obs: dict[str, torch.Tensor], num_samples: int) -> None:
    """S full passes from the same memory, as a model without the batched head would run."""
    memory = policy.get_memory()
    deltas, probs = [], []
    for _ in range(num_samples):
        policy.set_memory(memory)
        embedding = policy.step_embedding(obs)
        delta_ee, p = policy.sample_head(embedding, 1)
        deltas.append(delta_ee)
        probs.append(p)
    make_prediction(
        embedding,
        torch.cat(deltas, 1),
        torch.cat(probs, 1),
        policy.config.uncertainty_lambda,
        policy.config.gripper,
    )


def training_throughput(policy: VMCPolicy, batch_size: int, steps: int, image_size: int) -> float:
    """Training samples per second (forward, backward, Adam step)."""
    k = policy.config.n_obs_steps
    batch = {
        IMAGE_KEY: torch.rand(batch_size, k, 3, image_size, image_size),
        OBS_STATE: torch.randn(batch_size, k, 9),
        OBS_ENV_STATE: torch.randn(batch_size, k, 6),
        ACTION: torch.cat([torch.rand(batch_size, 3) * 2 - 1, torch.randint(-1, 2, (batch_size, 1))], -1),
        f"{OBS_STATE}_is_pad": torch.zeros(batch_size, k, dtype=torch.bool),
    }
    optimizer = torch.optim.Adam(policy.parameters(), lr=1e-4)
    policy.train()

    def train_step() -> None:
        loss, _ = policy.forward(batch)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()

    seconds = time_per_call(train_step, steps, warmup=3)
    policy.eval()
    return batch_size / seconds


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--rounds", type=int, default=30, help="timing rounds (variants alternate)")
    parser.add_argument("--calls", type=int, default=20, help="control steps per variant per round")
    parser.add_argument("--num-samples", type=int, default=50, help="S, Monte Carlo samples")
    parser.add_argument("--batch-size", type=int, default=32, help="training batch size")
    parser.add_argument("--train-steps", type=int, default=20, help="timed training steps")
    parser.add_argument("--image-size", type=int, default=64)
    parser.add_argument("--threads", type=int, default=None, help="torch threads (default: torch's)")
    parser.add_argument(
        "--rollout-memory", default="window", choices=ROLLOUT_MEMORY_MODES, help="policies' rollout memory"
    )
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    torch.manual_seed(0)

    vmc = make_policy(VMCPolicy, VMCConfig, args.image_size, args.rollout_memory)
    bvmc = make_policy(BVMCPolicy, BVMCConfig, args.image_size, args.rollout_memory)
    obs = {
        IMAGE_KEY: torch.rand(1, 3, args.image_size, args.image_size),
        OBS_STATE: torch.randn(1, 9),
    }
    s = args.num_samples
    with torch.inference_mode():
        times = time_interleaved(
            {
                "vmc": lambda: vmc.select_action(obs),
                "batched": lambda: bvmc.sample(obs, s),
                "select": lambda: bvmc.select_action(obs),
            },
            rounds=args.rounds,
            calls=args.calls,
        )
        t_naive = time_per_call(lambda: naive_step(bvmc, obs, s), max(args.rounds // 2, 5), warmup=2)

    print(
        f"torch {torch.__version__}, {torch.get_num_threads()} threads, {args.image_size}x{args.image_size}, "
        f"rollout_memory={args.rollout_memory}"
    )
    print(
        f"per-step latency, batch of 1 rollout, median (best) of {args.rounds} rounds x {args.calls} steps:"
    )
    t_vmc = times["vmc"]

    def row(label: str, t: tuple[float, float], note: str = "") -> None:
        ratio = f"{t[0] / t_vmc[0]:5.2f}x ({t[1] / t_vmc[1]:5.2f}x) vmc" if t is not t_vmc else ""
        print(f"  {label:27s} {t[0] * 1e3:7.3f} ms ({t[1] * 1e3:7.3f})   {ratio} {note}")

    row("vmc select_action", t_vmc)
    row(f"bvmc S={s} batched sample", times["batched"], "(mean action + uncertainty)")
    row(f"bvmc S={s} select_action", times["select"], "(mean action)")
    print(
        f"  bvmc S={s} naive full passes {t_naive * 1e3:7.3f} ms             {t_naive / t_vmc[0]:5.1f}x vmc, "
        f"{t_naive / times['batched'][0]:5.1f}x batched"
    )
    best = times["batched"][1] / t_vmc[1]
    median = times["batched"][0] / t_vmc[0]
    print(f"  goal bvmc batched <= 1.2x vmc: median {median:.2f}x, best {best:.2f}x")

    k = vmc.config.n_obs_steps
    print(f"training throughput (batch {args.batch_size}, K={k} frames per sample, no data loading):")
    for name, policy in (("vmc", vmc), ("bvmc", bvmc)):
        sps = training_throughput(policy, args.batch_size, args.train_steps, args.image_size)
        print(f"  {name:5s} {sps:8.1f} samples/s   {sps * k:8.1f} frames/s")


if __name__ == "__main__":
    main()
