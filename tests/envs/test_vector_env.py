"""The evaluation vector envs: a sub-env whose episode ended parks (no simulation, no rendering) until the
next batch, and the seeded episodes are the same as with LeRobot's autoreset."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.envs.vector_env import make_vector_env
from lerobot_ivmc.experts import make_expert

EPISODE_LENGTH = 80
SEEDS = [0, 1, 2]


class StepCounter(gym.Wrapper):
    """Counts the steps that reach the simulation."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        self.simulated_steps = 0

    def step(self, action):
        self.simulated_steps += 1
        return self.env.step(action)


def config() -> IvmcEnv:
    return IvmcEnv(task="pick_place", obs_type="state", episode_length=EPISODE_LENGTH)


def expert_batch(vec: gym.vector.VectorEnv) -> tuple[np.ndarray, np.ndarray]:
    """Drive a batch of seeded scenes with the scripted experts until every sub-env is done, as LeRobot's
    rollout does; the (T, B, 4) actions sent and the step each sub-env's episode ended on."""
    vec.reset(seed=SEEDS)
    experts = [make_expert(env.unwrapped) for env in vec.envs]
    for expert in experts:
        expert.reset()
    done, ends, actions = np.zeros(vec.num_envs, dtype=bool), np.zeros(vec.num_envs, dtype=int), []
    while not done.all():
        actions.append(np.stack([expert.act() for expert in experts]))
        _, _, terminated, truncated, _ = vec.step(actions[-1])
        ends[(terminated | truncated) & ~done] = len(actions) - 1
        done |= terminated | truncated
    return np.stack(actions), ends


def replay(vec: gym.vector.VectorEnv, actions: np.ndarray) -> dict[str, np.ndarray]:
    """Send the same actions after a seeded reset; every step's (B, ...) results, stacked over steps (the
    state of a step that ended an episode: its final one, which autoreset moves to the info)."""
    vec.reset(seed=SEEDS)
    steps = [vec.step(action) for action in actions]
    states = []
    for observation, *_, info in steps:
        state = observation["environment_state"].copy()
        for j in np.flatnonzero(info.get("_final_obs", [])):
            state[j] = info["final_obs"][j]["environment_state"]
        states.append(state)
    return {
        "state": np.stack(states),
        "reward": np.stack([s[1] for s in steps]),
        "terminated": np.stack([s[2] for s in steps]),
    }


def test_a_finished_sub_env_parks_until_the_next_batch_with_the_same_seeded_episodes():
    lerobot_way = make_vector_env(config(), len(SEEDS), use_async=False, wrap=StepCounter, park=False)
    actions, ends = expert_batch(lerobot_way)
    assert len(set(ends)) > 1 and ends.min() < len(actions) - 1, "sub-envs must finish at different steps"
    reference = replay(lerobot_way, actions)
    for use_async in (False, True):
        parking = make_vector_env(config(), len(SEEDS), use_async=use_async, wrap=StepCounter)
        parked = replay(parking, actions)
        for j, end in enumerate(ends):
            # The seeded episode step for step as LeRobot's autoreset gives it ...
            for key in parked:
                np.testing.assert_array_equal(parked[key][: end + 1, j], reference[key][: end + 1, j])
            assert parked["terminated"][end, j]
            # ... then its final observation, with nothing simulated, instead of an unseeded episode.
            assert (parked["state"][end + 1 :, j] == parked["state"][end, j]).all()
            assert not parked["reward"][end + 1 :, j].any() and not parked["terminated"][end + 1 :, j].any()
        assert list(parking.get_attr("simulated_steps")) == list(ends + 1)
        # The next batch's reset starts new seeded episodes in the parked sub-envs.
        first, _ = parking.reset(seed=[5, 6, 7])
        fresh, _ = lerobot_way.reset(seed=[5, 6, 7])
        np.testing.assert_array_equal(first["environment_state"], fresh["environment_state"])
        parking.step(actions[0])
        assert list(parking.get_attr("simulated_steps")) == list(ends + 2)
        parking.close()
    # Without parking every sub-env is simulated at every step of the batch.
    assert list(lerobot_way.get_attr("simulated_steps")) == [2 * len(actions)] * len(SEEDS)
    lerobot_way.close()


def test_success_flags_are_python_bools_so_a_parked_env_reads_false() -> None:
    """A milestone read from a comparison of positions is a numpy bool (pick_reach's stick over the target
    but too high). Reported as such, gymnasium's vector env collects `is_success` in an object array with
    None for a sub-env parked after an earlier success, and LeRobot's rollout fails on it; the envs report
    Python bools, so the parked sub-env reads False."""
    vec = make_vector_env(config(), 2, use_async=False)
    vec.reset(seed=SEEDS[:2])
    statuses = [
        {"reach": True, "pick": True, "place": True},
        {"reach": np.False_, "pick": np.False_, "place": np.False_},
    ]
    for env, status in zip(vec.envs, statuses, strict=True):
        env.unwrapped._subtask_status = lambda status=status: status
    _, _, terminated, _, _ = vec.step(np.zeros((2, 4), dtype=np.float32))
    assert terminated.tolist() == [True, False]  # the first succeeds at once and parks
    for _ in range(EPISODE_LENGTH - 1):
        _, _, _, truncated, info = vec.step(np.zeros((2, 4), dtype=np.float32))
    assert truncated.tolist() == [False, True]
    assert info["final_info"]["is_success"].dtype == bool
    assert info["final_info"]["is_success"].tolist() == [False, False]
