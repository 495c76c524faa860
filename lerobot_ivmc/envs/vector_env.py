"""Vector envs of the ivmc tasks: every sub-env in this process, or each in its own (`--eval.use_async_envs`).

LeRobot's `make_env` builds its `AsyncVectorEnv` with the platform's default start method, `fork` on Linux,
and a sub-env forked from a process whose MuJoCo has rendered deadlocks in its inherited EGL context. The
sub-envs here start from a forkserver instead, a clean process that never rendered. LeRobot 0.4.4's
`rollout` and `eval_policy` also read `vector_env.envs[i]` (the task attributes, `render()` for videos),
which only a `SyncVectorEnv` has: `RolloutAsyncVectorEnv` answers them from the sub-env processes.

LeRobot's `rollout` steps every sub-env until the whole batch is done, and a sub-env whose episode ended
early is autoreset into an unseeded episode nobody reads (on pick_place's test scenes, 9,117 of the
20,000 sub-env steps of a 100-episode evaluation belong to seeded episodes). The sub-envs here park
instead: after its episode ends, a sub-env answers with its final observation, without simulating or
rendering, until the vector env's next `reset`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv

ASYNC_START_METHOD = "forkserver"
# The reset option by which a parking vector env's `reset` tells its sub-envs a new episode starts (the
# vector env's autoreset calls a sub-env's `reset()` without it).
NEW_EPISODE_OPTION = "ivmc_new_episode"


def split_new_episode_flag(options: dict[str, Any] | None) -> tuple[bool, dict[str, Any] | None]:
    """Whether `options` carry the new-episode flag, and the options left for the sub-env (None if none)."""
    options = dict(options or {})
    new_episode = bool(options.pop(NEW_EPISODE_OPTION, False))
    return new_episode, options or None


class ParkAfterEpisode(gym.Wrapper):
    """A sub-env that, once its episode has ended, repeats its final observation instead of starting an
    unseeded episode: the vector env's autoreset gets the final observation and info back, and every later
    step the final observation with reward 0, not terminated, not truncated and an empty info, at no
    simulation or rendering cost. A `reset` with `NEW_EPISODE_OPTION` (the parking vector envs' `reset`)
    starts the next episode; a `reset` without it while nothing is parked resets as usual."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        self._final: tuple[Any, dict] | None = None  # (observation, info) of the ended episode

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        new_episode, options = split_new_episode_flag(options)
        if self._final is not None and not new_episode:
            return self._final
        self._final = None
        return self.env.reset(seed=seed, options=options)

    def step(self, action):
        if self._final is not None:
            return self._final[0], 0.0, False, False, {}
        observation, reward, terminated, truncated, info = self.env.step(action)
        if terminated or truncated:
            self._final = (observation, info)
        return observation, reward, terminated, truncated, info


class NeverPark(gym.Wrapper):
    """A sub-env of a parking vector env that autoresets as LeRobot's do (it drops the new-episode flag)."""

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        return self.env.reset(seed=seed, options=split_new_episode_flag(options)[1])


def new_episode_options(options: dict[str, Any] | None) -> dict[str, Any]:
    """`options` with the flag that starts a new episode in every parked sub-env."""
    return {**(options or {}), NEW_EPISODE_OPTION: True}


class ParkingSyncVectorEnv(gym.vector.SyncVectorEnv):
    """A `SyncVectorEnv` of `ParkAfterEpisode` sub-envs: its `reset` starts a new episode in each."""

    def reset(self, *, seed=None, options=None):
        return super().reset(seed=seed, options=new_episode_options(options))


class SubEnvHandle:
    """Sub-env `index` of an async vector env, as LeRobot's rollout reads a sub-env of a sync one."""

    def __init__(self, vector_env: RolloutAsyncVectorEnv, index: int):
        self._vector_env = vector_env
        self._index = index

    def render(self) -> np.ndarray:
        """This sub-env's `render()` frame of the current step."""
        return self._vector_env.rendered_frames()[self._index]


class RolloutAsyncVectorEnv(gym.vector.AsyncVectorEnv):
    """An `AsyncVectorEnv` with the `envs` list LeRobot's `rollout` reads, as handles to its sub-envs, of
    `ParkAfterEpisode` sub-envs: its `reset` starts a new episode in each."""

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

    def reset_async(self, seed=None, options=None):
        super().reset_async(seed=seed, options=new_episode_options(options))

    def reset_wait(self, *args, **kwargs):
        self._frames = None
        return super().reset_wait(*args, **kwargs)

    def step_wait(self, *args, **kwargs):
        self._frames = None
        return super().step_wait(*args, **kwargs)


def make_vector_env(
    env_cfg: IvmcEnv,
    n_envs: int,
    use_async: bool,
    wrap: Callable[[gym.Env], gym.Env] | None = None,
    park: bool = True,
) -> gym.vector.VectorEnv:
    """`n_envs` sub-envs as LeRobot's `make_env` builds them (same-step autoreset), each wrapped by `wrap`
    and parked after its episode (`ParkAfterEpisode`).

    Args:
        env_cfg: the env of every sub-env.
        n_envs: sub-envs (the batch size of LeRobot's `rollout`).
        use_async: one process per sub-env, started from a forkserver; else all in this process.
        wrap: applied to each sub-env (in its own process when async); must be picklable by cloudpickle.
        park: park the sub-envs whose episode ended; False: they autoreset into unseeded episodes, as
            LeRobot's do (the same results for the seeded episodes, at the cost of simulating the others).
    """
    if n_envs < 1:
        raise ValueError(f"A vector env needs at least one sub-env, got --eval.batch_size={n_envs}.")

    def make_one() -> gym.Env:
        env = gym.make(env_cfg.gym_id, disable_env_checker=True, **env_cfg.gym_kwargs)
        env = wrap(env) if wrap is not None else env
        return ParkAfterEpisode(env) if park else NeverPark(env)

    env_fns = [make_one] * n_envs
    autoreset = gym.vector.AutoresetMode.SAME_STEP
    if use_async:
        return RolloutAsyncVectorEnv(env_fns, autoreset_mode=autoreset, context=ASYNC_START_METHOD)
    return ParkingSyncVectorEnv(env_fns, autoreset_mode=autoreset)
