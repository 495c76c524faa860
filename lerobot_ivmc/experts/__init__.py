"""Scripted experts for the three tasks."""

from __future__ import annotations

from lerobot_ivmc.envs import check_task
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


__all__ = ["EXPERTS", "Waypoint", "WaypointExpert", "make_expert", "run_expert_episode"]
