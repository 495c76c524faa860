"""Env throughput with and without rendering per render style, and the scripted experts' success rate.

The render styles are timed against the renderer as it was before them (the "fetch" look drawn into the
Fetch XML's 640 x 480 framebuffer), all in this one run, so the ratios compare like with like.

python benchmarks/bench_env.py                 # 100 expert episodes per task
python benchmarks/bench_env.py --episodes 500  # the README's figure
python benchmarks/bench_env.py --episodes 0    # the step rates only
"""

import argparse
import time

import mujoco
import numpy as np

from lerobot_ivmc.envs import TASKS, make_task_env
from lerobot_ivmc.envs.render_styles import RENDER_STYLES
from lerobot_ivmc.experts.expert_runs import ExpertRunConfig, run_task


def steps_per_second(
    obs_type: str,
    image_size: int,
    render_style: str = "fast",
    xml_framebuffer: bool = False,
    n_steps: int = 300,
) -> float:
    """Steps/s of one pick_place env under random actions; `xml_framebuffer` renders into the Fetch XML's
    640 x 480 offscreen buffer, as before render styles."""
    env = make_task_env(
        "pick_place",
        obs_type=obs_type,
        image_size=image_size,
        terminate_on_success=False,
        render_style=render_style,
    )
    if xml_framebuffer:
        env.model.vis.global_.offwidth, env.model.vis.global_.offheight = 640, 480
        env.model.vis.quality.offsamples = RENDER_STYLES[render_style].multisamples
        env.renderers._renderers[image_size] = mujoco.Renderer(env.model, image_size, image_size)
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
    print(f"  physics only{'':<36}: {no_render:7.1f} steps/s")
    for size in (64, 128):
        before = steps_per_second("pixels_agent_pos", size, "fetch", xml_framebuffer=True)
        print(
            f"  {size}x{size} camera, fetch look, 640x480 buffer (before): {before:7.1f} steps/s "
            f"({before / no_render:.3f}x of physics only)"
        )
        for style in RENDER_STYLES:
            rate = steps_per_second("pixels_agent_pos", size, style)
            print(
                f"  {size}x{size} camera, {style:<5} style, frame-sized buffer : {rate:7.1f} steps/s "
                f"({rate / no_render:.3f}x of physics only, {rate / before:.2f}x before)"
            )
    if args.episodes <= 0:
        return

    print(f"expert success over {args.episodes} train scenes per task (seeds 0..{args.episodes - 1}):")
    for task in TASKS:
        start = time.perf_counter()
        rates = run_task(ExpertRunConfig(tasks=[task], n_episodes=args.episodes, n_videos=0), task)
        line = "  ".join(f"{name} {rate:6.1%}" for name, rate in rates.items())
        print(f"  {task:<11} {line}   ({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
