"""Closed-loop success against training wall time: every checkpoint of a training run on the same scenes.

A training's loss does not show when a policy starts to succeed (place success on pick_place emerges late),
so learning curves are compared in closed loop. Each numbered checkpoint under `<train-dir>/checkpoints/`
is evaluated with `lerobot-ivmc-eval` on the same scenes (kept under `--out`, so a rerun evaluates only new
checkpoints), and its wall time is read from the training log: the time of LeRobot's "Checkpoint policy
after step N" line minus the log's first timestamped line (a resumed training's downtime is included; the
script says when the log shows more than one start).

    python -m diagnostics.learning_curve --train-dir <out> --train-log <out>.log --task pick_place \\
        --split val --episodes 20 --out <curve folder>
"""

import argparse
import json
import re
import subprocess
import sys
from datetime import datetime
from pathlib import Path

from lerobot_ivmc.pipeline.stages import console_script

LOG_LINE = re.compile(r"INFO (\d{4}-\d\d-\d\d \d\d:\d\d:\d\d) \S+ (.{0,60})")
CHECKPOINT = re.compile(r"Checkpoint policy after step (\d+)")
START = "Logs will be saved"


def checkpoint_wall_s(log_text: str) -> tuple[dict[int, float], int]:
    """Seconds from the log's first line to each checkpoint's save, and how many training starts it shows."""
    first = None
    wall: dict[int, float] = {}
    starts = 0
    for stamp, message in LOG_LINE.findall(log_text):
        time = datetime.strptime(stamp, "%Y-%m-%d %H:%M:%S")
        first = first or time
        starts += message.startswith(START)
        found = CHECKPOINT.match(message)
        if found:
            wall[int(found.group(1))] = (time - first).total_seconds()
    return wall, starts


def numbered_checkpoints(train_dir: Path) -> list[Path]:
    """The training's checkpoints, by step (`last` is a link to one of them and is skipped)."""
    folder = train_dir / "checkpoints"
    if not folder.is_dir():
        sys.exit(f"{folder} does not exist: --train-dir must be a `lerobot-ivmc-train` --output_dir.")
    return sorted((p for p in folder.iterdir() if p.name.isdigit()), key=lambda p: int(p.name))


def evaluate(checkpoint: Path, out: Path, args: argparse.Namespace) -> dict:
    """Milestone rates of one checkpoint (evaluated once; the result is reused on later runs)."""
    info = out / "eval_info.json"
    if not info.is_file():
        command = [
            console_script("lerobot-ivmc-eval"),
            f"--policy.path={checkpoint / 'pretrained_model'}",
            "--env.type=ivmc",
            f"--env.task={args.task}",
            f"--env.split={args.split}",
            f"--eval.n_episodes={args.episodes}",
            f"--eval.batch_size={min(args.batch_size, args.episodes)}",
            f"--seed={args.seed}",
            f"--output_dir={out}",
        ]
        with open(out.with_suffix(".log"), "w") as log:
            subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, check=True)
    return json.loads(info.read_text())["aggregated_subtasks"]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--train-dir", type=Path, required=True, help="the training's --output_dir")
    parser.add_argument("--train-log", type=Path, required=True, help="the training command's log")
    parser.add_argument("--task", required=True)
    parser.add_argument("--split", default="val", choices=("train", "val", "test"))
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--batch-size", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, required=True, help="folder for the evaluations (reused)")
    args = parser.parse_args()
    if args.episodes < 1:
        sys.exit("--episodes must be >= 1.")
    if not args.train_log.is_file():
        sys.exit(f"--train-log {args.train_log} does not exist: pass the file the training printed to.")

    wall, starts = checkpoint_wall_s(args.train_log.read_text(errors="replace"))
    if starts > 1:
        print(f"note: the log shows {starts} training starts; wall times include the time between them")
    checkpoints = numbered_checkpoints(args.train_dir)
    if not checkpoints:
        sys.exit(f"{args.train_dir}/checkpoints holds no numbered checkpoint yet.")
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"{args.task}, {args.episodes} {args.split} scenes (seed {args.seed}), milestone success [%]")
    print("| step | wall [min] | milestones |")
    print("|---|---|---|")
    for checkpoint in checkpoints:
        step = int(checkpoint.name)
        rates = evaluate(checkpoint, args.out / checkpoint.name, args)
        shown = " / ".join(f"{name} {value['pc']:.0f}" for name, value in rates.items())
        minutes = f"{wall[step] / 60:.1f}" if step in wall else "?"
        print(f"| {step:,} | {minutes} | {shown} |", flush=True)


if __name__ == "__main__":
    main()
