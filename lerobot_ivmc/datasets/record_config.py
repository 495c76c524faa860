"""The collector's config in LeRobot's draccus style (`lerobot-record` is the model).

    lerobot-ivmc-collect --env.task=pick_place --dataset.num_episodes=2000 \\
        --dataset.root=data/ivmc_pick_place --dataset.repo_id=local/ivmc_pick_place --num_workers=2 --seed=0

Sections: `env` (which scenes and camera), `dataset` (where and how many), and the recording settings.
`RecordDemosConfig.to_collect_config` gives the `CollectConfig` that `collect_demos` runs, which validates
every value. A pipeline preset nests this config as its `collect` section.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from lerobot_ivmc.datasets.collect_config import CollectConfig


@dataclass
class DemoEnvConfig:
    """Which scenes the expert runs on.

    Args:
        task: task name (push, pick_place, pick_reach, or a MetaWorld v3 task such as pick-place-v3).
        split: scene split of the demos ("train" for policy training).
        image_size: camera height and width in pixels.
        render_style: how the camera image is drawn (`render_styles.RENDER_STYLES`); default: the suite's
            ("fast" for the Fetch tasks, "flat" for MetaWorld).

    The task has no default: the command refuses to run without it.
    """

    task: str = ""
    split: str = "train"
    image_size: int = 64
    render_style: str | None = None


@dataclass
class DemoDatasetConfig:
    """Where the demos go, as `lerobot-record`'s `--dataset.*`.

    Args:
        repo_id: dataset id; default ``local/ivmc_<task>`` (``<hub user>/<name>`` to push).
        root: local dataset folder; default ``data/ivmc_<task>``.
        num_episodes: successful demos the dataset must hold.
        episode_steps: steps of every demo (Fetch: 100 to 200, default 100; MetaWorld: default 150).
        video: store the camera as mp4 instead of PNG frames.
        push_to_hub: publish the finished dataset with `LeRobotDataset.push_to_hub`.
        private: make the hub repository private.

    `num_episodes` has no default: the command refuses to run without it.
    """

    repo_id: str | None = None
    root: Path | None = None
    num_episodes: int = 0
    episode_steps: int | None = None
    video: bool = False
    push_to_hub: bool = False
    private: bool = False


@dataclass
class RecordDemosConfig:
    """`lerobot-ivmc-collect`'s draccus config.

    Args:
        env: scenes and camera.
        dataset: destination and size.
        num_workers: parallel recording processes (0: in this process).
        seed: base seed of the attempts' scene seeds.
        action_noise: std of the noise on the executed delta-EE command, in action units (DART); the
            recorded label stays the expert's.
        expert_after_success: once the task is done the expert holds still ("hold"); MetaWorld's scripted
            policy may act on instead ("act"). Recorded in the collection's spec.
        progress: show a progress bar.

    The short flags of earlier versions (`--task`, `--num-episodes`, ...) are refused, naming these.
    """

    env: DemoEnvConfig = field(default_factory=DemoEnvConfig)
    dataset: DemoDatasetConfig = field(default_factory=DemoDatasetConfig)
    num_workers: int = 2
    seed: int = 0
    action_noise: float = 0.0
    expert_after_success: str = "hold"
    progress: bool = True

    def to_collect_config(self) -> CollectConfig:
        """The flat `CollectConfig` (validated: unknown task, bad counts and roots raise ValueError)."""
        if not self.env.task:
            raise ValueError("Give the task: --env.task=push|pick_place|pick_reach or a MetaWorld task.")
        if self.dataset.num_episodes <= 0:
            raise ValueError(
                "Give how many demos to record: --dataset.num_episodes=N (N > 0), got "
                f"{self.dataset.num_episodes}."
            )
        return CollectConfig(
            task=self.env.task,
            num_episodes=self.dataset.num_episodes,
            root=self.dataset.root,
            repo_id=self.dataset.repo_id,
            split=self.env.split,
            image_size=self.env.image_size,
            render_style=self.env.render_style,
            video=self.dataset.video,
            num_workers=self.num_workers,
            seed=self.seed,
            action_noise=self.action_noise,
            episode_steps=self.dataset.episode_steps,
            expert_after_success=self.expert_after_success,
            push_to_hub=self.dataset.push_to_hub,
            private=self.dataset.private,
            progress=self.progress,
        )


# The short flags of the collector's earlier command line and the draccus flag that replaced each; a switch
# (no value) maps to the whole new flag.
SHORT_FLAGS = {
    "--task": "--env.task",
    "--split": "--env.split",
    "--image-size": "--env.image_size",
    "--render-style": "--env.render_style",
    "--num-episodes": "--dataset.num_episodes",
    "--root": "--dataset.root",
    "--repo-id": "--dataset.repo_id",
    "--episode-steps": "--dataset.episode_steps",
    "--num-workers": "--num_workers",
    "--action-noise": "--action_noise",
}
SHORT_SWITCHES = {
    "--video": "--dataset.video=true",
    "--push-to-hub": "--dataset.push_to_hub=true",
    "--private": "--dataset.private=true",
    "--no-progress": "--progress=false",
}


def short_flag_replacements(argv: list[str]) -> list[tuple[str, str]]:
    """(new flag, old flag as given) for each short flag of earlier versions in `argv`, in order."""
    found = []
    for i, arg in enumerate(argv):
        name, has_value, value = arg.partition("=")
        if name in SHORT_SWITCHES:
            found.append((SHORT_SWITCHES[name], arg))
        elif name in SHORT_FLAGS:
            if not has_value:  # `--task push`: the value is the next argument, if it is not a flag
                following = argv[i + 1] if i + 1 < len(argv) else ""
                value = "" if following.startswith("--") else following
                arg = f"{name} {value}".rstrip()
            found.append((f"{SHORT_FLAGS[name]}={value or '...'}", arg))
    return found
