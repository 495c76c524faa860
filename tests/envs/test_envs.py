import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from lerobot_ivmc.envs import TASKS, gym_id, make_task_env
from lerobot_ivmc.envs.scenes import JITTER_FRACTION, SPLITS, scenes_of_split


@pytest.mark.parametrize("task", TASKS)
def test_gymnasium_env_checker_passes(task):
    env = gym.make(gym_id(task), image_size=32, render_size=32)
    check_env(env.unwrapped, skip_render_check=False)
    env.close()


@pytest.mark.parametrize("task", TASKS)
def test_same_seed_gives_same_scene_and_first_frame(task):
    env_a, env_b = make_task_env(task, image_size=32), make_task_env(task, image_size=32)
    obs_a, info_a = env_a.reset(seed=123)
    obs_b, info_b = env_b.reset(seed=123)
    assert env_a.scene == env_b.scene
    np.testing.assert_array_equal(obs_a["pixels"]["front"], obs_b["pixels"]["front"])
    np.testing.assert_array_equal(obs_a["environment_state"], obs_b["environment_state"])
    scenes = {make_task_env(task, obs_type="state").reset(seed=s)[1]["scene_object_cell"] for s in range(8)}
    assert len(scenes) > 1, "different seeds should spawn the object in different cells"
    env_a.close()
    env_b.close()


@pytest.mark.parametrize("task", TASKS)
def test_scene_splits_are_disjoint_and_cover_all_scenes(task):
    all_scenes = make_task_env(task, obs_type="state").all_scenes()
    splits = {name: set(scenes_of_split(all_scenes, name)) for name in SPLITS}
    assert not splits["train"] & splits["test"]
    assert not splits["train"] & splits["val"]
    assert not splits["val"] & splits["test"]
    assert set().union(*splits.values()) == set(all_scenes)
    assert len(splits["test"]) >= 50, "the paper evaluates on held-out scenes: the test split must be large"


def test_seeds_zero_to_n_minus_one_visit_every_scene_of_the_split_once():
    env = make_task_env("pick_place", obs_type="state", split="test")
    visited = []
    for seed in range(len(env.scenes)):
        env.reset(seed=seed)
        visited.append(env.scene)
    assert set(visited) == set(env.scenes) and len(visited) == len(set(visited))
    first_cells = [scene.object_cell for scene in visited[:10]]
    assert len(set(first_cells)) > 3, "consecutive seeds should spread over the table, not walk the grid"


def test_reset_draws_only_scenes_of_its_split():
    env = make_task_env("pick_place", obs_type="state", split="test")
    test_scenes = set(env.scenes)
    assert all(env.reset(seed=s)[0] is not None and env.scene in test_scenes for s in range(20))
    with pytest.raises(ValueError, match="out of range"):
        env.reset(options={"scene_index": len(env.scenes)})


def test_observation_has_lerobot_keys_and_auxiliary_targets():
    env = make_task_env("pick_place", image_size=48)
    obs, _ = env.reset(seed=0)
    assert obs["pixels"]["front"].shape == (48, 48, 3) and obs["pixels"]["front"].dtype == np.uint8
    assert obs["agent_pos"].shape == (9,)
    np.testing.assert_allclose(obs["environment_state"][:3], env.grip_position)
    np.testing.assert_allclose(obs["environment_state"][3:], env.object_position)
    env.close()


def test_env_pickles_for_async_vector_envs():
    env = make_task_env("push", obs_type="state")
    clone = pickle.loads(pickle.dumps(env))
    obs, _ = env.reset(seed=5)
    obs_clone, _ = clone.reset(seed=5)
    np.testing.assert_array_equal(obs["environment_state"], obs_clone["environment_state"])


def test_gripper_commands_close_and_open_the_fingers():
    env = make_task_env("pick_place", obs_type="state")
    env.reset(seed=0)
    for _ in range(10):
        env.step(np.array([0, 0, 0, -1], dtype=np.float32))
    closed = env.finger_positions.copy()
    for _ in range(5):
        env.step(np.array([0, 0, 0, 0], dtype=np.float32))
    np.testing.assert_allclose(env.finger_positions, closed, atol=2e-3)  # no-op holds the fingers
    for _ in range(5):
        env.step(np.array([0, 0, 0, 1], dtype=np.float32))
    assert np.all(env.finger_positions > closed + 0.03)


def test_delta_action_moves_the_end_effector():
    env = make_task_env("pick_place", obs_type="state")
    env.reset(seed=0)
    start = env.grip_position
    for _ in range(5):
        env.step(np.array([1.0, 0, 0, 0], dtype=np.float32))
    moved = env.grip_position - start
    assert 0.1 < moved[0] < 0.26, "5 full steps move up to 5 x 5 cm along x"
    assert abs(moved[1]) < 0.02 and abs(moved[2]) < 0.02


@pytest.mark.parametrize("direction", [(-1, -1, 1), (1, 1, 1), (1, -1, -1), (-1, 1, -1)])
def test_gripper_stays_inside_the_workspace_the_camera_sees(direction):
    env = make_task_env("pick_place", obs_type="state")
    env.reset(seed=0)
    for _ in range(25):
        env.step(np.array([*direction, 0], dtype=np.float32))
    low, high = env.grip_workspace
    assert np.all(env.grip_position > low - 0.01) and np.all(env.grip_position < high + 0.01)
    assert np.any(np.abs(env.grip_position - np.where(np.array(direction) > 0, high, low)) < 0.01)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"image_size": 0}, "image_size must be a positive"),
        ({"render_size": -4}, "render_size"),
        ({"obs_type": "depth"}, "Unknown obs_type"),
        ({"split": "holdout"}, "Unknown scene split"),
    ],
)
def test_bad_env_arguments_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        make_task_env("push", **kwargs)


@pytest.mark.parametrize("name", ["image_size", "render_size"])
def test_sizes_mujoco_cannot_render_are_refused_with_the_allowed_range(name):
    with pytest.raises(ValueError, match=f"{name} must be a positive integer number of pixels, at most 2048"):
        make_task_env("push", **{name: 4096})


def test_sizes_above_the_default_offscreen_framebuffer_render():
    """The Fetch XML's framebuffer is 640 x 480; the env enlarges it to the sizes it is asked for."""
    env = make_task_env("push", image_size=500, render_size=720)
    observation, _ = env.reset(seed=0)
    assert observation["pixels"]["front"].shape == (500, 500, 3) and observation["pixels"]["front"].std() > 0
    assert env.render().shape == (720, 720, 3)
    env.close()
    small = make_task_env("push", image_size=32)
    assert (small.model.vis.global_.offwidth, small.model.vis.global_.offheight) == (640, 480)  # unchanged
    small.close()


def test_unknown_task_is_refused_with_the_valid_names():
    with pytest.raises(ValueError, match="pick_place"):
        make_task_env("stack")


@pytest.mark.parametrize("gripper", [2.0, -1.5, 7])
def test_gripper_command_outside_the_three_values_is_refused(gripper):
    env = make_task_env("push", obs_type="state")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"-1 \(close\), 0 \(no-op\) or \+1 \(open\)"):
        env.step(np.array([0, 0, 0, gripper], dtype=np.float32))


def test_malformed_actions_are_refused():
    env = make_task_env("push", obs_type="state")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan, 0, 0, 0]))


@pytest.mark.parametrize("task", TASKS)
def test_seeds_past_the_split_revisit_its_setups_moved_within_their_cells(task):
    env = make_task_env(task, obs_type="state", split="test")
    n = len(env.scenes)

    def placed(seed):
        env.reset(seed=seed)
        target = env.model.body_pos[env._target_body][:2].copy()
        return env.scene, env.object_position[:2].copy(), target

    scene, object_xy, target_xy = placed(3)
    np.testing.assert_allclose(object_xy, env.object_grid.position(scene.object_cell), atol=1e-6)
    np.testing.assert_allclose(target_xy, env.target_grid.position(scene.target_cell), atol=1e-6)
    moved = [placed(3 + cycle * n) for cycle in (1, 2)]
    for again, obj, tgt in moved:
        assert again == scene, "a later seed revisits the same held-out cell pair"
        placements = ((env.object_grid, scene.object_cell, obj), (env.target_grid, scene.target_cell, tgt))
        for grid, cell, xy in placements:
            offset = np.abs(xy - grid.position(cell)) / np.maximum(grid.spacing, 1e-9)
            assert np.all(offset <= JITTER_FRACTION + 1e-6), "the jitter stays inside the cell"
    assert not np.allclose(moved[0][1], moved[1][1]), "each cycle moves the object elsewhere"
    assert not np.allclose(moved[0][1], object_xy)
    np.testing.assert_array_equal(placed(3 + n)[1], moved[0][1])  # the seed alone decides
