"""The scripted experts run on held-out or training scenes, the library of `lerobot-ivmc-experts`
(`scripts/lerobot_ivmc_experts.py`): each milestone's success rate per task, videos of the first episodes."""

import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from lerobot.utils.io_utils import write_video
from tqdm import tqdm

from lerobot_ivmc.envs import DEMO_EPISODE_STEPS, TASKS, check_task, make_task_env
from lerobot_ivmc.experts import make_expert, run_expert_episode

logger = logging.getLogger(__name__)


@dataclass
class ExpertRunConfig:
    """Args:
    tasks: tasks to run, any of push, pick_place, pick_reach.
    n_episodes: expert episodes per task, each on the scene drawn from seed `seed + i`.
    n_videos: how many of those episodes to save as mp4 (the first ones).
    split: scene split the scenes come from ("train", "val", "test", "all").
    seed: seed of the first episode.
    image_size: side of the saved video frames, in pixels.
    output_dir: where videos and `expert_success.json` go.
    """

    tasks: list[str] = field(default_factory=lambda: list(TASKS))
    n_episodes: int = 3
    n_videos: int = 3
    split: str = "train"
    seed: int = 0
    image_size: int = 256
    output_dir: Path = Path("outputs/experts")

    def __post_init__(self):
        for task in self.tasks:
            check_task(task)
        if self.n_episodes <= 0:
            raise ValueError(f"n_episodes must be positive, got {self.n_episodes}.")
        if not 0 <= self.n_videos <= self.n_episodes:
            raise ValueError(f"n_videos must be between 0 and n_episodes, got {self.n_videos}.")


def run_task(cfg: ExpertRunConfig, task: str) -> dict:
    """Run the expert `cfg.n_episodes` times on `task`; return its success rates per milestone."""
    env = make_task_env(
        task, obs_type="state", render_size=cfg.image_size, split=cfg.split, terminate_on_success=False
    )
    expert = make_expert(env)
    milestones = {name: [] for name in env.subtasks}
    video_dir = cfg.output_dir / "videos" / task
    try:
        for episode in tqdm(range(cfg.n_episodes), desc=f"expert {task}", leave=False):
            frames: list[np.ndarray] = []
            record = episode < cfg.n_videos
            if record:
                env.reset(seed=cfg.seed + episode)
                frames.append(env.render())
            info = run_expert_episode(
                env,
                expert,
                seed=cfg.seed + episode,
                max_steps=DEMO_EPISODE_STEPS,
                on_step=(lambda *_, frames=frames: frames.append(env.render())) if record else None,
            )
            for name, reached in info["subtasks"].items():
                milestones[name].append(bool(reached))
            if record:
                video_dir.mkdir(parents=True, exist_ok=True)
                write_video(str(video_dir / f"episode_{episode:04d}.mp4"), np.stack(frames), fps=25)
    finally:
        env.close()
    return {name: float(np.mean(values)) for name, values in milestones.items()}
