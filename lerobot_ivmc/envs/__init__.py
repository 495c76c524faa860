"""Fetch manipulation tasks of the paper as gymnasium envs, registered under the `lerobot_ivmc/` namespace."""

from __future__ import annotations

import gymnasium as gym

from lerobot_ivmc.envs.fetch_env import IvmcFetchEnv
from lerobot_ivmc.envs.tasks.pick_place import PickPlaceEnv
from lerobot_ivmc.envs.tasks.pick_reach import PickReachEnv
from lerobot_ivmc.envs.tasks.push import PushEnv

TASK_ENVS: dict[str, type[IvmcFetchEnv]] = {env.task: env for env in (PushEnv, PickPlaceEnv, PickReachEnv)}
TASKS = tuple(TASK_ENVS)
# The paper: "An episode terminates after the task is completed or after the maximum episode limit of 200".
MAX_EPISODE_STEPS = 200
# Expert demonstrations last 4 s at 25 Hz.
DEMO_EPISODE_STEPS = 100


def check_task(task: str) -> str:
    """Return `task` if it names one of the tasks, else raise a ValueError that lists them."""
    if task not in TASK_ENVS:
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
    return f"lerobot_ivmc/{TASK_ENVS[check_task(task)].__name__.removesuffix('Env')}-v0"


def make_task_env(task: str, **kwargs) -> IvmcFetchEnv:
    """Build the bare (unwrapped) env of a task."""
    return TASK_ENVS[check_task(task)](**kwargs)


def make_task_env_from_config(env_cfg) -> IvmcFetchEnv:
    """The bare env an `IvmcEnv` config describes (its gym kwargs; the caller's loop keeps the time limit)."""
    kwargs = {k: v for k, v in env_cfg.gym_kwargs.items() if k != "max_episode_steps"}
    return make_task_env(env_cfg.task, **kwargs)


for _task, _env in TASK_ENVS.items():
    if gym_id(_task) not in gym.registry:
        gym.register(
            id=gym_id(_task),
            entry_point=f"{_env.__module__}:{_env.__name__}",
            max_episode_steps=MAX_EPISODE_STEPS,
        )

__all__ = [
    "DEMO_EPISODE_STEPS",
    "MAX_EPISODE_STEPS",
    "TASKS",
    "TASK_ENVS",
    "IvmcFetchEnv",
    "check_demo_episode_steps",
    "check_task",
    "gym_id",
    "make_task_env",
]
