"""Faster start of every draccus command line (`lerobot-train`, `lerobot-ivmc-*`): cache class sources.

To build help texts, draccus reads each config field's comment from the source of its dataclass with
`inspect.getsource(cls)`, once per field; on Python 3.11 every call re-parses the class's whole module.
LeRobot's configs have about 1,300 fields across their choice classes, so parsing the command line took
15 s of a smoke-sized `lerobot-ivmc-eval`'s 42 s, 13.5 s of it reading sources (cProfile). Caching the
source of each class reads it once per class (the whole command then took 25 s); the help texts are the
same.
"""

from __future__ import annotations

import functools
import inspect
import types


class CachedSourceInspect(types.ModuleType):
    """The `inspect` module with `getsource` cached; every other name is the real module's."""

    def __init__(self) -> None:
        super().__init__("inspect")
        self.getsource = functools.cache(inspect.getsource)

    def __getattr__(self, name: str):
        return getattr(inspect, name)


def cache_draccus_class_sources() -> None:
    """Make draccus's docstring lookup read each dataclass's source once per process (idempotent)."""
    try:
        from draccus.wrappers import docstring
    except ImportError:  # another draccus layout: leave it as it is
        return
    if not isinstance(docstring.inspect, CachedSourceInspect):
        docstring.inspect = CachedSourceInspect()
