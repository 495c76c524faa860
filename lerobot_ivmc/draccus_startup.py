"""Faster start of every draccus command line (`lerobot-train`, `lerobot-ivmc-*`): cache class sources.

To build help texts, draccus reads each config field's comment from the source of its dataclass with
`inspect.getsource(cls)`, once per field; on Python 3.11 every call re-parses the class's whole module.
LeRobot's configs have about 1,300 fields across their choice classes, so parsing the command line took
13 of an eval's 42 s (cProfile of `lerobot-ivmc-eval`). Caching the source of each class makes it once per
class; the help texts are the same.
"""

from __future__ import annotations

import functools
import inspect
import types


def cache_draccus_class_sources() -> None:
    """Make draccus's docstring lookup read each dataclass's source once per process (idempotent)."""
    try:
        from draccus.wrappers import docstring
    except ImportError:  # another draccus layout: leave it as it is
        return
    if isinstance(docstring.inspect, types.SimpleNamespace):
        return
    docstring.inspect = types.SimpleNamespace(
        getsource=functools.cache(inspect.getsource), getmro=inspect.getmro
    )
