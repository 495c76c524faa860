"""Command-line parsing time of the project's draccus configs, without and with the cached class sources.

draccus builds help texts from each field's source comment, reading the dataclass's source once per field;
`lerobot_ivmc.draccus_startup` caches the source per class. Both are timed in this one process (the plain
lookup first, since the cache cannot be undone), building the argument parser of each config as the
commands do at start. Every `lerobot-train` / `lerobot-ivmc-*` start pays this.

Usage:
    python benchmarks/bench_cli_startup.py
"""

from __future__ import annotations

import inspect
import time

from draccus.argparsing import ArgumentParser
from draccus.wrappers import docstring
from lerobot.configs.train import TrainPipelineConfig

import lerobot_ivmc  # noqa: F401  (registers the plugin's choices; installs the cache)
from lerobot_ivmc.draccus_startup import CachedSourceInspect, cache_draccus_class_sources
from lerobot_ivmc.evaluation.eval_subtasks import IvmcEvalConfig
from lerobot_ivmc.pipeline.config import PipelineConfig

CONFIGS = {
    "lerobot-train": TrainPipelineConfig,
    "lerobot-ivmc-eval": IvmcEvalConfig,
    "lerobot-ivmc-pipeline": PipelineConfig,
}


def build_parsers() -> dict[str, float]:
    """Seconds to build each config's parser (docstrings read on the way), each from an empty cache as at
    a command's start."""
    times = {}
    for name, config_class in CONFIGS.items():
        if isinstance(docstring.inspect, CachedSourceInspect):
            docstring.inspect.getsource.cache_clear()
        start = time.perf_counter()
        ArgumentParser(config_class=config_class)
        times[name] = time.perf_counter() - start
    return times


def main() -> None:
    docstring.inspect = inspect  # undo the import's cache: time the plain lookup first
    plain = build_parsers()
    cache_draccus_class_sources()
    assert isinstance(docstring.inspect, CachedSourceInspect)
    cached = build_parsers()
    print(f"{'command config':<24} {'plain [s]':>10} {'cached [s]':>11} {'speed-up':>9}")
    for name in CONFIGS:
        print(f"{name:<24} {plain[name]:>10.2f} {cached[name]:>11.2f} {plain[name] / cached[name]:>8.1f}x")
    total_plain, total_cached = sum(plain.values()), sum(cached.values())
    print(f"{'all':<24} {total_plain:>10.2f} {total_cached:>11.2f} {total_plain / total_cached:>8.1f}x")


if __name__ == "__main__":
    main()
