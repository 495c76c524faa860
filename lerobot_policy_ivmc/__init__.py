"""Entry point found by LeRobot's plugin discovery (distributions named ``lerobot_policy_*``).

`lerobot.utils.import_utils.register_third_party_plugins()` imports this module by the distribution's
name; importing `lerobot_ivmc` registers the ``ivmc`` env and the plugin's policy types with LeRobot.
"""

import lerobot_ivmc  # noqa: F401
from lerobot_ivmc import *  # noqa: F401,F403
