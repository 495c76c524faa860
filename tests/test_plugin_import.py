"""Installing the plugin leaves LeRobot's other commands as they were: LeRobot's plugin discovery imports
it into every `lerobot-train` / `lerobot-eval`, so importing it registers its configs and nothing more."""

from __future__ import annotations

import os
import subprocess
import sys

PROBE = """
import os, sys
import lerobot_policy_ivmc
from lerobot.configs.policies import PreTrainedConfig
from lerobot.envs.configs import EnvConfig
print(EnvConfig.get_choice_class("ivmc").__name__, PreTrainedConfig.get_choice_class("bvmc").__name__)
print(sorted(m for m in ("mujoco", "gymnasium_robotics") if m in sys.modules), os.environ.get("MUJOCO_GL"))
from lerobot_ivmc.envs import make_task_env
env = make_task_env("push", obs_type="state")
print(type(env).__name__, os.environ.get("MUJOCO_GL"))
"""


def test_importing_the_plugin_loads_no_simulator_and_sets_no_global_state() -> None:
    environment = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    result = subprocess.run(
        [sys.executable, "-c", PROBE], capture_output=True, text=True, env=environment, timeout=300
    )
    assert result.returncode == 0, result.stderr[-2000:]
    registered, loaded, built = result.stdout.strip().splitlines()
    assert registered == "IvmcEnv BVMCConfig"
    assert loaded == "[] None", "importing the plugin loaded the simulator or set MUJOCO_GL"
    assert built == "PushEnv egl", "building an env loads the simulator with headless rendering"
