"""Success rates with standard errors, the form of the paper's Table I."""

from __future__ import annotations

import math
from collections.abc import Sequence


def rate_with_stderr(flags: Sequence[bool]) -> dict[str, float]:
    """Percentage of True flags and its binomial standard error, both in percent."""
    if not flags:
        raise ValueError("No episodes to aggregate.")
    p = sum(bool(f) for f in flags) / len(flags)
    return {"pc": 100.0 * p, "stderr": 100.0 * math.sqrt(p * (1.0 - p) / len(flags)), "n": len(flags)}


def aggregate_milestones(episodes: Sequence[dict[str, bool]]) -> dict[str, dict[str, float]]:
    """Per-milestone success over episodes: {name: {"pc", "stderr", "n"}}."""
    names = list(episodes[0])
    return {name: rate_with_stderr([episode[name] for episode in episodes]) for name in names}
