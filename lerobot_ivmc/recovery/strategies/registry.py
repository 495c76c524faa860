"""The recovery strategies by name (`--recovery.mode`): each module registers its class with
`register_strategy`, and `make_strategy` builds the one a config names."""

from __future__ import annotations

from collections.abc import Callable

from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.strategies.base import RecoveryStrategy

STRATEGIES: dict[str, type[RecoveryStrategy]] = {}


def register_strategy(name: str) -> Callable[[type[RecoveryStrategy]], type[RecoveryStrategy]]:
    """Class decorator: make `cls` the strategy of `--recovery.mode=<name>`."""

    def register(cls: type[RecoveryStrategy]) -> type[RecoveryStrategy]:
        if name in STRATEGIES:
            raise ValueError(f"Recovery strategy {name!r} is registered twice.")
        cls.name = name
        STRATEGIES[name] = cls
        return cls

    return register


def make_strategy(settings: RecoveryConfig) -> RecoveryStrategy:
    """The strategy of `settings.mode`, with its settings."""
    if settings.mode not in STRATEGIES:
        raise ValueError(f"Unknown recovery mode {settings.mode!r}; choose one of {tuple(STRATEGIES)}.")
    return STRATEGIES[settings.mode](settings)
