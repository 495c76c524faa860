"""Recording one MetaWorld demonstration with MetaWorld's own scripted policy (`metaworld.policies`), in the
collection's worker processes; the MetaWorld counterpart of `expert_attempts.Recorder`, same interface."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.expert_attempts import ActionNoise, Recorder, attempt_seed
from lerobot_ivmc.envs.metaworld import DEMO_EPISODE_STEPS, scripted_policy_name


@dataclass
class MetaworldRecorder(Recorder):
    """A seeded MetaWorld env and the task's scripted policy that record attempts into a staging folder.

    The recorded action is the policy's, clipped to the action space (its raw actions exceed [-1, 1]; the
    env clips them); with `action_noise` the executed one has N(0, std) added to its xyz (DART). A demo
    lasts `episode_steps` steps whatever happens (the policy keeps acting once the task is done) and counts
    only if the task is done at its last step.

    Args: as `expert_attempts.Recorder` (`task` a MetaWorld v3 name; `action_noise` in action units).
    """

    episode_steps: int = DEMO_EPISODE_STEPS
    render_style: str = "flat"

    def __post_init__(self) -> None:
        scripted_policy_name(self.task)  # refuses a task without a scripted policy
        from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv

        self.env = SeededMetaworldEnv(
            self.task,
            split=self.split,
            image_size=self.image_size,
            render_style=self.render_style,
            terminate_on_success=False,
        )
        self.expert = self.env.expert_policy  # LeRobot's choice of `metaworld.policies` class for the task

    def record(self, attempt: int) -> tuple[int, bool]:
        """Run attempt `attempt`, stage it (episode file or failure marker), return (attempt, success)."""
        seed = attempt_seed(self.base_seed, attempt)
        perturb = ActionNoise(self.action_noise, seed) if self.action_noise > 0 else None
        observation, info = self.env.reset(seed=seed)
        images, states, env_states, actions = [], [], [], []
        for _ in range(self.episode_steps):
            action = np.clip(self.expert.get_action(observation["environment_state"]), -1.0, 1.0)
            images.append(observation["pixels"])
            states.append(observation["agent_pos"])
            env_states.append(observation["environment_state"])
            actions.append(action)
            observation, _, _, _, info = self.env.step(perturb(action) if perturb else action)
        if not self.env.success_now:
            staging.write_failure(self.episodes_dir, attempt)
            return attempt, False
        episode = staging.StagedEpisode.from_steps(attempt, seed, (images, states, env_states, actions))
        staging.write_episode(self.episodes_dir, episode)
        return attempt, True
