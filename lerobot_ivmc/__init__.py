"""lerobot-ivmc: Introspective Visuomotor Control (Hung et al.) as a LeRobot plugin.

Importing the package registers its LeRobot extensions: the ``ivmc`` env config and the gym envs.
"""

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv

__all__ = ["IvmcEnv"]
__version__ = "0.1.0"
