"""Make the README's recovery GIF (docs/assets/recovery.gif) from the demo's recovery video.

    python scripts/recovery_gif.py [--video=PATH] [--output=docs/assets/recovery.gif] [--fps=10]

Without `--video` it first runs `lerobot-ivmc-demo --n_episodes=2` into a temporary folder (about a minute
on 2 cores: test scenes 0 and 1, which the shipped pick_place `bvmc` fails alone and `--recovery.mode=anchor`
rescues) and converts the recovery video the demo writes (`recovery_episode_0000.mp4`: the camera the
policy sees, under it the window sum of its uncertainty, the threshold and the recovery phases). The GIF
keeps every frame, played at `--fps` (slower than the video's 25 so that the phases can be followed), with
one 128-colour palette for all frames: about 0.5 MB.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import imageio.v3 as iio
import numpy as np
from PIL import Image

REPO = Path(__file__).resolve().parents[1]


def demo_video(n_episodes: int) -> Path:
    """Run the demo on the shipped checkpoint into a temporary folder; the recovery video it wrote."""
    out = Path(tempfile.mkdtemp(prefix="recovery_gif_")) / "demo"
    demo = Path(sys.executable).with_name("lerobot-ivmc-demo")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    subprocess.run([str(demo), f"--n_episodes={n_episodes}", f"--output_dir={out}"], check=True, env=env)
    videos = sorted(out.glob("recovery_episode_*.mp4"))
    if not videos:
        raise SystemExit(f"The demo in {out} wrote no recovery video: no episode recovered.")
    return videos[0]


def write_gif(video: Path, output: Path, fps: float, colours: int = 128) -> Path:
    """The video's frames as a looping GIF, quantised to one palette taken from the whole clip."""
    frames = iio.imread(video)  # (T, H, W, 3) uint8
    # One palette for all: quantise a strip of every 4th frame side by side, then map each frame to it.
    strip = Image.fromarray(np.concatenate(list(frames[::4]), axis=1))
    palette = strip.quantize(colors=colours, method=Image.Quantize.MEDIANCUT)
    images = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    output.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(
        output, save_all=True, append_images=images[1:], duration=round(1000 / fps), loop=0, optimize=True
    )
    return output


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--video", type=Path, help="a recovery mp4; default: run the demo and take its video")
    parser.add_argument("--output", type=Path, default=REPO / "docs" / "assets" / "recovery.gif")
    parser.add_argument("--fps", type=float, default=10.0, help="playback speed (steps per second)")
    parser.add_argument("--n_episodes", type=int, default=2, help="the demo's test scenes (without --video)")
    args = parser.parse_args()
    video = args.video or demo_video(args.n_episodes)
    gif = write_gif(video, args.output, args.fps)
    print(f"{gif}: {gif.stat().st_size / 1e6:.2f} MB, from {video}")


if __name__ == "__main__":
    main()
