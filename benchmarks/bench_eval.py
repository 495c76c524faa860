"""Evaluation throughput: episodes per minute of `lerobot-ivmc-eval` with the settings of before the
throughput work against today's, for recovery none and min_unc, all measured in this one run.

Settings compared (the same checkpoint, test scenes and seeds):
  before  one process (SyncVectorEnv), the "fetch" render style, LeRobot's 10 rendered episodes, finished
          sub-envs autoreset into unseeded episodes (`--park_finished_envs=false`);
  fast    one process, the "fast" render style, no rendered episodes, autoreset as before;
  parked  as fast, with finished sub-envs parked until the batch ends (today's default);
  async   one process per sub-env (`--eval.use_async_envs=true`, forkserver), "fast", none rendered, parked.
Parking changes no episode: the benchmark checks that each setting's per-episode results equal the fast
setting's (success, u, recoveries), and says so.
Each eval runs as its own `lerobot-ivmc-eval` process, start-up included. ("before" omits one cost of the
old code: it rendered 256-px frames of every step until its recovery videos were found; the videos are now
made from the camera images the policy saw.) A checkpoint without a foresight head gets an untrained one
for min_unc (its cost, not its choices, is measured), and `--threshold` sets C where it has no threshold.
The policy acts on "fast" frames whatever style it was trained on (`--policy.render_style=fast`): success
rates, printed next to the times, may differ between styles, and so the episodes' lengths.

Usage:
    python benchmarks/bench_eval.py --policy-path ../shared/checkpoints/bvmc_pick_place_2000dart_36k \\
        --threshold 0.817 [--task pick_place --episodes 100 --batch-size 10]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy

SETTINGS = {
    "before": [
        "--eval.use_async_envs=false",
        "--env.render_style=fetch",
        "--max_episodes_rendered=10",
        "--park_finished_envs=false",
    ],
    "fast": [
        "--eval.use_async_envs=false",
        "--env.render_style=fast",
        "--max_episodes_rendered=0",
        "--park_finished_envs=false",
    ],
    "parked": ["--eval.use_async_envs=false", "--env.render_style=fast", "--max_episodes_rendered=0"],
    "async": ["--eval.use_async_envs=true", "--env.render_style=fast", "--max_episodes_rendered=0"],
}
# What an episode's result is made of: equal between settings of the same render style.
EPISODE_KEYS = ("success", "max_uncertainty", "recoveries", "subtasks", "seed")


def with_foresight_head(policy_path: Path, out: Path) -> Path:
    """`policy_path` if it has a foresight head, else a copy of it with an untrained one."""
    policy = BVMCPolicy.from_pretrained(policy_path)
    if policy.foresight is not None:
        return policy_path
    shutil.copytree(policy_path, out)
    policy.attach_foresight()
    policy.save_pretrained(out)
    return out


def run_eval(policy_path: Path, out: Path, args: argparse.Namespace, mode: str, setting: list[str]) -> dict:
    """One `lerobot-ivmc-eval` process; its eval info and wall time."""
    style = next(flag.split("=")[1] for flag in setting if flag.startswith("--env.render_style"))
    command = [
        str(Path(sys.executable).with_name("lerobot-ivmc-eval")),
        f"--policy.path={policy_path}",
        f"--policy.render_style={style}",
        "--env.type=ivmc",
        f"--env.task={args.task}",
        f"--eval.n_episodes={args.episodes}",
        f"--eval.batch_size={args.batch_size}",
        "--seed=0",
        f"--recovery.mode={mode}",
        f"--output_dir={out}",
        *setting,
    ]
    if mode != "none" and args.threshold is not None:
        command.append(f"--recovery.threshold={args.threshold}")
    start = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True, env={**os.environ, "MUJOCO_GL": "egl"})
    wall = time.perf_counter() - start
    if result.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{result.stderr[-2000:]}")
    info = json.loads((out / "eval_info.json").read_text())
    episodes = [{key: episode.get(key) for key in EPISODE_KEYS} for episode in info["per_episode"]]
    return {"wall_s": wall, "success": info["aggregated"]["pc_success"], "episodes": episodes}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--policy-path", type=Path, required=True, help="a bvmc checkpoint folder")
    parser.add_argument("--threshold", type=float, default=None, help="C, where the checkpoint has none")
    parser.add_argument("--task", default="pick_place")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--batch-size", type=int, default=10)
    parser.add_argument("--modes", nargs="+", default=["none", "min_unc"])
    parser.add_argument(
        "--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS), help="before comes first"
    )
    args = parser.parse_args()
    if args.settings[0] != "before":
        parser.error("--settings must start with before: the ratios are against it.")

    with tempfile.TemporaryDirectory() as tmp:
        policy_path = with_foresight_head(args.policy_path, Path(tmp) / "checkpoint")
        print(f"lerobot-ivmc-eval, {args.episodes} {args.task} test episodes, batch {args.batch_size}:")
        for mode in args.modes:
            runs = {
                name: run_eval(policy_path, Path(tmp) / f"{mode}_{name}", args, mode, setting)
                for name, setting in SETTINGS.items()
                if name in args.settings
            }
            before = runs["before"]["wall_s"]
            for name, run in runs.items():
                rate = args.episodes / run["wall_s"] * 60
                same = ""
                if name not in ("before", "fast") and "fast" in runs:
                    equal = run["episodes"] == runs["fast"]["episodes"]
                    same = f", episodes as fast: {'same' if equal else 'DIFFER'}"
                print(
                    f"  {mode:<8} {name:<7} {run['wall_s']:7.1f} s  {rate:6.1f} episodes/min  "
                    f"{before / run['wall_s']:5.2f}x before  (success {run['success']:.0f}%{same})"
                )


if __name__ == "__main__":
    main()
