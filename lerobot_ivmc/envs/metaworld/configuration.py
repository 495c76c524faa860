"""LeRobot `EnvConfig` of the MetaWorld suite, registered as ``--env.type=meta_world``.

It subclasses LeRobot's own `metaworld` config. Its type name avoids the substring "metaworld": LeRobot
0.4.4's `make_env` sends every such type to its `create_metaworld_envs`, which builds LeRobot's unseeded env
and drops this config's settings; under another name `make_env` builds `SeededMetaworldEnv` by gym id.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot.configs.types import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig, MetaworldEnv
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_IMAGE, OBS_STATE

from lerobot_ivmc.envs.camera import check_image_size
from lerobot_ivmc.envs.metaworld import (
    GYM_ID,
    MAX_EPISODE_STEPS,
    METAWORLD_FPS,
    ROLLOUT_EPISODE_STEPS,
    check_metaworld_task,
)
from lerobot_ivmc.envs.metaworld.env_state import AGENT_POS_DIM, STATE_DIM
from lerobot_ivmc.envs.render_styles import check_render_style
from lerobot_ivmc.envs.scenes import SPLITS

DEFAULT_METAWORLD_RENDER_STYLE = "flat"


@EnvConfig.register_subclass("meta_world")
@dataclass
class SeededMetaworldEnvConfig(MetaworldEnv):
    """A MetaWorld task with seeded scenes for `make_env`, `lerobot-eval` and the plugin's commands.

    Args:
        task: a MetaWorld v3 task name, e.g. "pick-place-v3".
        fps: MetaWorld's control rate (80 Hz, as `lerobot/metaworld_mt50`).
        episode_length: steps before truncation (MetaWorld allows at most 500).
        image_size: side of the square camera image, in pixels (`lerobot/metaworld_mt50`: 480).
        render_size: side of the frames rendered into eval videos, in pixels.
        render_style: how frames are drawn (`render_styles.RENDER_STYLES`); a policy runs in the style its
            training data was collected in, which its checkpoint records.
        split: scene seeds to draw from; evaluation uses the held-out "test" scenes.
        terminate_on_success: end an episode as soon as MetaWorld reports success.
    """

    task: str = "pick-place-v3"
    fps: int = METAWORLD_FPS
    episode_length: int = ROLLOUT_EPISODE_STEPS
    image_size: int = 64
    render_size: int = 256
    render_style: str = DEFAULT_METAWORLD_RENDER_STYLE
    split: str = "test"
    terminate_on_success: bool = True
    features: dict[str, PolicyFeature] = field(
        default_factory=lambda: {
            ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(4,)),
            "agent_pos": PolicyFeature(type=FeatureType.STATE, shape=(AGENT_POS_DIM,)),
            "environment_state": PolicyFeature(type=FeatureType.ENV, shape=(STATE_DIM,)),
        }
    )
    features_map: dict[str, str] = field(
        default_factory=lambda: {
            ACTION: ACTION,
            "agent_pos": OBS_STATE,
            "environment_state": OBS_ENV_STATE,
            "pixels": OBS_IMAGE,
        }
    )

    def __post_init__(self):
        check_metaworld_task(self.task)
        if self.obs_type != "pixels_agent_pos":
            raise ValueError(f"--env.obs_type must be 'pixels_agent_pos' here, got {self.obs_type!r}.")
        if not 0 < self.episode_length <= MAX_EPISODE_STEPS:
            raise ValueError(
                f"--env.episode_length must be in [1, {MAX_EPISODE_STEPS}] (MetaWorld's own limit), "
                f"got {self.episode_length}."
            )
        if self.fps <= 0:
            raise ValueError(f"--env.fps must be positive, got {self.fps}.")
        for name in ("image_size", "render_size"):
            check_image_size(f"env.{name}", getattr(self, name))
        check_render_style("env.render_style", self.render_style)
        if self.split not in (*SPLITS,):
            raise ValueError(f"Unknown split {self.split!r}; choose one of {SPLITS}.")
        self.features["pixels"] = PolicyFeature(
            type=FeatureType.VISUAL, shape=(self.image_size, self.image_size, 3)
        )

    @property
    def package_name(self) -> str:
        return "lerobot_ivmc.envs.metaworld"

    @property
    def gym_id(self) -> str:
        return GYM_ID

    @property
    def gym_kwargs(self) -> dict:
        return {
            "task": self.task,
            "split": self.split,
            "image_size": self.image_size,
            "render_size": self.render_size,
            "render_style": self.render_style,
            "terminate_on_success": self.terminate_on_success,
            "max_episode_steps": self.episode_length,
        }
