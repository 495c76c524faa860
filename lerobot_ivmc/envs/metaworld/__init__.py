"""MetaWorld's Sawyer tasks as the plugin's second suite, through LeRobot's own `MetaworldEnv`.

Importing this package is light: the task names come from LeRobot's `metaworld_config.json` (no MetaWorld
import), and the env class (`env.py`, a subclass of LeRobot's `MetaworldEnv`) loads MetaWorld only when an
env is first built. Without MetaWorld installed, building one says which extra to install.
"""

from __future__ import annotations

import functools
import json
from importlib import resources

import gymnasium as gym

# The gym id of every MetaWorld task here (the task is a kwarg).
GYM_ID = "lerobot_ivmc/MetaWorld-v0"
# MetaWorld's Sawyer runs its mocap arm at 80 Hz (5 substeps of 2.5 ms), as `lerobot/metaworld_mt50`.
METAWORLD_FPS = 80
# MetaWorld's own step limit (`SawyerXYZEnv.max_path_length`): its `step` refuses to go past it.
MAX_EPISODE_STEPS = 500
# Steps of every scripted demo (the experts succeed in a median 52 to 124 steps; docs/metaworld.md) and of
# a rollout (twice that, as the Fetch suite's 100-step demos and 200-step rollouts).
DEMO_EPISODE_STEPS = 150
ROLLOUT_EPISODE_STEPS = 300
# The scripted policies that shift the object position they parse from the state in place (door-open's
# handle x by -5 cm): given the observation itself, they edit what a demo records.
STATE_EDITING_POLICIES = frozenset({"SawyerDoorCloseV3Policy", "SawyerDoorOpenV3Policy"})
INSTALL_HINT = (
    "pip install 'lerobot_policy_ivmc[metaworld]' (metaworld==3.0.0, the version LeRobot 0.4.4 pins)"
)


@functools.cache
def _lerobot_metaworld_config() -> dict:
    """LeRobot's `metaworld_config.json`: task descriptions and each task's scripted policy class."""
    return json.loads(resources.files("lerobot.envs").joinpath("metaworld_config.json").read_text())


def is_metaworld_task(task: str | None) -> bool:
    """Whether `task` is a MetaWorld task name (the Fetch suite's names never are)."""
    return task in _lerobot_metaworld_config()["TASK_DESCRIPTIONS"]


def check_metaworld_task(task: str | None) -> str:
    """Return `task` if MetaWorld has it, else raise a ValueError with examples."""
    if not is_metaworld_task(task):
        examples = ", ".join(("pick-place-v3", "push-v3", "drawer-open-v3", "peg-insert-side-v3"))
        raise ValueError(
            f"Unknown MetaWorld task {task!r}; use a v3 name of LeRobot's metaworld_config.json, e.g. "
            f"{examples}."
        )
    return task


def scripted_policy_name(task: str) -> str:
    """The `metaworld.policies` class of a task's scripted expert; a ValueError if it has none."""
    name = _lerobot_metaworld_config()["TASK_POLICY_MAPPING"].get(check_metaworld_task(task))
    if name is None:
        raise ValueError(
            f"MetaWorld task {task!r} has no scripted policy in metaworld.policies to collect with."
        )
    return name


def expert_edits_state(task: str) -> bool:
    """Whether the task's scripted policy edits the state it is given (`STATE_EDITING_POLICIES`)."""
    return scripted_policy_name(task) in STATE_EDITING_POLICIES


def task_description(task: str) -> str:
    """The task's instruction, as LeRobot's `MetaworldEnv` and `lerobot/metaworld_mt50` give it."""
    return _lerobot_metaworld_config()["TASK_DESCRIPTIONS"][check_metaworld_task(task)]


def require_metaworld() -> None:
    """Raise an ImportError naming the extra to install when MetaWorld is missing."""
    try:
        import metaworld  # noqa: F401
    except ImportError:
        raise ImportError(f"MetaWorld is not installed: {INSTALL_HINT}.") from None


# Outside the time limit, so LeRobot's `add_envs_task` finds the instruction (`task_wrapper.py`).
if GYM_ID not in gym.registry:
    gym.register(
        id=GYM_ID,
        entry_point="lerobot_ivmc.envs.metaworld.env:SeededMetaworldEnv",
        max_episode_steps=ROLLOUT_EPISODE_STEPS,
        additional_wrappers=(
            gym.envs.registration.WrapperSpec(
                name="TaskDescription",
                entry_point="lerobot_ivmc.envs.task_wrapper:TaskDescription",
                kwargs={},
            ),
        ),
    )
