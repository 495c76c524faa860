"""Scripted experts for the three tasks."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.envs import check_task, make_task_env
from lerobot_ivmc.envs.fetch_env import IvmcFetchEnv
from lerobot_ivmc.experts.pick_place import PickPlaceExpert
from lerobot_ivmc.experts.pick_reach import PickReachExpert
from lerobot_ivmc.experts.push import PushExpert
from lerobot_ivmc.experts.waypoint_expert import Waypoint, WaypointExpert, run_expert_episode

EXPERTS: dict[str, type[WaypointExpert]] = {
    "push": PushExpert,
    "pick_place": PickPlaceExpert,
    "pick_reach": PickReachExpert,
}


def make_expert(env: IvmcFetchEnv) -> WaypointExpert:
    """The scripted expert for the (unwrapped) env's task."""
    return EXPERTS[check_task(env.unwrapped.task)](env.unwrapped)


def demo_end_object(task: str, seed: int, split: str = "train", steps: int = 200) -> np.ndarray:
    """Where the object is at the end of the scripted demo of `split`'s scene `seed` after `steps` steps
    (`lite`'s 200): the goal head's label, (3,) metres."""
    env = make_task_env(task, obs_type="state", split=split, terminate_on_success=False)
    try:
        run_expert_episode(env, make_expert(env), seed=seed, max_steps=steps)
        return env.object_position.copy()
    finally:
        env.close()


__all__ = ["EXPERTS", "Waypoint", "WaypointExpert", "demo_end_object", "make_expert", "run_expert_episode"]
