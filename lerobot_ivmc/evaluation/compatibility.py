"""Does a checkpoint fit the env it is about to run in?

A checkpoint's `config.json` records the features it was trained on (`input_features`,
`output_features`). `check_policy_matches_env` compares them with the features the env config produces,
as LeRobot derives them (`env_to_policy_features`), and the render style of its training frames with the
env's, before the first step: a 64-pixel policy on
`--env.image_size=32` would otherwise fail with a tensor-size error deep inside the CNN, and a pixel policy
on `--env.obs_type=state` with a `KeyError`. The error is a `ValueError`, so the plugin's CLIs end on it
with one line (`lerobot_ivmc.cli.run_cli`).
"""

from __future__ import annotations

from lerobot.configs.policies import PreTrainedConfig
from lerobot.configs.types import FeatureType
from lerobot.envs.configs import EnvConfig
from lerobot.envs.utils import env_to_policy_features

from lerobot_ivmc.policies.legacy_configs import complete_legacy_config
from lerobot_ivmc.policies.vmc.configuration_vmc import VMCConfig

_PIXEL_OBS_TYPE = "pixels_agent_pos"


class EnvMismatchError(ValueError):
    """The env does not give what the policy was trained on; the message says which flag fixes it."""


def _fix(env_cfg: EnvConfig, key: str, want: tuple[int, ...], visual: bool, provided: bool) -> str:
    """The `--env.*` flag that makes `env_cfg` give feature `key` of shape `want`, if there is one."""
    if not visual:
        return ""
    if not provided and getattr(env_cfg, "obs_type", _PIXEL_OBS_TYPE) != _PIXEL_OBS_TYPE:
        flags = [f"--env.obs_type={_PIXEL_OBS_TYPE}"]
        if hasattr(env_cfg, "image_size") and len(want) == 3 and want[1] == want[2] != env_cfg.image_size:
            flags.append(f"--env.image_size={want[1]}")
        return f"; pass {' '.join(flags)}"
    if provided and hasattr(env_cfg, "image_size") and len(want) == 3 and want[1] == want[2]:
        return f"; pass --env.image_size={want[1]}"
    return ""


def check_policy_matches_env(policy_cfg: PreTrainedConfig, env_cfg: EnvConfig) -> None:
    """Refuse an env that does not give the observations (or take the actions) the policy was trained on.

    A checkpoint's config that lacks fields added since it was saved is completed first with the values it
    was made with (`complete_legacy_config`).

    Args:
        policy_cfg: the checkpoint's config (`--policy.path`), with the features it was trained on.
        env_cfg: the env it is about to run in.

    Raises:
        EnvMismatchError (a ValueError): naming each feature the policy expects and the env does not give
            as expected, with the flag that fixes it where there is one (e.g. `--env.image_size=64`,
            `--env.obs_type=pixels_agent_pos`).
    """
    if isinstance(policy_cfg, VMCConfig) and policy_cfg.pretrained_path is not None:
        # A checkpoint saved before a field existed is checked as it was made (e.g. its render style).
        complete_legacy_config(policy_cfg, policy_cfg.pretrained_path)
    given = env_to_policy_features(env_cfg)
    problems = []
    for key, feature in (policy_cfg.input_features or {}).items():
        want, visual = tuple(feature.shape), feature.type is FeatureType.VISUAL
        if key not in given:
            obs_type = getattr(env_cfg, "obs_type", None)
            problems.append(
                f"the policy reads {key} of shape {want}, which this env does not give"
                + (f" with obs_type={obs_type!r}" if obs_type is not None else "")
                + _fix(env_cfg, key, want, visual, provided=False)
            )
        elif tuple(given[key].shape) != want:
            problems.append(
                f"the policy expects {key} of shape {want}, this env gives {tuple(given[key].shape)}"
                + _fix(env_cfg, key, want, visual, provided=True)
            )
    for key, feature in (policy_cfg.output_features or {}).items():
        if key in given and tuple(given[key].shape) != tuple(feature.shape):
            problems.append(
                f"the policy outputs {key} of shape {tuple(feature.shape)}, "
                f"the env takes {tuple(given[key].shape)}"
            )
    trained_style, env_style = (
        getattr(policy_cfg, "render_style", None),
        getattr(env_cfg, "render_style", None),
    )
    if None not in (trained_style, env_style) and trained_style != env_style:
        problems.append(
            f"it was trained on frames drawn in the {trained_style!r} render style, this env draws "
            f"{env_style!r}; pass --env.render_style={trained_style}"
        )
    trained_task, env_task = getattr(policy_cfg, "trained_task", None), getattr(env_cfg, "task", None)
    if None not in (trained_task, env_task) and trained_task != env_task:
        problems.append(
            f"it was trained on {trained_task!r} demos, this env is {env_task!r}; "
            f"pass --env.task={trained_task}"
        )
    if problems:
        env_name = getattr(env_cfg, "type", type(env_cfg).__name__)
        raise EnvMismatchError(
            f"This {policy_cfg.type} checkpoint does not fit the {env_name} env: {'; '.join(problems)}."
        )
