"""The camera an ivmc env observes with: its name, the observation types and the image sizes it renders.

Kept apart from the env (and from MuJoCo) so that configs and dataset features can use them without
loading the simulator.
"""

from __future__ import annotations

from typing import Any

import numpy as np

CAMERA_NAME = "front"
OBS_TYPES = ("pixels_agent_pos", "state")
# Largest camera image and render() frame side, in pixels, which every OpenGL implementation's renderbuffers
# allow (each frame size is drawn into a framebuffer of its own size: `IvmcFetchEnv._make_renderer`).
MAX_IMAGE_SIZE = 2048


def check_image_size(name: str, size: Any) -> None:
    """Refuse an image side MuJoCo cannot render here, naming the allowed range."""
    if not isinstance(size, int | np.integer) or isinstance(size, bool) or not 0 < size <= MAX_IMAGE_SIZE:
        raise ValueError(
            f"{name} must be a positive integer number of pixels, at most {MAX_IMAGE_SIZE}, got {size!r}."
        )
