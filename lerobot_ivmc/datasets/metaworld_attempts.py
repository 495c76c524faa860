"""Recording one MetaWorld demonstration with MetaWorld's own scripted policy (`metaworld.policies`), in the
collection's worker processes; the MetaWorld counterpart of `expert_attempts.Recorder`, same interface."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.expert_attempts import ActionNoise, Recorder, attempt_seed
from lerobot_ivmc.envs.metaworld import DEMO_EPISODE_STEPS, scripted_policy_name

if TYPE_CHECKING:  # the env module loads MetaWorld
    from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv


@dataclass
class MetaworldRecorder(Recorder):
    """A seeded MetaWorld env and the task's scripted policy that record attempts into a staging folder.

    The recorded action is the policy's, clipped to the action space (its raw actions exceed [-1, 1]; the
    env clips them); with `action_noise` the executed one has N(0, std) added to its xyz (DART). Once done,
    the expert holds still (`run_scripted_episode`; left acting, `expert_after_success="act"`, the
    scripted policy undoes some demos it has done). A demo lasts `episode_steps` steps and counts only if
    the task is done at its last step.

    Args: as `expert_attempts.Recorder` (`task` a MetaWorld v3 name; `action_noise` in action units).
    """

    episode_steps: int = DEMO_EPISODE_STEPS
    render_style: str = "flat"

    def __post_init__(self) -> None:
        self.check_after_success()
        scripted_policy_name(self.task)  # refuses a task without a scripted policy
        from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv

        self.env = SeededMetaworldEnv(
            self.task,
            split=self.split,
            image_size=self.image_size,
            render_style=self.render_style,
            terminate_on_success=False,
        )

    def record(self, attempt: int) -> tuple[int, bool]:
        """Run attempt `attempt`, stage it (episode file or failure marker), return (attempt, success)."""
        seed = attempt_seed(self.base_seed, attempt)
        images, states, env_states, actions = [], [], [], []

        def on_step(observation: dict, action: np.ndarray) -> None:
            images.append(observation["pixels"])
            states.append(observation["agent_pos"])
            env_states.append(observation["environment_state"])
            actions.append(action)

        run_scripted_episode(
            self.env,
            seed,
            self.episode_steps,
            self.action_noise,
            on_step,
            hold_once_done=self.expert_after_success == "hold",
        )
        if not self.env.success_now:
            staging.write_failure(self.episodes_dir, attempt)
            return attempt, False
        episode = staging.StagedEpisode.from_steps(attempt, seed, (images, states, env_states, actions))
        staging.write_episode(self.episodes_dir, episode)
        return attempt, True


def scripted_action(env: SeededMetaworldEnv, state: np.ndarray) -> np.ndarray:
    """(4,) the task's scripted action on the (39,) `state`, clipped to the action space. The policy gets a
    copy: some edit the state they parse in place (`STATE_EDITING_POLICIES`)."""
    return np.clip(env.expert_policy.get_action(state.copy()), -1.0, 1.0)


def run_scripted_episode(
    env: SeededMetaworldEnv,
    seed: int,
    episode_steps: int,
    action_noise: float = 0.0,
    on_step: Callable[[dict, np.ndarray], None] | None = None,
    hold_once_done: bool = True,
) -> list[bool]:
    """One demo's episode on scene `seed`: the task's scripted policy (`env.expert_policy`, LeRobot's choice
    of `metaworld.policies` class) acts, N(0, `action_noise`) added to the executed xyz, until MetaWorld's
    success flag is on; then it holds still (no motion, its last grab effort, no noise) to step
    `episode_steps` (`hold_once_done=False`: it acts to the end, as the collector did before the hold).
    `on_step(observation, action)` sees each step's observation and recorded action before the step.
    Returns the success flag after each step."""
    perturb = ActionNoise(action_noise, seed) if action_noise > 0 else None
    observation, _ = env.reset(seed=seed)
    hold: np.ndarray | None = None  # the still action, once the task is done
    successes = []
    for _ in range(episode_steps):
        acting = hold is None
        state = observation["environment_state"]
        action = scripted_action(env, state) if acting else hold
        if on_step is not None:
            on_step(observation, action)
        observation, *_ = env.step(perturb(action) if perturb and acting else action)
        successes.append(env.success_now)
        if acting and hold_once_done and env.success_now:
            hold = np.array([0.0, 0.0, 0.0, action[3]])
    return successes
