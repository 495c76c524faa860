"""What a demo collection is asked for (`CollectConfig`, checked when made) and what it did
(`CollectSummary`); `lerobot-ivmc-collect`'s flags are `record_config.RecordDemosConfig`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.demo_suites import DemoSuite, suite_of
from lerobot_ivmc.envs.camera import check_image_size
from lerobot_ivmc.envs.render_styles import LEGACY_RENDER_STYLE, check_render_style
from lerobot_ivmc.envs.scenes import SPLITS


@dataclass
class CollectConfig:
    """What to collect and where.

    Args:
        task: task name, one of `lerobot_ivmc.envs.TASKS` or a MetaWorld v3 task (`demo_suites.suite_of`).
        num_episodes: number of successful demonstrations the dataset must hold.
        root: local dataset folder; default ``data/ivmc_<task>`` under the working directory.
        repo_id: dataset id (``<hub user>/<name>`` to push); default ``local/ivmc_<task>``.
        split: scene split the demonstrations come from: "train" (policy training), "val" or "test".
        image_size: camera image height and width, in pixels.
        render_style: how the camera image is drawn (`render_styles.RENDER_STYLES`); recorded in the
            dataset's `meta/ivmc_collection.json`, from which `lerobot-ivmc-train` records it in the
            checkpoint. None: the suite's default ("fast" for the Fetch tasks, "flat" for MetaWorld).
        video: store the camera as mp4 video instead of PNG frames (slower to decode when training).
        num_workers: parallel recording processes; 0 records in this process.
        seed: base seed from which every attempt's scene seed is derived.
        action_noise: std (action units, 1 = 5 cm) of Gaussian noise on the executed delta-EE command while
            the recorded action stays the expert's (DART); 0 records the expert's own trajectories.
        episode_steps: steps of every demo; None: the suite's default (Fetch: 100, 4 s at 25 Hz, up to 200,
            the rollouts' limit; MetaWorld: 150 of its 500). Success does not end a demo: once done, the
            expert holds (the Fetch expert its final pose against the noise, MetaWorld's scripted policy
            still, without noise), and the demo counts only if the task is done at its last step.
        expert_after_success: what the expert does once the task is done: "hold" (the default, above), or
            for MetaWorld "act": its scripted policy acts on to the demo's end, noise and all (so the demos
            show it carrying on; left acting, it undoes some demos, which are then not kept).
        push_to_hub: publish the finished dataset with `LeRobotDataset.push_to_hub`.
        private: make the hub repository private.
        progress: show a progress bar.
    """

    task: str
    num_episodes: int
    root: Path | None = None
    repo_id: str | None = None
    split: str = "train"
    image_size: int = 64
    render_style: str | None = None
    video: bool = False
    num_workers: int = 2
    seed: int = 0
    action_noise: float = 0.0
    episode_steps: int | None = None
    expert_after_success: str = "hold"
    push_to_hub: bool = False
    private: bool = False
    progress: bool = True

    def __post_init__(self) -> None:
        suite = self.suite
        self.render_style = self.render_style or suite.default_render_style
        self.episode_steps = self.episode_steps or suite.default_episode_steps
        if not isinstance(self.num_episodes, int) or self.num_episodes <= 0:
            raise ValueError(f"num_episodes must be a positive integer, got {self.num_episodes!r}.")
        if self.split not in SPLITS:
            raise ValueError(f"Unknown split {self.split!r}; choose one of {SPLITS}.")
        check_image_size("image_size", self.image_size)
        check_render_style("render_style", self.render_style, framing=suite.name == "metaworld")
        if self.num_workers < 0:
            raise ValueError(f"num_workers must be >= 0, got {self.num_workers}.")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}.")
        suite.check_episode_steps("episode_steps", self.episode_steps)
        if not 0.0 <= self.action_noise <= 1.0:
            raise ValueError(f"action_noise must be in [0, 1] action units, got {self.action_noise}.")
        if self.expert_after_success not in suite.after_success:
            raise ValueError(
                f"expert_after_success must be one of {suite.after_success} for {self.task}, got "
                f"{self.expert_after_success!r}."
            )
        self.root = Path(self.root) if self.root is not None else Path("data") / f"ivmc_{self.task}"
        if self.root.exists() and not self.root.is_dir():
            raise ValueError(f"root {self.root} is a file; give a folder (new, or one this command made).")
        self.repo_id = self.repo_id or f"local/ivmc_{self.task}"
        if self.repo_id.count("/") != 1:
            raise ValueError(f"repo_id must look like '<user>/<name>', got {self.repo_id!r}.")
        if self.push_to_hub and self.repo_id.startswith("local/"):
            raise ValueError(
                f"--dataset.push_to_hub needs a hub repo id '<hf user>/<name>' (--dataset.repo_id), got "
                f"{self.repo_id!r}."
            )

    @property
    def suite(self) -> DemoSuite:
        """The task's suite (an unknown task raises a ValueError listing the suites' tasks)."""
        return suite_of(self.task)

    def spec(self) -> dict:
        """What the dataset in `root` must match to be resumed or reused (the episode count aside)."""
        # Every MetaWorld collection and every noisy Fetch one names the expert's hold once its task is
        # done, so that demos recorded before the hold never mix with new ones.
        suite = self.suite
        # Datasets of the Fetch XML's look keep the spec they had before render styles existed.
        style = {} if self.render_style == LEGACY_RENDER_STYLE else {"render_style": self.render_style}
        return staging.normalise(
            {
                **suite.expert_spec(self.action_noise, self.task, self.expert_after_success),
                **style,
                "task": self.task,
                "gym_id": suite.gym_id(self.task),
                "split": self.split,
                "seed": self.seed,
                "image_size": self.image_size,
                "video": self.video,
                "fps": suite.fps,
                "episode_steps": self.episode_steps,
                "features": suite.features(self.image_size, self.video),
            }
        )


@dataclass
class CollectSummary:
    """What a collection produced."""

    root: str
    repo_id: str
    task: str
    split: str
    num_episodes: int
    num_frames: int
    attempts: int = 0
    failed_attempts: int = 0
    resumed_episodes: int = 0
    already_complete: bool = False
    pushed: bool = False
    elapsed_s: float = 0.0
    episode_seeds: list[int] = field(default_factory=list)
