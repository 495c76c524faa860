"""lerobot-ivmc: Introspective Visuomotor Control (Hung et al.) as a LeRobot plugin.

Importing the package registers its LeRobot extensions: the ``ivmc`` env config (and the gym envs) and
the ``vmc`` / ``bvmc`` policy types.
"""

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.policies import BVMCConfig, VMCConfig

__all__ = ["BVMCConfig", "IvmcEnv", "VMCConfig"]
__version__ = "0.1.0"
