import gymnasium as gym
import numpy as np
import pytest

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.evaluation.eval_subtasks import collect_episode_milestones, make_recorded_vector_env
from lerobot_ivmc.evaluation.metrics import aggregate_milestones, rate_with_stderr
from lerobot_ivmc.experts import make_expert


def drive_with_experts(
    vec: gym.vector.SyncVectorEnv, seeds: list[int], max_steps: int
) -> tuple[list[dict], list[int]]:
    """A rollout like LeRobot's: seed once, step every sub-env until all are done.

    Returns each sub-env's milestones at the end of its first episode and the step it ended on."""
    vec.reset(seed=seeds)
    experts = [make_expert(env.unwrapped) for env in vec.envs]
    for expert in experts:
        expert.reset()
    done = np.zeros(vec.num_envs, dtype=bool)
    first_final = [None] * vec.num_envs
    end_steps = [max_steps] * vec.num_envs
    for step in range(max_steps):
        actions = np.stack([expert.act() for expert in experts])
        _, _, terminated, truncated, info = vec.step(actions)
        for j in np.flatnonzero((terminated | truncated) & ~done):
            subtasks = info["final_info"]["subtasks"]
            first_final[j] = {name: bool(flags[j]) for name, flags in subtasks.items() if name[0] != "_"}
            end_steps[j] = step
            experts[j].reset()  # the sub-env restarted on an unseeded scene
        done |= terminated | truncated
        if done.all():
            break
    return first_final, end_steps


def test_recorder_keeps_the_first_episode_of_each_seeded_reset_in_eval_order():
    cfg = IvmcEnv(task="pick_place", obs_type="state", episode_length=80)
    vec = make_recorded_vector_env(cfg, n_envs=2)
    finals, end_steps = drive_with_experts(vec, seeds=[0, 1], max_steps=80)
    more_finals, more_end_steps = drive_with_experts(vec, seeds=[2, 3], max_steps=80)
    end_steps += more_end_steps
    assert len(set(end_steps)) > 1, "some sub-env must finish early and run an unrecorded episode"
    recorded = collect_episode_milestones(vec, n_episodes=3)
    assert recorded == (finals + more_finals)[:3]
    assert all(record["reach"] for record in recorded)
    vec.close()


def test_rates_with_standard_errors():
    rate = rate_with_stderr([True] * 49 + [False] * 51)
    assert rate["pc"] == pytest.approx(49.0)
    assert rate["stderr"] == pytest.approx(100 * np.sqrt(0.49 * 0.51 / 100))
    aggregated = aggregate_milestones([{"reach": True, "pick": False}, {"reach": True, "pick": True}])
    assert aggregated["reach"]["pc"] == 100.0 and aggregated["pick"]["pc"] == 50.0
    with pytest.raises(ValueError, match="No episodes"):
        rate_with_stderr([])
