"""Offscreen MuJoCo renderers drawn in a named render style, shared by the Fetch and MetaWorld envs."""

from __future__ import annotations

import os

import mujoco
import numpy as np

from lerobot_ivmc.envs.coarse_meshes import coarse_meshes
from lerobot_ivmc.envs.render_styles import RENDER_STYLES


def make_styled_renderer(model: mujoco.MjModel, size: int, render_style: str) -> mujoco.Renderer:
    """A renderer of `size` x `size` frames whose offscreen framebuffer is that size, in `render_style`.

    MuJoCo's rendering context takes its framebuffer's size and multisampling from the model's visual
    settings when it is created; they do not affect the physics. A frame-sized buffer draws the same pixels
    as a larger one, without clearing and resolving the rest of it.
    """
    style = RENDER_STYLES[render_style]
    model.vis.global_.offwidth = model.vis.global_.offheight = size
    model.vis.quality.offsamples = style.multisamples
    try:
        with coarse_meshes(model, style.mesh_cell):
            renderer = mujoco.Renderer(model, size, size)
    except mujoco.FatalError as error:
        raise RuntimeError(
            "MuJoCo could not create an offscreen renderer "
            f"(MUJOCO_GL={os.environ.get('MUJOCO_GL')!r}). "
            "Set MUJOCO_GL=egl (or osmesa) in the environment before anything imports mujoco; "
            "lerobot_ivmc sets it only if mujoco was not imported first."
        ) from error
    # The scene's render flags persist across `update_scene` calls: set once.
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = style.shadows
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = style.reflections
    return renderer


class StyledRenderers:
    """One renderer per frame size of a model, made on first use, all in one render style."""

    def __init__(self, model: mujoco.MjModel, render_style: str):
        self.model = model
        self.render_style = render_style
        self._renderers: dict[int, mujoco.Renderer] = {}

    def frame(self, data: mujoco.MjData, camera: str, size: int) -> np.ndarray:
        """A (size, size, 3) uint8 frame of `camera` (a copy)."""
        if size not in self._renderers:
            self._renderers[size] = make_styled_renderer(self.model, size, self.render_style)
        renderer = self._renderers[size]
        renderer.update_scene(data, camera=camera)
        return renderer.render().copy()

    def close(self) -> None:
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers.clear()
