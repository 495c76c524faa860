"""The envs the plugin's evaluation commands run on (`--env.type=ivmc`, the Fetch tasks, and
`--env.type=meta_world`), and what each tells recovery: its robot and its task's settings."""

from __future__ import annotations

from lerobot.envs.configs import EnvConfig

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.envs.embodiment import Embodiment
from lerobot_ivmc.envs.metaworld.configuration import SeededMetaworldEnvConfig
from lerobot_ivmc.envs.task_traits import TaskTraits
from lerobot_ivmc.recovery.config import RECOVERY_MODES, RecoveryConfig

PLUGIN_ENV_CONFIGS = (IvmcEnv, SeededMetaworldEnvConfig)


def check_plugin_env(env_cfg: EnvConfig, command: str) -> None:
    """Refuse an env whose episodes the command cannot seed and record, naming the ones it runs on."""
    if not isinstance(env_cfg, PLUGIN_ENV_CONFIGS):
        raise ValueError(
            f"{command} runs on --env.type=ivmc or --env.type=meta_world (seeded scenes with recorded "
            f"milestones), got {env_cfg.type!r}; evaluate other envs with lerobot-eval."
        )


def embodiment_of(env_cfg: EnvConfig) -> Embodiment:
    """The robot of the env (what recovery moves)."""
    if isinstance(env_cfg, IvmcEnv):
        from lerobot_ivmc.envs.fetch_env import EMBODIMENT

        return EMBODIMENT
    from lerobot_ivmc.envs.metaworld.embodiment import SAWYER

    return SAWYER


def task_traits_of(env_cfg: EnvConfig) -> TaskTraits | None:
    """What recovery may know of the env's task (a Fetch task's object handling and push geometry); None
    for MetaWorld, whose recovery modes know no task."""
    if isinstance(env_cfg, IvmcEnv):
        from lerobot_ivmc.envs import task_env_class

        return task_env_class(env_cfg.task).traits()
    return None


def recovery_settings(recovery: RecoveryConfig, env_cfg: EnvConfig) -> RecoveryConfig:
    """The recovery settings as they act in the env: anchor's task settings resolved for a Fetch task;
    anchor refused elsewhere (it is a planner for the Fetch tasks)."""
    if isinstance(env_cfg, IvmcEnv):
        from lerobot_ivmc.envs import task_env_class

        return recovery.for_task_traits(task_env_class(env_cfg.task).traits())
    if recovery.mode == "anchor":
        raise ValueError(
            f"--recovery.mode=anchor is a planner for the Fetch tasks (--env.type=ivmc); on {env_cfg.type} "
            f"use another of {tuple(m for m in RECOVERY_MODES if m != 'anchor')}."
        )
    return recovery
