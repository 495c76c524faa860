"""Recording one expert demonstration: runs in the collection's worker processes.

This module imports no LeRobot code, so spawned workers start quickly; they write each finished episode to
the staging folder themselves (see `lerobot_ivmc.datasets.staging`) and send back only its attempt index.
"""

from __future__ import annotations

import signal
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.envs import DEMO_EPISODE_STEPS, make_task_env
from lerobot_ivmc.envs.camera import CAMERA_NAME
from lerobot_ivmc.envs.fetch_env import DELTA_EE_DIM, IvmcFetchEnv
from lerobot_ivmc.envs.render_styles import DEFAULT_RENDER_STYLE
from lerobot_ivmc.experts import WaypointExpert, make_expert, run_expert_episode


def attempt_seed(base_seed: int, attempt: int) -> int:
    """Scene seed of attempt `attempt`: a fixed function of (base seed, attempt), so reruns repeat it.

    Attempts are numbered 0, 1, 2, ...; the dataset keeps the successful ones in attempt order.
    """
    return int(np.random.SeedSequence([base_seed, attempt]).generate_state(1, dtype=np.uint32)[0])


@dataclass
class ActionNoise:
    """Gaussian noise on the executed delta-EE command (DART, Laskey et al. 2017).

    The demo records the expert's clean action while the robot executes a perturbed one, so the data shows
    how the expert recovers from small deviations: the states a learned policy drifts into.

    Args:
        std: standard deviation in action units (1 unit = 5 cm); 0 executes the expert's action unchanged.
        seed: seeds the noise of one episode (the attempt's scene seed), so reruns repeat it.
    """

    std: float
    seed: int

    def __post_init__(self) -> None:
        self._rng = np.random.default_rng([self.seed, 1])

    def __call__(self, action: np.ndarray) -> np.ndarray:
        noisy = action.copy()
        noisy[:DELTA_EE_DIM] = np.clip(
            noisy[:DELTA_EE_DIM] + self._rng.normal(0.0, self.std, DELTA_EE_DIM), -1.0, 1.0
        )
        return noisy


@dataclass
class Recorder:
    """An env and its expert that record attempts into a staging folder.

    Args:
        task: task name, one of `lerobot_ivmc.envs.TASKS`.
        image_size: camera image height and width, in pixels.
        split: scene split the seeds draw from ("train", "val", "test").
        base_seed: the collection's `--seed`.
        episodes_dir: where finished attempts are staged.
        action_noise: std of the noise on the executed delta-EE command (`ActionNoise`); 0 for none.
        episode_steps: steps of every demo (the expert holds its final pose once done).
        render_style: how the camera image is drawn (`fetch_env.RENDER_STYLES`).
        expert_after_success: "hold" (the Fetch expert holds its final pose; MetaWorld's recorder also
            takes "act").
    """

    task: str
    image_size: int
    split: str
    base_seed: int
    episodes_dir: Path
    action_noise: float = 0.0
    episode_steps: int = DEMO_EPISODE_STEPS
    render_style: str = DEFAULT_RENDER_STYLE
    expert_after_success: str = "hold"

    def __post_init__(self) -> None:
        self.check_after_success()
        # Demos always last `episode_steps` steps: success does not end them.
        self.env: IvmcFetchEnv = make_task_env(
            self.task,
            image_size=self.image_size,
            split=self.split,
            terminate_on_success=False,
            render_style=self.render_style,
        )
        self.expert: WaypointExpert = make_expert(self.env)

    def check_after_success(self) -> None:
        """Refuse an `expert_after_success` the task's suite does not offer (`DemoSuite.after_success`)."""
        from lerobot_ivmc.datasets.demo_suites import suite_of

        offered = suite_of(self.task).after_success
        if self.expert_after_success not in offered:
            raise ValueError(
                f"expert_after_success must be one of {offered} for {self.task}, got "
                f"{self.expert_after_success!r}."
            )

    def record(self, attempt: int) -> tuple[int, bool]:
        """Run attempt `attempt`, stage it (episode file or failure marker), return (attempt, success)."""
        seed = attempt_seed(self.base_seed, attempt)
        images, states, env_states, actions = [], [], [], []

        def on_step(observation: dict, action: np.ndarray, info: dict) -> None:
            images.append(observation["pixels"][CAMERA_NAME])
            states.append(observation["agent_pos"])
            env_states.append(observation["environment_state"])
            actions.append(action)

        perturb = ActionNoise(self.action_noise, seed) if self.action_noise > 0 else None
        info = run_expert_episode(
            self.env, self.expert, seed=seed, max_steps=self.episode_steps, on_step=on_step, perturb=perturb
        )
        success = bool(info["is_success"]) and len(actions) == self.episode_steps
        if not success:
            staging.write_failure(self.episodes_dir, attempt)
            return attempt, False
        episode = staging.StagedEpisode.from_steps(
            attempt,
            seed,
            (images, states, env_states, actions),
            int(info["scene_object_cell"]),
            int(info["scene_target_cell"]),
        )
        staging.write_episode(self.episodes_dir, episode)
        return attempt, True

    def close(self) -> None:
        self.env.close()


_worker_recorder = None  # this worker's `Recorder` (or the suite's recorder of the same interface)


def init_worker(
    task: str,
    image_size: int,
    split: str,
    base_seed: int,
    episodes_dir: Path,
    action_noise: float,
    episode_steps: int = DEMO_EPISODE_STEPS,
    render_style: str = DEFAULT_RENDER_STYLE,
    expert_after_success: str = "hold",
) -> None:
    """Pool initializer: build the worker's env once. Ctrl-C is left to the parent, which stops the pool."""
    global _worker_recorder
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from lerobot_ivmc.datasets.demo_suites import suite_of

    _worker_recorder = suite_of(task).recorder_class()(
        task,
        image_size,
        split,
        base_seed,
        Path(episodes_dir),
        action_noise,
        episode_steps,
        render_style,
        expert_after_success,
    )


def record_in_worker(attempt: int) -> tuple[int, bool]:
    """Pool task: record one attempt with the worker's recorder."""
    assert _worker_recorder is not None, "init_worker() must run first"
    return _worker_recorder.record(attempt)
