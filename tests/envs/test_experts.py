import numpy as np
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


@pytest.mark.parametrize("task", ["pick_place", "pick_reach"])
def test_expert_lifts_on_the_first_frame_the_grasp_is_visibly_complete(task):
    """No demo frame shows a settled, closed, motionless gripper labelled "keep still": the lift starts there.

    Otherwise identical frames would carry both labels and a cloned policy could stall after grasping.
    """
    env = make_task_env(task, obs_type="state", terminate_on_success=False)
    expert = make_expert(env)
    for seed in range(4):
        frames: list = []
        run_expert_episode(env, expert, seed=seed, on_step=lambda o, a, _i, out=frames: out.append((o, a)))
        checked = 0
        for (before, _), (now, action) in zip(frames[:-1], frames[1:], strict=True):
            fingers, previous_fingers = now["agent_pos"][7:], before["agent_pos"][7:]
            gripper_moved = np.abs(now["environment_state"][:3] - before["environment_state"][:3]).max()
            closed_and_still = (
                action[3] == -1.0
                and fingers.max() < 0.04
                and np.abs(fingers - previous_fingers).max() < expert.finger_settle_tolerance
                and gripper_moved < 1e-3
            )
            if closed_and_still:
                checked += 1
                assert action[2] > 0.3, f"{task} seed {seed}: settled grasp labelled {action}"
        assert checked >= 1  # the grasp was seen
