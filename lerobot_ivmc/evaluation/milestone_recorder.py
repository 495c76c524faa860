"""Keeps the subtask milestones of each evaluation episode, which LeRobot's `rollout` does not return.

LeRobot's `eval_policy` seeds the vector env once per batch and runs every sub-env until all are done;
with same-step autoreset a sub-env that finishes early starts a new, unseeded episode. The recorder keeps,
for every seeded reset, the milestones of the episode it started, so after `eval_policy` the records of
sub-env ``j`` are its episodes of batches 0, 1, 2, ... in order.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym


class MilestoneRecorder(gym.Wrapper):
    """Wraps an ivmc task env; `episode_milestones[k]` and `episode_lengths[k]` describe its k-th seeded
    episode (its milestones, and the steps it lasted)."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        self.episode_milestones: list[dict[str, bool]] = []
        self.episode_lengths: list[int] = []
        self._recording = False

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        observation, info = self.env.reset(seed=seed, options=options)
        self._recording = seed is not None
        if self._recording:
            self.episode_milestones.append(dict(info["subtasks"]))
            self.episode_lengths.append(0)
        return observation, info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        if self._recording:
            self.episode_milestones[-1] = dict(info["subtasks"])
            self.episode_lengths[-1] += 1
            self._recording = not (terminated or truncated)
        return observation, reward, terminated, truncated, info
