"""Render styles: "fetch" draws the Fetch XML's frames exactly, "fast" its own; others are refused."""

from __future__ import annotations

import pickle

import mujoco
import numpy as np
import pytest

from lerobot_ivmc.envs import make_task_env, scene_model
from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.envs.render_styles import RENDER_STYLES


def camera_frames(env, steps: int = 5) -> np.ndarray:
    """(steps + 1, H, W, 3) camera images of a seeded episode under fixed random actions."""
    observation, _ = env.reset(seed=3)
    frames = [observation["pixels"][scene_model.CAMERA_NAME]]
    actions = np.random.default_rng(0).uniform(-1, 1, size=(steps, 4)).astype(np.float32)
    for action in actions:
        observation, *_ = env.step(action)
        frames.append(observation["pixels"][scene_model.CAMERA_NAME])
    return np.stack(frames)


def test_the_fetch_style_draws_the_frames_of_the_fetch_xml_settings():
    """The style of every dataset and checkpoint made before render styles: a 640 x 480 4x-multisampled
    framebuffer, as MuJoCo sets it up from the Fetch XML; the env's frame-sized buffer draws the same
    pixels."""
    env = make_task_env("pick_place", image_size=64, render_style="fetch")
    xml_model = scene_model.build_model(env.object_shape, env.target_radius)
    assert (xml_model.vis.global_.offwidth, xml_model.vis.global_.offheight) == (640, 480)
    assert xml_model.vis.quality.offsamples == 4
    xml_renderer = mujoco.Renderer(xml_model, 64, 64)
    try:
        frames = camera_frames(env)
        xml_renderer.update_scene(env.data, camera=scene_model.CAMERA_NAME)
        assert np.array_equal(frames[-1], xml_renderer.render())
    finally:
        xml_renderer.close()
        env.close()


def test_the_fast_style_changes_the_pixels_not_the_scene():
    fetch, fast = (make_task_env("push", image_size=64, render_style=style) for style in ("fetch", "fast"))
    try:
        fetch_frames, fast_frames = camera_frames(fetch), camera_frames(fast)
    finally:
        fetch.close()
        fast.close()
    assert not np.array_equal(fetch_frames, fast_frames)
    # Only edges change (no antialiasing): the mean difference is a few grey levels.
    assert np.abs(fetch_frames.astype(int) - fast_frames).mean() < 8


def test_the_style_survives_pickling_for_async_vector_envs():
    env = make_task_env("push", render_style="fetch")
    clone = pickle.loads(pickle.dumps(env))
    try:
        assert clone.render_style == "fetch"
        assert np.array_equal(camera_frames(clone, steps=1), camera_frames(env, steps=1))
    finally:
        clone.close()
        env.close()


def test_an_unknown_style_is_refused_naming_the_styles():
    styles = r"\('fetch', 'fast', 'flat', 'lean', 'framed'\)"
    with pytest.raises(ValueError, match=rf"Unknown render_style 'pretty'; choose one of {styles}"):
        make_task_env("push", render_style="pretty")
    with pytest.raises(ValueError, match=r"env.render_style 'pretty'"):
        IvmcEnv(task="push", render_style="pretty")
    assert set(RENDER_STYLES) == {"fetch", "fast", "flat", "lean", "framed"}


def test_the_framed_style_is_refused_by_the_fetch_tasks_naming_the_others():
    """Framing is MetaWorld's (the Fetch camera is framed on its table): a Fetch env never ignores it."""
    others = r"\('fetch', 'fast', 'flat', 'lean'\)"
    with pytest.raises(ValueError, match=rf"env.render_style 'framed' frames .*choose one of {others}"):
        IvmcEnv(task="push", render_style="framed")
    with pytest.raises(ValueError, match=r"render_style 'framed'"):
        make_task_env("push", render_style="framed")
