"""What demo collection needs of each suite of tasks (the Fetch tasks, MetaWorld): names, rates, features,
the instruction and the recorder class, looked up from the task name in one place.

Light to import: neither simulator is loaded here (the recorders load theirs in the worker processes).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from lerobot_ivmc.datasets import features as fetch_features
from lerobot_ivmc.envs import DEMO_EPISODE_STEPS, MAX_EPISODE_STEPS, TASKS, gym_id
from lerobot_ivmc.envs import metaworld as mw
from lerobot_ivmc.envs.metaworld import env_state as mw_state
from lerobot_ivmc.envs.render_styles import DEFAULT_RENDER_STYLE

# The spec entry (True) of a MetaWorld collection whose scripted policy edits the state it reads
# (`mw.STATE_EDITING_POLICIES`): it reads a copy, so the demos record the state as the env gave it.
STATE_COPY_KEY = "expert_reads_state_copy"
EDITED_STATE = (
    "demos whose observation.environment_state is MetaWorld's state as the task's scripted policy edited it "
    "in place (the object position shifted on the steps it acted; collected before the collector gave the "
    "policy a copy)"
)


@dataclass(frozen=True)
class DemoSuite:
    """A suite's collection facts.

    Args:
        name: "ivmc" (the Fetch tasks) or "metaworld".
        fps: the control rate the datasets record.
        robot_type: LeRobot's `robot_type` of the datasets.
        default_episode_steps: steps of a demo unless asked otherwise.
        max_episode_steps: the longest demo (the rollouts' limit).
        default_render_style: the camera's style unless asked otherwise.
        recorder: "module:Class" of the recorder that runs the scripted expert.
        scene_cells: whether frames carry the scene's grid cells (the Fetch tasks' spawn grids).
        aux_state_indices: the entries of `observation.environment_state` the policies' auxiliary heads
            learn (`VMCConfig.aux_state_indices`); None: the whole 6-D state.
        hold_key: the spec entry that names the expert's hold once its task is done, so that demos of
            before the hold never mix with new ones.
        after_success: what the expert may do once its task is done (`--expert_after_success`): "hold",
            and for MetaWorld also "act" (the scripted policy acts on to the demo's end).
        hold_without_noise: whether noise-free collections name it too (the Fetch expert stood still
            without noise before its hold; MetaWorld's scripted policy kept acting with or without).
        before_hold: what the demos of before the hold were, for the refusal that keeps them apart.
    """

    name: str
    fps: int
    robot_type: str
    default_episode_steps: int
    max_episode_steps: int
    default_render_style: str
    recorder: str
    scene_cells: bool
    hold_key: str
    after_success: tuple[str, ...]
    hold_without_noise: bool
    before_hold: str
    aux_state_indices: tuple[int, ...] | None = None

    def expert_spec(self, action_noise: float, task: str, after_success: str = "hold") -> dict:
        """The collection spec's entries for the expert: its noise, what it does once the task is done
        ("hold", or MetaWorld's "act"), and, where MetaWorld's scripted policy edits the state it reads, that
        it reads a copy."""
        spec: dict = {"action_noise": action_noise} if action_noise > 0 else {}
        if action_noise > 0 or self.hold_without_noise:
            spec[self.hold_key] = after_success
        if self.name == "metaworld" and mw.expert_edits_state(task):
            spec[STATE_COPY_KEY] = True
        return spec

    def recorded_with_edited_state(self, spec: dict) -> bool:
        """Whether a stored collection spec's demos recorded the state as the scripted policy edited it."""
        return self.name == "metaworld" and mw.expert_edits_state(spec["task"]) and STATE_COPY_KEY not in spec

    def recorded_before_the_hold(self, spec: dict) -> bool:
        """Whether a stored collection spec was recorded before the expert held once its task was done."""
        return bool(self.hold_without_noise or spec.get("action_noise")) and self.hold_key not in spec

    def check_episode_steps(self, flag: str, steps: int) -> int:
        """Return `steps` if demos may last that long, else raise a ValueError naming `flag` and the range."""
        low = DEMO_EPISODE_STEPS if self.name == "ivmc" else 1
        if not low <= steps <= self.max_episode_steps:
            raise ValueError(f"{flag} must be in [{low}, {self.max_episode_steps}] here, got {steps}.")
        return steps

    def gym_id(self, task: str) -> str:
        return gym_id(task) if self.name == "ivmc" else mw.GYM_ID

    def task_description(self, task: str) -> str:
        if self.name == "metaworld":
            return mw.task_description(task)
        from lerobot_ivmc.envs import TASK_ENVS

        return TASK_ENVS[task].task_description

    def features(self, image_size: int, use_video: bool) -> dict[str, dict]:
        """LeRobot features of the suite's demos (`LeRobotDataset.create(features=...)`)."""
        if self.name == "ivmc":
            return fetch_features.demo_features(image_size, use_video)
        return metaworld_demo_features(image_size, use_video)

    def recorder_class(self) -> type:
        module, name = self.recorder.split(":")
        return getattr(importlib.import_module(module), name)


FETCH = DemoSuite(
    name="ivmc",
    fps=fetch_features.DEMO_FPS,
    robot_type="fetch",
    default_episode_steps=DEMO_EPISODE_STEPS,
    max_episode_steps=MAX_EPISODE_STEPS,
    default_render_style=DEFAULT_RENDER_STYLE,
    recorder="lerobot_ivmc.datasets.expert_attempts:Recorder",
    scene_cells=True,
    hold_key="expert_after_last_waypoint",
    after_success=("hold",),
    hold_without_noise=False,
    before_hold="noisy demos recorded before the expert held its final pose (after its last waypoint it "
    "stood still while the noise moved the arm)",
)
METAWORLD = DemoSuite(
    name="metaworld",
    fps=mw.METAWORLD_FPS,
    robot_type="sawyer",
    default_episode_steps=mw.DEMO_EPISODE_STEPS,
    max_episode_steps=mw.MAX_EPISODE_STEPS,
    default_render_style="flat",
    recorder="lerobot_ivmc.datasets.metaworld_attempts:MetaworldRecorder",
    scene_cells=False,
    hold_key="expert_after_success",
    after_success=("hold", "act"),
    hold_without_noise=True,
    before_hold="demos recorded before the scripted policy held still once the task was done (it kept "
    "acting, and undid some of the demos it had done)",
    aux_state_indices=mw_state.AUX_STATE_INDICES,
)


def suite_of(task: str) -> DemoSuite:
    """The suite a task belongs to; a ValueError naming both suites' tasks for an unknown one."""
    if task in TASKS:
        return FETCH
    if mw.is_metaworld_task(task):
        return METAWORLD
    raise ValueError(
        f"Unknown task {task!r}; choose one of {TASKS} or a MetaWorld v3 task such as 'pick-place-v3'."
    )


def metaworld_demo_features(image_size: int, use_video: bool) -> dict[str, dict]:
    """The features of `lerobot/metaworld_mt50` (`observation.image`, `observation.state` (4),
    `observation.environment_state` (39), `action` (4)) and the scene seed of each frame."""
    return {
        fetch_features.METAWORLD_IMAGE_KEY: {
            "dtype": "video" if use_video else "image",
            "shape": (image_size, image_size, 3),
            "names": ["height", "width", "channels"],
        },
        fetch_features.STATE_KEY: {
            "dtype": "float32",
            "shape": (mw_state.AGENT_POS_DIM,),
            "names": list(mw_state.STATE_NAMES[: mw_state.AGENT_POS_DIM]),
        },
        fetch_features.ENV_STATE_KEY: {
            "dtype": "float32",
            "shape": (mw_state.STATE_DIM,),
            "names": list(mw_state.STATE_NAMES),
        },
        fetch_features.ACTION_KEY: {
            "dtype": "float32",
            "shape": (4,),
            "names": ["delta_x", "delta_y", "delta_z", "grab_effort"],
        },
        fetch_features.SCENE_SEED_KEY: {"dtype": "int64", "shape": (1,), "names": None},
    }
