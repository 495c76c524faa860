"""Milestones flip exactly when their physical condition first holds, in order, and stay reached."""

import numpy as np
import pytest

from lerobot_ivmc.envs import make_task_env
from lerobot_ivmc.envs.tasks.common import PICK_LIFT, rests_on_target, xy_distance
from lerobot_ivmc.envs.tasks.pick_place import PICK_REACH_DISTANCE
from lerobot_ivmc.envs.tasks.push import PUSH_REACH_DISTANCE
from lerobot_ivmc.experts import make_expert, run_expert_episode


def record_expert(task: str, seed: int) -> tuple[list[dict], list[dict]]:
    env = make_task_env(task, obs_type="state", terminate_on_success=False)
    expert = make_expert(env)
    infos, states = [], []

    def on_step(_obs, _action, info):
        infos.append(info)
        states.append(
            {
                "grip": env.grip_position,
                "object": env.object_position,
                "grasped": env.is_grasped(),
                "lift": env.object_lift(),
                "on_target": rests_on_target(env),
                "target": env.target_position,
            }
        )

    run_expert_episode(env, expert, seed=seed, on_step=on_step)
    return infos, states


def first_step(infos: list[dict], name: str) -> int:
    return next(i for i, info in enumerate(infos) if info["subtasks"][name])


def assert_latched(infos: list[dict], name: str) -> None:
    flags = [info["subtasks"][name] for info in infos]
    first = flags.index(True)
    assert all(flags[first:]), f"{name} must stay reached once reached"


@pytest.mark.parametrize("seed", [0, 1])
def test_pick_place_milestones_flip_at_the_right_moments(seed):
    infos, states = record_expert("pick_place", seed)
    reach, pick, place = (first_step(infos, n) for n in ("reach", "pick", "place"))
    assert 0 < reach < pick < place
    for name in ("reach", "pick", "place"):
        assert_latched(infos, name)
    # reach flips on the first step the grip point comes within the reach distance of the cube
    distances = [np.linalg.norm(s["grip"] - s["object"]) for s in states]
    assert distances[reach] < PICK_REACH_DISTANCE <= min(distances[:reach])
    # pick flips on the first step the cube is held by both fingers and lifted
    held = [s["grasped"] and s["lift"] > PICK_LIFT for s in states]
    assert held.index(True) == pick
    # place flips when the released cube lies on the target; it was not on the target before
    assert states[place]["on_target"] and not states[place]["grasped"]
    assert not any(s["on_target"] and not s["grasped"] for s in states[:place])
    assert infos[-1]["is_success"]


def test_pushing_the_cube_onto_the_target_is_not_a_place():
    """pick_place's `place` needs the pick first: slide the cube onto the target with the push expert."""
    from lerobot_ivmc.envs.tasks.push import PushEnv
    from lerobot_ivmc.experts.push import PushExpert

    scene = next(s for s in PushEnv.all_scenes())  # a scene that is valid for both tasks
    env = make_task_env("pick_place", obs_type="state", split="all", terminate_on_success=False)
    index = env.scenes.index(scene)
    expert = PushExpert(env)
    final = run_expert_episode(env, expert, options={"scene_index": index})
    assert rests_on_target(env), "the push expert should have slid the cube onto the target"
    assert not final["subtasks"]["pick"] and not final["subtasks"]["place"]


def test_push_milestones_flip_at_the_right_moments():
    infos, states = record_expert("push", seed=3)
    reach, push = first_step(infos, "reach"), first_step(infos, "push")
    assert 0 < reach < push
    distances = [np.linalg.norm(s["grip"] - s["object"]) for s in states]
    assert distances[reach] < PUSH_REACH_DISTANCE <= min(distances[:reach])
    assert xy_distance(states[push]["object"], states[push]["target"]) < 0.03
    assert not any(s["on_target"] for s in states[:push])
    assert_latched(infos, "push")


def test_pick_reach_milestones_flip_in_order():
    infos, states = record_expert("pick_reach", seed=2)
    reach, pick, task = (first_step(infos, n) for n in ("reach", "pick", "task"))
    assert 0 < reach < pick < task
    assert states[task]["grasped"], "the stick must be held while its far end touches the target"
    for name in ("reach", "pick", "task"):
        assert_latched(infos, name)


def test_success_terminates_the_episode_when_asked():
    env = make_task_env("pick_place", obs_type="state", terminate_on_success=True)
    expert = make_expert(env)
    env.reset(seed=0)
    expert.reset()
    for step in range(100):  # noqa: B007 - the last step is checked below
        _, reward, terminated, truncated, info = env.step(expert.act())
        if terminated:
            break
    assert terminated and info["is_success"] and reward == 1.0
    assert step < 99
