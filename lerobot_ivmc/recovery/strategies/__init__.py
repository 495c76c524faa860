"""Recovery strategies, one module each, registered by `--recovery.mode` name (`registry.py`)."""

from lerobot_ivmc.recovery.strategies import belief_anchor, paper, reach, retry  # noqa: F401  (they register)
from lerobot_ivmc.recovery.strategies.base import RecoveryStrategy
from lerobot_ivmc.recovery.strategies.registry import STRATEGIES, make_strategy, register_strategy

__all__ = ["STRATEGIES", "RecoveryStrategy", "make_strategy", "register_strategy"]
