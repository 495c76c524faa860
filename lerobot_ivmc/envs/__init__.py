"""Fetch manipulation tasks of the paper as gymnasium envs, registered under the `lerobot_ivmc/` namespace.

Importing this package is light: the gym ids are registered by entry point and the env classes (with
MuJoCo and gymnasium-robotics) load only when a task env is first built or `TASK_ENVS` is first read, so
installing the plugin leaves LeRobot's other commands as they were.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

import gymnasium as gym

if TYPE_CHECKING:
    from lerobot_ivmc.envs.fetch_env import IvmcFetchEnv

# Each task's env class, as "module:class" (imported on first use).
TASK_ENTRY_POINTS = {
    "push": "lerobot_ivmc.envs.tasks.push:PushEnv",
    "pick_place": "lerobot_ivmc.envs.tasks.pick_place:PickPlaceEnv",
    "pick_reach": "lerobot_ivmc.envs.tasks.pick_reach:PickReachEnv",
}
TASKS = tuple(TASK_ENTRY_POINTS)
# The paper: "An episode terminates after the task is completed or after the maximum episode limit of 200".
MAX_EPISODE_STEPS = 200
# Expert demonstrations last 4 s at 25 Hz.
DEMO_EPISODE_STEPS = 100


def check_task(task: str) -> str:
    """Return `task` if it names one of the tasks, else raise a ValueError that lists them."""
    if task not in TASK_ENTRY_POINTS:
        raise ValueError(f"Unknown task {task!r}; choose one of {TASKS}.")
    return task


def check_demo_episode_steps(flag: str, steps: int) -> int:
    """Return `steps` if demos may last that long, else raise a ValueError naming `flag` and the range."""
    if not DEMO_EPISODE_STEPS <= steps <= MAX_EPISODE_STEPS:
        raise ValueError(
            f"{flag} must be in [{DEMO_EPISODE_STEPS}, {MAX_EPISODE_STEPS}] (the experts need up to "
            f"{DEMO_EPISODE_STEPS} steps; rollouts end at {MAX_EPISODE_STEPS}), got {steps}."
        )
    return steps


def gym_id(task: str) -> str:
    """The gymnasium id of a task, e.g. ``lerobot_ivmc/PickPlace-v0``."""
    class_name = TASK_ENTRY_POINTS[check_task(task)].rsplit(":", 1)[1]
    return f"lerobot_ivmc/{class_name.removesuffix('Env')}-v0"


def task_env_class(task: str) -> type[IvmcFetchEnv]:
    """The env class of a task (importing the simulator on first use)."""
    module, name = TASK_ENTRY_POINTS[check_task(task)].split(":")
    return getattr(importlib.import_module(module), name)


def make_task_env(task: str, **kwargs) -> IvmcFetchEnv:
    """Build the bare (unwrapped) env of a task."""
    return task_env_class(task)(**kwargs)


def make_task_env_from_config(env_cfg):
    """The bare env an `ivmc` or `meta_world` config describes (its gym kwargs; the caller's loop keeps the
    time limit): an `IvmcFetchEnv` or a `SeededMetaworldEnv`."""
    kwargs = {k: v for k, v in env_cfg.gym_kwargs.items() if k != "max_episode_steps"}
    if env_cfg.type == "meta_world":
        from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv

        return SeededMetaworldEnv(**kwargs)
    return make_task_env(env_cfg.task, **kwargs)


def __getattr__(name: str) -> Any:
    """`TASK_ENVS` (task -> env class) and `IvmcFetchEnv`, loaded with the simulator on first access."""
    if name == "TASK_ENVS":
        return {task: task_env_class(task) for task in TASKS}
    if name == "IvmcFetchEnv":
        return importlib.import_module("lerobot_ivmc.envs.fetch_env").IvmcFetchEnv
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# Outside the time limit, so LeRobot's `add_envs_task` finds the instruction (`task_wrapper.py`).
_TASK_WRAPPER = gym.envs.registration.WrapperSpec(
    name="TaskDescription", entry_point="lerobot_ivmc.envs.task_wrapper:TaskDescription", kwargs={}
)
for _task, _entry_point in TASK_ENTRY_POINTS.items():
    if gym_id(_task) not in gym.registry:
        gym.register(
            id=gym_id(_task),
            entry_point=_entry_point,
            max_episode_steps=MAX_EPISODE_STEPS,
            additional_wrappers=(_TASK_WRAPPER,),
        )

__all__ = [
    "DEMO_EPISODE_STEPS",
    "MAX_EPISODE_STEPS",
    "TASKS",
    "TASK_ENTRY_POINTS",
    "TASK_ENVS",
    "IvmcFetchEnv",
    "check_demo_episode_steps",
    "check_task",
    "gym_id",
    "make_task_env",
    "task_env_class",
]
