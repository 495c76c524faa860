"""`SeededMetaworldEnv`: LeRobot's `MetaworldEnv` with seeded scenes, a small styled camera and the state.

A subclass, so MetaWorld's task set-up (MT1, the corner2 camera LeRobot moves, the task instruction, the
scripted policy of each task) stays LeRobot's. What it changes, each where LeRobot 0.4.4's env falls short
for this plugin (docs/metaworld.md):
- `reset(seed)` fixes the scene: MetaWorld's own draw seeded from (split, seed) (`scenes.scene_key`).
- the camera image is drawn at `image_size` into a buffer of that size in a render style, instead of
  480 x 480 frames with MSAA, shadows and reflections; `render()` draws video frames at `render_size`.
  The `framed` style also frames the camera on the task's workspace (`framing.py`).
- the observation adds `environment_state`, MetaWorld's 39-D state (hand, gripper, objects, goal).
- a step past success does not reset the env itself (LeRobot's vector env autoresets), and `info` carries
  the milestones the plugin's evaluation reads.
"""

from __future__ import annotations

import os
from typing import Any, ClassVar

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering, as the Fetch envs

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

from lerobot_ivmc.envs.metaworld import (  # noqa: E402
    MAX_EPISODE_STEPS,
    METAWORLD_FPS,
    check_metaworld_task,
    require_metaworld,
)
from lerobot_ivmc.envs.metaworld.env_state import (  # noqa: E402
    AGENT_POS_DIM,
    HAND_POSITION,
    OBJECT_POSITION,
    STATE_DIM,
)
from lerobot_ivmc.envs.metaworld.framing import frame_camera, task_workspace  # noqa: E402
from lerobot_ivmc.envs.metaworld.scenes import scene_key  # noqa: E402
from lerobot_ivmc.envs.offscreen import StyledRenderers  # noqa: E402
from lerobot_ivmc.envs.render_styles import RENDER_STYLES, check_render_style  # noqa: E402

require_metaworld()

from lerobot.envs.metaworld import MetaworldEnv  # noqa: E402

SUBTASKS = ("success",)


class SeededMetaworldEnv(MetaworldEnv):
    """One MetaWorld task with seeded scenes from a split.

    Args:
        task: a MetaWorld v3 task name, e.g. "pick-place-v3".
        split: the scene split the episode seeds draw from ("train", "val", "test").
        image_size: side of the square camera image, in pixels.
        render_size: side of `render()` frames (videos), in pixels.
        render_style: how both are drawn (`render_styles.RENDER_STYLES`).
        terminate_on_success: end an episode as soon as MetaWorld reports success.
        camera_name: the MetaWorld camera (LeRobot's default, "corner2", moved as LeRobot moves it).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": METAWORLD_FPS}
    subtasks = SUBTASKS

    def __init__(
        self,
        task: str,
        split: str = "test",
        image_size: int = 64,
        render_size: int = 256,
        render_style: str = "flat",
        terminate_on_success: bool = True,
        camera_name: str = "corner2",
    ):
        check_metaworld_task(task)
        check_render_style("render_style", render_style)
        super().__init__(
            task=task,
            camera_name=camera_name,
            obs_type="pixels_agent_pos",
            observation_width=image_size,
            observation_height=image_size,
            visualization_width=render_size,
            visualization_height=render_size,
        )
        self.split = split
        self.image_size = int(image_size)
        self.render_size = int(render_size)
        self.render_style = render_style
        self.terminate_on_success = terminate_on_success
        self.observation_space = gym.spaces.Dict(
            {
                "pixels": gym.spaces.Box(0, 255, (self.image_size, self.image_size, 3), np.uint8),
                "agent_pos": gym.spaces.Box(-1000.0, 1000.0, (AGENT_POS_DIM,), np.float64),
                "environment_state": gym.spaces.Box(-np.inf, np.inf, (STATE_DIM,), np.float64),
            }
        )
        scene_key(split, 0)  # refuses an unknown split
        if RENDER_STYLES[render_style].framed:
            frame_camera(self._env.model, self._env.data, camera_name, *task_workspace(self._env))
        self.renderers = StyledRenderers(self._env.model, render_style)
        self._succeeded = False
        self._steps = 0
        self.success_now = False  # MetaWorld's success flag at the last step (`_succeeded`: at any step)
        self.scene_seed: int | None = None

    @property
    def raw_env(self):
        """MetaWorld's own Sawyer env (what its scripted policies and state read)."""
        return self._env

    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None):
        gym.Env.reset(self, seed=seed)
        if seed is None:  # an unseeded episode (e.g. an autoreset): a scene drawn from this env's stream
            seed = int(self.np_random.integers(0, 2**31))
        self.scene_seed = int(seed)
        self._env._freeze_rand_vec = False
        self._env.seeded_rand_vec = True
        self._env.seed(scene_key(self.split, seed))
        raw_obs, _ = self._env.reset()
        self._succeeded, self._steps, self.success_now = False, 0, False
        return self._observation(raw_obs), self._info()

    def step(self, action: np.ndarray):
        action = np.asarray(action, dtype=np.float64)
        if action.shape != (4,) or not np.all(np.isfinite(action)):
            raise ValueError(f"Action must be a finite [dx, dy, dz, grab], shape (4,), got {action!r}.")
        if self._steps >= MAX_EPISODE_STEPS:
            raise ValueError(f"MetaWorld episodes end at {MAX_EPISODE_STEPS} steps; reset the env first.")
        raw_obs, reward, _, _, raw_info = self._env.step(np.clip(action, -1.0, 1.0))
        self._steps += 1
        self.success_now = bool(raw_info.get("success", 0))
        self._succeeded = self._succeeded or self.success_now
        terminated = self._succeeded and self.terminate_on_success
        return self._observation(raw_obs), float(reward), terminated, False, self._info()

    def render(self) -> np.ndarray:
        """An RGB frame of the camera at `render_size` (for videos)."""
        return self._render(self.render_size)

    def close(self) -> None:
        self.renderers.close()
        super().close()

    @property
    def grip_position(self) -> np.ndarray:
        """(3,) the hand's grip point (MetaWorld's tcp centre), metres."""
        return self._last_state[list(HAND_POSITION)].copy()

    @property
    def object_position(self) -> np.ndarray:
        """(3,) the task's first object, metres."""
        return self._last_state[list(OBJECT_POSITION)].copy()

    @property
    def target_position(self) -> np.ndarray:
        """(3,) the task's goal, metres."""
        return np.asarray(self._env._target_pos, dtype=np.float64).copy()

    def is_grasped(self) -> bool | None:
        """Whether both finger pads touch the task's object (MetaWorld's own contact test); None where the
        task names no object geom to test (door-open-v3 has no `objGeom` and no override of its own)."""
        try:
            return bool(self._env.touching_main_object)
        except KeyError:
            return None

    def _observation(self, raw_obs: np.ndarray) -> dict[str, np.ndarray]:
        raw_obs = np.asarray(raw_obs, dtype=np.float64)
        self._last_state = raw_obs.copy()
        return {
            "pixels": self._render(self.image_size),
            "agent_pos": raw_obs[:AGENT_POS_DIM].copy(),
            "environment_state": raw_obs.copy(),
        }

    def _info(self) -> dict[str, Any]:
        # Python bools: a numpy one in `is_success` crashes LeRobot's rollout next to a parked sub-env.
        return {
            "is_success": bool(self._succeeded),
            "subtasks": {"success": bool(self._succeeded)},
            "scene_seed": self.scene_seed,
        }

    def _render(self, size: int) -> np.ndarray:
        frame = self.renderers.frame(self._env.data, self.camera_name, size)
        # LeRobot flips the corner2 camera's frames on both axes (they come out upside down).
        return np.ascontiguousarray(np.flip(frame, (0, 1)) if self.camera_name == "corner2" else frame)
