"""lerobot-ivmc: Introspective Visuomotor Control (Hung et al.) as a LeRobot plugin.

Importing the package registers its LeRobot extensions: the ``ivmc`` env config and the gym envs.
"""

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv
from lerobot_ivmc.policies import BVMCConfig, VMCConfig  # noqa: F401  (registers the policy types)

__all__ = ["IvmcEnv"]
__version__ = "0.1.0"
