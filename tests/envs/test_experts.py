import pytest

from lerobot_ivmc.envs import DEMO_EPISODE_STEPS, TASKS, make_task_env
from lerobot_ivmc.experts import make_expert, run_expert_episode


@pytest.mark.parametrize("task", TASKS)
def test_expert_succeeds_within_a_demo_on_sampled_scenes(task):
    env = make_task_env(task, obs_type="state", terminate_on_success=False)
    expert = make_expert(env)
    results = [run_expert_episode(env, expert, seed=1000 + s)["is_success"] for s in range(6)]
    assert all(results), f"{task} expert failed on seeds {[s for s, ok in enumerate(results) if not ok]}"


def test_expert_episode_lasts_exactly_one_demo_when_not_terminating():
    env = make_task_env("push", obs_type="state", terminate_on_success=False)
    steps = []
    run_expert_episode(env, make_expert(env), seed=0, on_step=lambda *args: steps.append(args))
    assert len(steps) == DEMO_EPISODE_STEPS


def test_expert_actions_are_valid_env_actions():
    env = make_task_env("pick_reach", obs_type="state")
    expert = make_expert(env)
    actions = []
    run_expert_episode(env, expert, seed=0, on_step=lambda _o, a, _i: actions.append(a))
    for action in actions:
        assert env.action_space.contains(action)
        assert action[3] in (-1.0, 0.0, 1.0)
