"""The outermost wrapper of every registered ivmc env: it shows the task's instruction where LeRobot looks.

LeRobot's `add_envs_task` asks `hasattr(vector_env.envs[0], "task_description")`, and gymnasium's wrappers
(TimeLimit, OrderEnforcing) no longer forward attributes, so without this the policies' observations carry
an empty instruction (and LeRobot warns every batch) while the datasets' frames carry the task's.
"""

from __future__ import annotations

import gymnasium as gym


class TaskDescription(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Passes everything through; `task_description` is the wrapped task's instruction."""

    def __init__(self, env: gym.Env):
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)

    @property
    def task_description(self) -> str:
        return self.env.unwrapped.task_description
