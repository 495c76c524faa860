import numpy as np
import pytest

from lerobot_ivmc.envs import DEMO_EPISODE_STEPS, TASKS, make_task_env
from lerobot_ivmc.experts import make_expert, run_expert_episode

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow


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


@pytest.mark.parametrize("task", TASKS)
def test_after_its_last_waypoint_the_expert_holds_that_pose_against_action_noise(task):
    """With injected action noise (DART demos), the finished expert steers back to its last waypoint instead
    of labelling a random walk "stay still"; without noise it stays still."""
    from lerobot_ivmc.datasets.expert_attempts import ActionNoise

    env = make_task_env(task, image_size=32, terminate_on_success=False)
    expert = make_expert(env)
    for noise in (0.0, 0.15):
        checked = 0
        for seed in range(4):
            grips, actions, done = [], [], []

            def on_step(observation, action, info, grips=grips, actions=actions, done=done):
                grips.append(env.grip_position.copy())
                actions.append(action)
                done.append(expert.done)

            perturb = ActionNoise(noise, seed) if noise else None
            run_expert_episode(env, expert, seed=seed, on_step=on_step, perturb=perturb)
            if True not in done or done.index(True) > DEMO_EPISODE_STEPS - 10:  # too late to show a hold
                continue
            first = done.index(True)
            checked += 1
            away = np.linalg.norm(np.stack(grips[first:]) - grips[first], axis=1)
            if noise == 0:
                assert np.all(np.stack(actions[first:])[:, :3] == 0) and away.max() < 0.01
            else:
                # Noise steps of 0.75 cm per axis random-walk ~5 cm in 50 steps; the hold stays near the goal.
                assert np.abs(np.stack(actions[first:])[:, :3]).max() > 0, "it corrects the noise"
                from_goal = np.linalg.norm(np.stack(grips[first:]) - expert._goal, axis=1)
                assert np.median(from_goal) < 0.025, from_goal
        assert checked >= 2
    env.close()
