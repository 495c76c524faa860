"""LeRobot `EnvConfig` for the tasks, registered as ``--env.type=ivmc``."""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_IMAGES, OBS_STATE

from lerobot_ivmc.envs import MAX_EPISODE_STEPS, check_task, gym_id
from lerobot_ivmc.envs.camera import CAMERA_NAME, OBS_TYPES, check_image_size
from lerobot_ivmc.envs.render_styles import DEFAULT_RENDER_STYLE, check_render_style
from lerobot_ivmc.envs.scenes import SPLITS

IMAGE_KEY = f"{OBS_IMAGES}.{CAMERA_NAME}"


@EnvConfig.register_subclass("ivmc")
@dataclass
class IvmcEnv(EnvConfig):
    """The paper's Fetch tasks for `make_env`, `lerobot-eval` and `lerobot-train`'s in-training eval.

    Args:
        task: "push", "pick_place" or "pick_reach".
        fps: control frequency; the simulator runs the arm at 25 Hz.
        episode_length: steps before truncation (the paper: 200).
        obs_type: "pixels_agent_pos" (camera + proprioception) or "state" (no camera).
        image_size: side of the square camera image, in pixels.
        render_size: side of the frames rendered into eval videos, in pixels.
        render_style: how frames are drawn ("fast" or "fetch", `fetch_env.RENDER_STYLES`); a policy runs in
            the style its training data was collected in, which its checkpoint records.
        split: scene setups to draw from; evaluation uses the held-out "test" scenes.
        terminate_on_success: end an episode as soon as the task succeeds.
    """

    task: str | None = "pick_place"
    fps: int = 25
    episode_length: int = MAX_EPISODE_STEPS
    obs_type: str = "pixels_agent_pos"
    image_size: int = 64
    render_size: int = 256
    render_style: str = DEFAULT_RENDER_STYLE
    split: str = "test"
    terminate_on_success: bool = True
    features: dict[str, PolicyFeature] = field(
        default_factory=lambda: {
            ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(4,)),
            "agent_pos": PolicyFeature(type=FeatureType.STATE, shape=(9,)),
            "environment_state": PolicyFeature(type=FeatureType.ENV, shape=(6,)),
        }
    )
    features_map: dict[str, str] = field(
        default_factory=lambda: {
            ACTION: ACTION,
            "agent_pos": OBS_STATE,
            "environment_state": OBS_ENV_STATE,
            f"pixels/{CAMERA_NAME}": IMAGE_KEY,
        }
    )

    def __post_init__(self):
        check_task(self.task)
        if self.obs_type not in OBS_TYPES:
            raise ValueError(f"Unknown obs_type {self.obs_type!r}; choose one of {OBS_TYPES}.")
        for name in ("episode_length", "fps"):
            if getattr(self, name) <= 0:
                raise ValueError(f"env.{name} must be positive, got {getattr(self, name)}.")
        for name in ("image_size", "render_size"):
            check_image_size(f"env.{name}", getattr(self, name))
        check_render_style("env.render_style", self.render_style, framing=False)
        if self.split not in (*SPLITS, "all"):
            raise ValueError(f"Unknown split {self.split!r}; choose one of {(*SPLITS, 'all')}.")
        if self.obs_type == "pixels_agent_pos":
            self.features[f"pixels/{CAMERA_NAME}"] = PolicyFeature(
                type=FeatureType.VISUAL, shape=(self.image_size, self.image_size, 3)
            )

    @property
    def package_name(self) -> str:
        return "lerobot_ivmc.envs"

    @property
    def gym_id(self) -> str:
        return gym_id(self.task)

    @property
    def gym_kwargs(self) -> dict:
        return {
            "obs_type": self.obs_type,
            "image_size": self.image_size,
            "render_size": self.render_size,
            "render_style": self.render_style,
            "split": self.split,
            "terminate_on_success": self.terminate_on_success,
            "max_episode_steps": self.episode_length,
        }
