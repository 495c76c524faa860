"""Seeded MetaWorld scenes and their disjoint train / validation / test splits.

LeRobot's `MetaworldEnv.reset(seed)` leaves the object and goal positions to MetaWorld's unseeded draw.
Here the episode seed s of split k seeds MetaWorld's own draw (`seeded_rand_vec`) with the scene key
k * 2**32 + s: the same seed gives the same scene, and two splits never share a key.
"""

from __future__ import annotations

from lerobot_ivmc.envs.scenes import SPLITS

# Episode seeds of a split: [0, 2**32), so that split k's keys are [k * 2**32, (k + 1) * 2**32).
SEEDS_PER_SPLIT = 2**32


def scene_key(split: str, seed: int) -> int:
    """The integer MetaWorld's generator is seeded with for episode seed `seed` of `split`."""
    if split not in SPLITS:
        raise ValueError(f"Unknown split {split!r}; choose one of {SPLITS}.")
    if not 0 <= int(seed) < SEEDS_PER_SPLIT:
        raise ValueError(f"A MetaWorld episode seed must be in [0, 2**32), got {seed}.")
    return SPLITS.index(split) * SEEDS_PER_SPLIT + int(seed)
