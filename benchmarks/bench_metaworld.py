"""MetaWorld: env steps/s of the plugin's `meta_world` env (64-px camera, "flat" and "lean" render styles)
against LeRobot 0.4.4's own `MetaworldEnv` (480 x 480 frames) and against physics only, each env in its own
process; the scripted policies' success rate with the demos' noise; and `lerobot-ivmc-collect`'s demos per
minute. Every ratio is measured in this one run.

python benchmarks/bench_metaworld.py                      # 10 scripted episodes per task, 20 demos
python benchmarks/bench_metaworld.py --episodes 50 --demos 50
python benchmarks/bench_metaworld.py --scripted_only --episodes 50 --noise 0 --demo_steps 150 200
python benchmarks/bench_metaworld.py --scripted_only --episodes 300 --keep_acting   # no hold once done
python benchmarks/bench_metaworld.py --env_only --steps 500
"""

import argparse
import multiprocessing
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before LeRobot's env imports mujoco

import numpy as np  # noqa: E402
from lerobot.envs.metaworld import MetaworldEnv  # noqa: E402

from lerobot_ivmc.datasets.collect import collect_demos  # noqa: E402
from lerobot_ivmc.datasets.collect_config import CollectConfig  # noqa: E402
from lerobot_ivmc.datasets.expert_attempts import attempt_seed  # noqa: E402
from lerobot_ivmc.datasets.metaworld_attempts import run_scripted_episode, scripted_action  # noqa: E402
from lerobot_ivmc.envs.coarse_meshes import coarse_meshes  # noqa: E402
from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv  # noqa: E402
from lerobot_ivmc.envs.render_styles import RENDER_STYLES  # noqa: E402

TASKS = ("pick-place-v3", "push-v3", "drawer-open-v3", "peg-insert-side-v3")
NOISE = 0.1  # the metaworld preset's demo noise


def rate(step, n_steps: int) -> float:
    """Steps/s of `step(action)` under random actions."""
    actions = np.random.default_rng(0).uniform(-1, 1, size=(n_steps, 4)).astype(np.float32)
    start = time.perf_counter()
    for action in actions:
        step(action)
    return n_steps / (time.perf_counter() - start)


def env_rate(kind: str, task: str, n_steps: int) -> float:
    """Steps/s of one env kind; run alone in its process (`step_rates`)."""
    if kind == "lerobot":
        env = MetaworldEnv(task=task, obs_type="pixels_agent_pos")
        env.reset(seed=0)
        return rate(env.step, n_steps)
    style = "flat" if kind == "physics" else kind
    env = SeededMetaworldEnv(task, terminate_on_success=False, render_style=style)
    env.reset(seed=0)
    return rate(env.raw_env.step if kind == "physics" else env.step, n_steps)


def step_rates(task: str, n_steps: int) -> dict[str, float]:
    """Each env in a fresh process: gymnasium's renderer (LeRobot's env) makes its GL context current
    only once, so it draws nothing once another renderer in the process has made its own current."""
    kinds = {
        "physics only": ("physics", n_steps),
        "meta_world, 64-px flat camera": ("flat", n_steps),
        "meta_world, 64-px lean camera": ("lean", n_steps),
        "LeRobot's MetaworldEnv (480 px)": ("lerobot", n_steps // 5),
    }
    rates = {}
    context = multiprocessing.get_context("spawn")
    for name, (kind, steps) in kinds.items():
        with context.Pool(1) as pool:
            rates[name] = pool.apply(env_rate, (kind, task, steps))
    return rates


def lean_difference(task: str, steps: int = 60) -> tuple[float, float, int, int]:
    """How far "lean" frames are from "flat" ones over a scripted episode: mean abs difference (grey levels),
    the share of pixels off by more than 16, and the triangles drawn (all meshes, flat then lean)."""
    frames = {}
    for style in ("flat", "lean"):
        env = SeededMetaworldEnv(task, render_style=style, terminate_on_success=False)
        observation, _ = env.reset(seed=4)
        episode = [observation["pixels"]]
        for _ in range(steps):
            action = scripted_action(env, observation["environment_state"])
            observation, *_ = env.step(action)
            episode.append(observation["pixels"])
        frames[style] = np.stack(episode).astype(int)
        model = env.raw_env.model
        env.close()
    with coarse_meshes(model, RENDER_STYLES["lean"].mesh_cell):
        lean_faces = int(model.mesh_facenum.sum())
    difference = np.abs(frames["flat"] - frames["lean"])
    return difference.mean(), (difference.max(-1) > 16).mean(), int(model.mesh_facenum.sum()), lean_faces


class _UndrawnMetaworldEnv(SeededMetaworldEnv):
    """The demos' env without its camera drawn (frames do not change the physics): scripted runs only."""

    def _render(self, size: int) -> np.ndarray:
        return np.zeros((size, size, 3), np.uint8)


def scripted_success(
    task: str,
    episodes: int,
    noise_std: float = NOISE,
    demo_steps: tuple[int, ...] = (150,),
    hold_once_done: bool = True,
) -> tuple[dict[int, int], list[int]]:
    """The noisy scripted policy's successes at each of `demo_steps` (a demo of that length is kept only if
    done at its last step) and its steps to first success, on the scenes of a collection's first `episodes`
    attempts (`--seed=0`), as `lerobot-ivmc-collect` runs them (holding once done, unless told not to)."""
    env = _UndrawnMetaworldEnv(task, split="train", terminate_on_success=False)
    wins, first = dict.fromkeys(demo_steps, 0), []
    for attempt in range(episodes):
        seed = attempt_seed(0, attempt)
        successes = run_scripted_episode(env, seed, max(demo_steps), noise_std, hold_once_done=hold_once_done)
        for n in demo_steps:
            wins[n] += int(successes[n - 1])
        first += [successes.index(True) + 1] if any(successes) else []
    env.close()
    return wins, first


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--episodes", type=int, default=10, help="scripted episodes per task")
    parser.add_argument("--demos", type=int, default=20, help="demos for the collection rate")
    parser.add_argument("--steps", type=int, default=400, help="env steps per rate (at most 500)")
    parser.add_argument("--noise", type=float, default=NOISE, help="the scripted policy's xyz noise std")
    parser.add_argument("--demo_steps", type=int, nargs="+", default=[150], help="demo lengths to score")
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), help="tasks of the scripted runs")
    parser.add_argument("--scripted_only", action="store_true", help="only the scripted policies' success")
    parser.add_argument(
        "--keep_acting", action="store_true", help="scripted runs that act on once done (no hold)"
    )
    parser.add_argument("--env_only", action="store_true", help="only the env step rates")
    args = parser.parse_args()
    if not 5 <= args.steps <= 500 or not all(1 <= n <= 500 for n in args.demo_steps):
        parser.error("--steps and --demo_steps must be in [5, 500]: MetaWorld's episodes end at 500 steps.")

    if not args.scripted_only:
        env_rates(args.steps)
    if args.env_only:
        return
    lengths = "/".join(map(str, args.demo_steps))
    after = "acting on once done" if args.keep_acting else "holding once done"
    print(
        f"scripted policies, N(0, {args.noise}) xyz noise, {lengths}-step demos, {args.episodes} scenes "
        f"each, {after}:"
    )
    for task in args.tasks:
        wins, first = scripted_success(
            task, args.episodes, args.noise, tuple(args.demo_steps), not args.keep_acting
        )
        median = int(np.median(first)) if first else None
        done = ", ".join(f"{count}/{args.episodes} done at step {n}" for n, count in wins.items())
        print(f"  {task:<20}: {done}; done at some step in {len(first)}, median first at step {median}")
    if not args.scripted_only:
        collection_rates(args.demos)


def env_rates(n_steps: int) -> None:
    """Print the env step rates of pick-place-v3 and their ratios, and how far lean frames are from flat."""
    rates = step_rates("pick-place-v3", n_steps)
    print("pick-place-v3, one env, one process (steps/s):")
    for name, value in rates.items():
        print(f"  {name:<34}: {value:8.1f}")
    lerobot = rates["LeRobot's MetaworldEnv (480 px)"]
    for style in ("flat", "lean"):
        ours = rates[f"meta_world, 64-px {style} camera"]
        print(f"  meta_world {style} / LeRobot's MetaworldEnv: {ours / lerobot:5.1f}x")
        print(f"  meta_world {style} / physics only:           {ours / rates['physics only']:5.2f}x")
    print("lean against flat frames, 61 frames of a scripted episode:")
    for task in ("pick-place-v3", "door-open-v3", "drawer-open-v3", "assembly-v3", "peg-insert-side-v3"):
        mean, share, flat_faces, lean_faces = lean_difference(task)
        print(
            f"  {task:<20}: {mean:.2f} grey levels, {share:.1%} of pixels off by > 16; "
            f"triangles {flat_faces} -> {lean_faces}"
        )


def collection_rates(demos: int) -> None:
    """Print `lerobot-ivmc-collect`'s pick-place-v3 demos per minute in one process and with two workers."""
    with tempfile.TemporaryDirectory() as tmp:
        for workers in (0, 2):
            cfg = CollectConfig(
                task="pick-place-v3",
                num_episodes=demos,
                root=Path(tmp) / f"demos_{workers}",
                num_workers=workers,
                action_noise=NOISE,
                progress=False,
            )
            start = time.perf_counter()
            collect_demos(cfg)
            minutes = (time.perf_counter() - start) / 60
            rate_per_minute = demos / minutes
            print(f"lerobot-ivmc-collect, {workers} workers: {rate_per_minute:.1f} pick-place-v3 demos/min")


if __name__ == "__main__":
    main()
