"""The `lite` training step against the machine's GEMM rate, in one run: where a training step's time goes.

The step is `lerobot-ivmc-train`'s (LeRobot's delta indices, `FrameCache`, the pre-processor, forward,
backward, gradient clipping and Adam) with the `lite` preset's policy (sequence training on whole demos,
goal and frame position heads, `--batch-size` demos a step). It prints, from one run (interleaved rounds,
medians):

- the step's floating-point work (forward and backward, `torch.utils.flop_counter`) and its rate in fp32
  and under bf16 autocast, against a square GEMM's rate in the same dtype measured between the rounds;
- where a step's time goes: the batch (loader and pre-processor), forward, backward, the optimiser; and,
  from `torch.profiler`, the forward and backward's own operator time by kind (convolutions, the LSTM,
  linear layers, the image shift augmentation, element-wise and the rest);
- with `--variants`, other ways to run the same step, as ratios to the default: `channels_last` (the CNN's
  weights and activations in NHWC) and `compile` (`torch.compile` of the CNN; its compile time is printed).

    python benchmarks/bench_training_rate.py --root <study>/data --repo-id local/ivmc_push \\
        [--episodes 40] [--threads 2] [--rounds 3] [--steps-per-round 12] [--variants channels_last compile]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict

import torch
from bench_training import Mode, Trainer
from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata
from torch.profiler import ProfilerActivity, profile
from torch.utils.flop_counter import FlopCounterMode

from lerobot_ivmc.hardware import cpu_has_native_bf16
from lerobot_ivmc.policies import BVMCConfig

GEMM_SIZE = 2048
# Operator kinds of the profile, by a substring of the operator's name (first match wins).
OP_KINDS = (
    ("convolution", ("convolution",)),
    ("LSTM", ("rnn", "lstm")),
    ("linear", ("aten::mm", "aten::addmm", "aten::bmm", "aten::linear")),
    ("image shift", ("aten::index", "replication_pad")),
    ("element-wise", ("clamp", "threshold", "relu", "aten::mul", "aten::add", "aten::sub", "aten::div")),
)
PHASES = ("batch", "forward", "backward", "optimiser")


def lite_config(chunk_length: int) -> BVMCConfig:
    """The `lite` preset's policy (lerobot_ivmc/pipeline/presets/lite.yaml), #fc = 1."""
    return BVMCConfig(
        device="cpu",
        num_fc_layers=1,
        training_mode="sequence",
        chunk_length=chunk_length,
        goal_head=True,
        frame_position_head=True,
    )


def apply_variant(trainer: Trainer, variant: str) -> float:
    """Run `trainer`'s step as `variant`; returns the seconds it took to set up (compile: its first steps)."""
    start = time.perf_counter()
    if variant == "channels_last":
        trainer.policy.net.cnn.to(memory_format=torch.channels_last)
    elif variant == "compile":
        trainer.policy.net.cnn = torch.compile(trainer.policy.net.cnn)
        for _ in range(2):
            trainer.step()
    elif variant != "default":
        raise ValueError(f"Unknown variant {variant!r}: use channels_last or compile.")
    return time.perf_counter() - start


def step_flops(trainer: Trainer) -> tuple[float, int]:
    """(forward + backward FLOPs of one step, frames it learned from), counted on the next batch."""
    batch = trainer.preprocessor(next(trainer.batches))
    counter = FlopCounterMode(display=False)  # (entering it again would reset its counts)
    with counter:
        with trainer.autocast():
            loss, info = trainer.policy.forward(batch)
        loss.backward()
    trainer.optimizer.zero_grad()
    return float(counter.get_total_flops()), int(info["supervised_steps"])


def timed_phases(trainer: Trainer, steps: int) -> dict[str, float]:
    """Seconds per step in each of `PHASES`, over `steps` steps."""
    totals: dict[str, float] = defaultdict(float)
    for _ in range(steps):
        t0 = time.perf_counter()
        batch = trainer.preprocessor(next(trainer.batches))
        t1 = time.perf_counter()
        with trainer.autocast():
            loss, _ = trainer.policy.forward(batch)
        t2 = time.perf_counter()
        loss.backward()
        t3 = time.perf_counter()
        clip = trainer.mode.config.optimizer_grad_clip_norm
        torch.nn.utils.clip_grad_norm_(trainer.policy.parameters(), clip)
        trainer.optimizer.step()
        trainer.optimizer.zero_grad()
        t4 = time.perf_counter()
        for phase, seconds in zip(PHASES, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
            totals[phase] += seconds
    return {phase: totals[phase] / steps for phase in PHASES}


def operator_shares(trainer: Trainer, steps: int) -> dict[str, float]:
    """Share of the forward and backward's own operator time (profiled over `steps` steps) by kind."""
    by_kind: dict[str, float] = defaultdict(float)
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for _ in range(steps):
            batch = trainer.preprocessor(next(trainer.batches))
            with trainer.autocast():
                loss, _ = trainer.policy.forward(batch)
            loss.backward()
            trainer.optimizer.zero_grad()
    for event in prof.key_averages():
        if not event.key.startswith("aten::") and "rnn" not in event.key:
            continue
        kind = next((k for k, names in OP_KINDS if any(n in event.key for n in names)), "other")
        by_kind[kind] += event.self_cpu_time_total
    total = sum(by_kind.values())
    return {kind: by_kind[kind] / total for kind in [*(k for k, _ in OP_KINDS), "other"]}


def gemm_rate(dtype: torch.dtype, shape: tuple[int, int, int] = (GEMM_SIZE,) * 3, repeats: int = 5) -> float:
    """GFLOP/s of an (M, K) x (K, N) matrix product in `dtype` (the best of `repeats`); `shape` = (M, K, N),
    by default square."""
    m, k, n = shape
    a, b = torch.randn(m, k).to(dtype), torch.randn(k, n).to(dtype)
    torch.mm(a, b)
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        torch.mm(a, b)
        best = min(best, time.perf_counter() - start)
    return 2 * m * k * n / best / 1e9


def conv_gemm_shapes(trainer: Trainer, frames: int) -> list[tuple[int, int, int]]:
    """Each CNN layer as the GEMM it amounts to over a step's `frames` (im2col): (frames x output
    pixels, input channels x kernel area, output channels)."""
    shapes = []

    def record(module: torch.nn.Conv2d, _inputs, output: torch.Tensor) -> None:
        kernel_area = module.kernel_size[0] * module.kernel_size[1]
        pixels = output.shape[-2] * output.shape[-1]
        shapes.append((frames * pixels, module.in_channels * kernel_area, module.out_channels))

    convs = [m for m in trainer.policy.net.cnn.modules() if isinstance(m, torch.nn.Conv2d)]
    hooks = [conv.register_forward_hook(record) for conv in convs]
    image_shape = trainer.policy.config.image_features[next(iter(trainer.policy.config.image_features))].shape
    with torch.no_grad():
        trainer.policy.net.cnn(torch.zeros(1, *image_shape))
    for hook in hooks:
        hook.remove()
    return shapes


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--root", required=True, help="root of a demo dataset (lerobot-ivmc-collect)")
    parser.add_argument("--repo-id", required=True)
    parser.add_argument("--episodes", type=int, default=40, help="first N episodes (cache fill time)")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--steps-per-round", type=int, default=12)
    parser.add_argument("--batch-size", type=int, default=2, help="demos a step (the lite preset's 2)")
    parser.add_argument("--chunk-length", type=int, default=100, help="the demos' length")
    parser.add_argument("--variants", nargs="*", default=[], choices=["channels_last", "compile"])
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)

    meta = LeRobotDatasetMetadata(args.repo_id, root=args.root)
    episodes = list(range(min(args.episodes, meta.total_episodes)))
    config = lite_config(args.chunk_length)
    runs = [("fp32", "default", False), ("bf16", "default", True)]
    runs += [("bf16" if cpu_has_native_bf16() else "fp32", v, cpu_has_native_bf16()) for v in args.variants]
    trainers, setup_s = {}, {}
    for dtype, variant, bf16 in runs:
        mode = Mode(f"{dtype} {variant}", config, args.batch_size, bf16)
        trainer = Trainer(mode, meta, args.root, episodes)
        for _ in range(2):
            trainer.step()
        setup_s[(dtype, variant)] = apply_variant(trainer, variant)
        trainers[(dtype, variant)] = trainer
    flops, frames = step_flops(trainers[("fp32", "default")])

    steps_per_s: dict[tuple[str, str], list[float]] = defaultdict(list)
    gemm: dict[str, list[float]] = defaultdict(list)
    for _ in range(args.rounds):
        for key, trainer in trainers.items():
            start = time.perf_counter()
            for _ in range(args.steps_per_round):
                trainer.step()
            steps_per_s[key].append(args.steps_per_round / (time.perf_counter() - start))
        gemm["fp32"].append(gemm_rate(torch.float32))
        gemm["bf16"].append(gemm_rate(torch.bfloat16))

    print(
        f"threads={args.threads}, {args.batch_size} demos of {args.chunk_length} frames a step "
        f"({frames} frames), native bf16: {cpu_has_native_bf16()}; one step: {flops / 1e9:.2f} GFLOP "
        f"forward and backward ({flops / frames / 1e6:.1f} MFLOP a frame)"
    )
    print(f"{'run':<22} {'steps/s':>8} {'frames/s':>9} {'GFLOP/s':>8} {'GEMM GFLOP/s':>13} {'of GEMM':>8}")
    for (dtype, variant), rates in steps_per_s.items():
        rate = statistics.median(rates)
        gemm_gflops = statistics.median(gemm[dtype])
        gflops = rate * flops / 1e9
        print(
            f"{dtype + ' ' + variant:<22} {rate:>8.2f} {rate * frames:>9.0f} {gflops:>8.1f} "
            f"{gemm_gflops:>13.1f} {gflops / gemm_gflops:>7.0%}"
        )
    shapes = conv_gemm_shapes(trainers[("fp32", "default")], frames)
    for dtype, torch_dtype in (("fp32", torch.float32), ("bf16", torch.bfloat16)):
        square = statistics.median(gemm[dtype])
        layer_rates = [gemm_rate(torch_dtype, shape) for shape in shapes]
        print(
            f"{dtype}: the CNN's layers as GEMMs (M x K x N = "
            + ", ".join(f"{m}x{k}x{n}" for m, k, n in shapes)
            + "): "
            + ", ".join(f"{rate:.0f}" for rate in layer_rates)
            + f" GFLOP/s ({', '.join(f'{rate / square:.0%}' for rate in layer_rates)} of the square GEMM)"
        )
    for dtype in ("fp32", "bf16"):
        base = statistics.median(steps_per_s[(dtype, "default")])
        for (other_dtype, variant), rates in steps_per_s.items():
            if other_dtype == dtype and variant != "default":
                print(
                    f"{variant} ({dtype}): {statistics.median(rates) / base:.2f}x the default "
                    f"(set-up {setup_s[(dtype, variant)]:.0f} s)"
                )
    for dtype in ("fp32", "bf16"):
        trainer = trainers[(dtype, "default")]
        phases = timed_phases(trainer, args.steps_per_round)
        step_s = sum(phases.values())
        print(
            f"{dtype} step {step_s * 1e3:.1f} ms: "
            + ", ".join(f"{phase} {seconds / step_s:.0%}" for phase, seconds in phases.items())
        )
        shares = operator_shares(trainer, 4)
        print(
            f"{dtype} forward and backward operators: "
            + ", ".join(f"{kind} {share:.0%}" for kind, share in shares.items())
        )


if __name__ == "__main__":
    main()
