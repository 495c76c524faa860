"""The MetaWorld suite's env: LeRobot's `MetaworldEnv` with seeded scenes, disjoint splits, a small styled
camera and the state, built by LeRobot's own `make_env`."""

from __future__ import annotations

import builtins

import gymnasium as gym
import numpy as np
import pytest
from lerobot.envs.configs import EnvConfig
from lerobot.envs.factory import make_env
from lerobot.envs.utils import preprocess_observation
from lerobot.utils.constants import OBS_ENV_STATE, OBS_IMAGE, OBS_STATE

import lerobot_ivmc.envs.metaworld as mw
from lerobot_ivmc.envs.metaworld.configuration import SeededMetaworldEnvConfig
from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv
from lerobot_ivmc.envs.metaworld.framing import task_workspace
from lerobot_ivmc.envs.metaworld.scenes import scene_key

TASK = "pick-place-v3"
OBJECT = slice(4, 7)  # the first object's position in MetaWorld's state


@pytest.fixture(scope="module")
def env() -> SeededMetaworldEnv:
    env = SeededMetaworldEnv(TASK, split="val")
    yield env
    env.close()


def scene(env: SeededMetaworldEnv, seed: int, split: str) -> np.ndarray:
    env.split = split
    observation, _ = env.reset(seed=seed)
    return observation["environment_state"][OBJECT].copy()


def test_the_same_seed_gives_the_same_scene_and_other_seeds_other_ones(env: SeededMetaworldEnv) -> None:
    first, again = scene(env, 3, "val"), scene(env, 3, "val")
    np.testing.assert_array_equal(first, again)
    other = SeededMetaworldEnv(TASK, split="val")  # another env: the scene depends on the seed alone
    np.testing.assert_array_equal(scene(other, 3, "val"), first)
    other.close()
    objects = np.stack([scene(env, seed, "val") for seed in range(5)])
    assert len({tuple(o.round(6)) for o in objects}) == 5


def test_validation_and_test_scenes_never_meet(env: SeededMetaworldEnv) -> None:
    val_keys = {scene_key("val", s) for s in range(1000)}
    test_keys = {scene_key("test", s) for s in range(1000)}
    assert not val_keys & test_keys
    val = {tuple(scene(env, s, "val").round(6)) for s in range(10)}
    test = {tuple(scene(env, s, "test").round(6)) for s in range(10)}
    assert not val & test


def test_the_camera_is_drawn_at_the_image_size_and_the_state_is_metaworlds(env: SeededMetaworldEnv) -> None:
    observation, info = env.reset(seed=0)
    assert observation["pixels"].shape == (64, 64, 3) and observation["pixels"].dtype == np.uint8
    assert observation["agent_pos"].shape == (4,) and observation["environment_state"].shape == (39,)
    np.testing.assert_array_equal(observation["agent_pos"], observation["environment_state"][:4])
    assert env.render().shape == (256, 256, 3)
    assert info == {"is_success": False, "subtasks": {"success": False}, "scene_seed": 0}


def test_the_lean_style_draws_nearly_the_flat_frames_and_leaves_the_physics_alone() -> None:
    """ "lean" draws the Sawyer's meshes coarser (a fraction of the triangles) in the same scene."""
    frames, states = {}, {}
    for style in ("flat", "lean"):
        env = SeededMetaworldEnv(TASK, render_style=style, terminate_on_success=False)
        observation, _ = env.reset(seed=4)
        frames[style], states[style] = [observation["pixels"]], [observation["environment_state"]]
        for _ in range(20):
            action = np.clip(env.expert_policy.get_action(observation["environment_state"]), -1, 1)
            observation, *_ = env.step(action)
            frames[style].append(observation["pixels"])
            states[style].append(observation["environment_state"])
        env.close()
    np.testing.assert_array_equal(np.stack(states["flat"]), np.stack(states["lean"]))
    difference = np.abs(np.stack(frames["flat"]).astype(int) - np.stack(frames["lean"]))
    assert 0 < difference.mean() < 2  # grey levels: edges of the arm move by about a pixel


def camera_view(env: SeededMetaworldEnv, points: np.ndarray) -> tuple[np.ndarray, float]:
    """(N, 2) tangents right and up of `points` (world) seen from corner2 as the env's data has it, and the
    tangent of half its field of view."""
    model, data = env.raw_env.model, env.raw_env.data
    camera = model.camera("corner2").id
    offsets = (points - data.cam_xpos[camera]) @ data.cam_xmat[camera].reshape(3, 3)
    return offsets[:, :2] / -offsets[:, 2:], float(np.tan(np.radians(model.cam_fovy[camera]) / 2))


def test_the_framed_style_zooms_on_the_workspace_and_leaves_the_physics_alone() -> None:
    """ "framed" turns corner2 to the centre of the task's workspace box and narrows it until the box just
    fits; it changes nothing but the camera."""
    envs = {style: SeededMetaworldEnv(TASK, render_style=style) for style in ("flat", "framed")}
    try:
        observations = {style: env.reset(seed=4)[0] for style, env in envs.items()}
        low, high = task_workspace(envs["framed"].raw_env)
        corners = np.array(
            [[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])]
        )
        centre, half_view = camera_view(envs["framed"], ((low + high) / 2)[None])
        np.testing.assert_allclose(centre, 0.0, atol=1e-9)  # the box's centre on the camera's axis
        tangents, _ = camera_view(envs["framed"], corners)
        assert np.abs(tangents).max() == pytest.approx(half_view)  # the farthest corner at the frame's edge
        flat_tangents, flat_half_view = camera_view(envs["flat"], corners)
        assert half_view < 0.6 * flat_half_view and np.abs(flat_tangents).max() < flat_half_view
        np.testing.assert_array_equal(
            observations["flat"]["environment_state"], observations["framed"]["environment_state"]
        )
        assert not np.array_equal(observations["flat"]["pixels"], observations["framed"]["pixels"])
    finally:
        for env in envs.values():
            env.close()


def test_framing_reads_where_scenes_are_drawn_not_a_goal_space_of_the_hands_whole_range() -> None:
    """drawer-open-v3's `goal_space` is the hand's whole range; its framed view still narrows corner2."""
    env = SeededMetaworldEnv("drawer-open-v3", render_style="framed")
    try:
        assert (np.asarray(env.raw_env.goal_space.high) - env.raw_env.goal_space.low).min() > 0.3
        env.reset(seed=0)
        _, half_view = camera_view(env, np.zeros((1, 3)))
        assert half_view < np.tan(np.radians(45) / 2)  # corner2: 60 degrees
    finally:
        env.close()


def test_the_scripted_policy_succeeds_and_success_ends_the_episode() -> None:
    env = SeededMetaworldEnv(TASK, split="train")
    observation, _ = env.reset(seed=1)
    for _ in range(200):
        action = env.expert_policy.get_action(observation["environment_state"])
        observation, _, terminated, truncated, info = env.step(action)
        if terminated:
            break
    env.close()
    assert terminated and info["is_success"] is True and not truncated


def test_the_grasp_is_read_where_metaworld_names_the_object_and_unknown_where_it_does_not() -> None:
    """MetaWorld's contact test reads the task's main object geom; door-open-v3 names none (no `objGeom`),
    so `is_grasped` says None there instead of raising (`lerobot-ivmc-inspect` crashed on it)."""
    for task, expected in (("pick-place-v3", False), ("door-open-v3", None)):
        env = SeededMetaworldEnv(task, split="train")
        env.reset(seed=0)
        assert env.is_grasped() is expected, task
        env.close()


def test_lerobots_make_env_builds_it_and_its_observations_map_to_the_hub_datasets_keys() -> None:
    cfg = SeededMetaworldEnvConfig(task=TASK, split="val")
    envs = make_env(cfg, n_envs=2)
    vector_env = envs[cfg.type][0]
    observation, _ = vector_env.reset(seed=[0, 1])
    batch = preprocess_observation(observation)
    assert batch[OBS_IMAGE].shape == (2, 3, 64, 64)
    assert batch[OBS_STATE].shape == (2, 4) and batch[OBS_ENV_STATE].shape == (2, 39)
    assert vector_env.envs[0].task_description == mw.task_description(TASK)
    vector_env.close()


def test_lerobots_own_metaworld_type_is_left_as_it_is() -> None:
    from lerobot.envs.configs import MetaworldEnv

    assert EnvConfig.get_choice_class("metaworld") is MetaworldEnv
    assert EnvConfig.get_choice_class("meta_world") is SeededMetaworldEnvConfig


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"task": "pick-place-v9"}, "Unknown MetaWorld task 'pick-place-v9'"),
        ({"episode_length": 501}, "MetaWorld's own limit"),
        ({"render_style": "glossy"}, "Unknown env.render_style"),
        ({"split": "holdout"}, "Unknown split"),
    ],
)
def test_bad_env_settings_are_refused_in_one_line(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match) as error:
        SeededMetaworldEnvConfig(**kwargs)
    assert "\n" not in str(error.value)


def test_without_metaworld_building_an_env_says_which_extra_to_install(monkeypatch) -> None:
    real_import = builtins.__import__

    def no_metaworld(name, *args, **kwargs):
        if name == "metaworld" or name.startswith("metaworld."):
            raise ImportError("No module named 'metaworld'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_metaworld)
    with pytest.raises(ImportError, match=r"pip install 'lerobot_policy_ivmc\[metaworld\]'"):
        mw.require_metaworld()


def test_a_task_without_a_scripted_policy_cannot_be_collected(monkeypatch) -> None:
    config = dict(mw._lerobot_metaworld_config())
    config["TASK_POLICY_MAPPING"] = {k: v for k, v in config["TASK_POLICY_MAPPING"].items() if k != TASK}
    monkeypatch.setattr(mw, "_lerobot_metaworld_config", lambda: config)
    with pytest.raises(ValueError, match="has no scripted policy"):
        mw.scripted_policy_name(TASK)


def test_the_gym_id_is_registered_with_the_rollout_length() -> None:
    assert gym.spec(mw.GYM_ID).max_episode_steps == mw.ROLLOUT_EPISODE_STEPS
