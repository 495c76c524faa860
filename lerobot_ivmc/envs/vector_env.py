"""Vector envs of the ivmc tasks: every sub-env in this process, or each in its own (`--eval.use_async_envs`).

LeRobot's `make_env` builds its `AsyncVectorEnv` with the platform's default start method, `fork` on Linux,
and a sub-env forked from a process whose MuJoCo has rendered deadlocks in its inherited EGL context. The
sub-envs here start from a forkserver instead, a clean process that never rendered. LeRobot 0.4.4's
`rollout` and `eval_policy` also read `vector_env.envs[i]` (the task attributes, `render()` for videos),
which only a `SyncVectorEnv` has: `RolloutAsyncVectorEnv` answers them from the sub-env processes.
"""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv

ASYNC_START_METHOD = "forkserver"


class SubEnvHandle:
    """Sub-env `index` of an async vector env, as LeRobot's rollout reads a sub-env of a sync one."""

    def __init__(self, vector_env: RolloutAsyncVectorEnv, index: int):
        self._vector_env = vector_env
        self._index = index

    def render(self) -> np.ndarray:
        """This sub-env's `render()` frame of the current step."""
        return self._vector_env.rendered_frames()[self._index]


class RolloutAsyncVectorEnv(gym.vector.AsyncVectorEnv):
    """An `AsyncVectorEnv` with the `envs` list LeRobot's `rollout` reads, as handles to its sub-envs."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._frames: tuple | None = None  # every sub-env's render() of the current step, once asked for

    @property
    def envs(self) -> list[SubEnvHandle]:
        return [SubEnvHandle(self, index) for index in range(self.num_envs)]

    def rendered_frames(self) -> tuple:
        """Every sub-env's `render()` frame of the current step (rendered together, once a step)."""
        if self._frames is None:
            self._frames = self.call("render")
        return self._frames

    def reset_wait(self, *args, **kwargs):
        self._frames = None
        return super().reset_wait(*args, **kwargs)

    def step_wait(self, *args, **kwargs):
        self._frames = None
        return super().step_wait(*args, **kwargs)


def make_vector_env(
    env_cfg: IvmcEnv, n_envs: int, use_async: bool, wrap: Callable[[gym.Env], gym.Env] | None = None
) -> gym.vector.VectorEnv:
    """`n_envs` sub-envs as LeRobot's `make_env` builds them (same-step autoreset), each wrapped by `wrap`.

    Args:
        env_cfg: the env of every sub-env.
        n_envs: sub-envs (the batch size of LeRobot's `rollout`).
        use_async: one process per sub-env, started from a forkserver; else all in this process.
        wrap: applied to each sub-env (in its own process when async); must be picklable by cloudpickle.
    """
    if n_envs < 1:
        raise ValueError(f"A vector env needs at least one sub-env, got --eval.batch_size={n_envs}.")

    def make_one() -> gym.Env:
        env = gym.make(env_cfg.gym_id, disable_env_checker=True, **env_cfg.gym_kwargs)
        return wrap(env) if wrap is not None else env

    env_fns = [make_one] * n_envs
    autoreset = gym.vector.AutoresetMode.SAME_STEP
    if use_async:
        return RolloutAsyncVectorEnv(env_fns, autoreset_mode=autoreset, context=ASYNC_START_METHOD)
    return gym.vector.SyncVectorEnv(env_fns, autoreset_mode=autoreset)
