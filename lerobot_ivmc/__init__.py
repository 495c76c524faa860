"""lerobot-ivmc: Introspective Visuomotor Control (Hung et al.) as a LeRobot plugin.

Importing the package registers its LeRobot extensions: the ``ivmc`` env config (and the gym envs) and
the ``meta_world`` env config (MetaWorld with seeded scenes), and the ``vmc`` / ``bvmc`` policy types.
"""

from lerobot_ivmc.draccus_startup import cache_draccus_class_sources

cache_draccus_class_sources()

from lerobot_ivmc.envs.configuration_ivmc import IvmcEnv  # noqa: E402
from lerobot_ivmc.envs.metaworld.configuration import SeededMetaworldEnvConfig  # noqa: E402
from lerobot_ivmc.policies import BVMCConfig, VMCConfig  # noqa: E402

__all__ = ["BVMCConfig", "IvmcEnv", "SeededMetaworldEnvConfig", "VMCConfig"]
__version__ = "0.1.0"
