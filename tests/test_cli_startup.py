"""Command-line start: draccus reads each config class's source once, and the help texts stay the same."""

from __future__ import annotations

import inspect

from draccus.argparsing import ArgumentParser
from draccus.wrappers import docstring

import lerobot_ivmc  # noqa: F401  (installs the cache, as every command that imports the plugin)
from lerobot_ivmc.draccus_startup import CachedSourceInspect, cache_draccus_class_sources
from lerobot_ivmc.evaluation.eval_subtasks import IvmcEvalConfig


def test_each_config_class_source_is_read_once_and_the_help_is_unchanged() -> None:
    assert isinstance(docstring.inspect, CachedSourceInspect), "importing the plugin installs the cache"
    assert docstring.inspect.getmro is inspect.getmro  # the rest of `inspect` is the real module's
    getsource = docstring.inspect.getsource
    getsource.cache_clear()
    cached_help = ArgumentParser(config_class=IvmcEvalConfig).parser.format_help()
    reads = getsource.cache_info()
    # One read per class; the other fields of each class reuse it (LeRobot's eval config: ~1,300 fields).
    assert reads.misses > 10 and reads.hits > 5 * reads.misses

    docstring.inspect = inspect  # the plain lookup, as draccus does it
    try:
        plain_help = ArgumentParser(config_class=IvmcEvalConfig).parser.format_help()
    finally:
        cache_draccus_class_sources()
    assert cached_help == plain_help
    assert "specifies the number of environments" in cached_help  # a field comment of LeRobot's EvalConfig
    cached = docstring.inspect.getsource
    cache_draccus_class_sources()  # idempotent: the same cache stays
    assert docstring.inspect.getsource is cached
