"""Scene setups on 6x8 spawn grids and their disjoint train / validation / test splits.

The paper spawns the object and the target on 6x8 grids (Sec. "Experimental Setup") and evaluates on
held-out scene setups. A *scene* here is the pair (object cell, target cell). Every valid pair of a task
is assigned to exactly one split by a fixed, seeded permutation, so a scene seen in training never
appears in validation or test.

A split holds a finite number of setups (push: 84 test scenes), fewer than an evaluation may need (the
paper: 100 test episodes, 800 for Fig. 3). Seeds past a split's n setups revisit them with the object and
the target moved by a seeded continuous offset within their grid cells (`cell_jitter`): the held-out cell
pairs stay held out, and every task follows the same rule. Seeds 0..n-1 place both exactly on the grid.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

SPLITS = ("train", "val", "test")
# Fraction of a task's scenes that go to validation and to test; the rest are for training.
SPLIT_FRACTIONS = {"val": 0.1, "test": 0.1}
# Fixed seed of the scene-to-split permutation: changing it would silently mix the splits of
# datasets recorded before and after, so it is a constant, not a parameter.
_SPLIT_PERMUTATION_SEED = 20_210_530
# Largest offset of a jittered position, as a fraction of the grid spacing on each axis: neighbouring
# cells' jittered positions never meet (0.4 + 0.4 < 1).
JITTER_FRACTION = 0.4
# Stream of the jitter's random generator, kept apart from other uses of the episode seed.
_JITTER_STREAM = 1_729


@dataclass(frozen=True)
class Grid:
    """A rows x cols grid of spawn points on the table, rows along x (away from the robot), cols along y."""

    x_range: tuple[float, float]
    y_range: tuple[float, float]
    rows: int = 6
    cols: int = 8

    @property
    def size(self) -> int:
        return self.rows * self.cols

    def cell(self, index: int) -> tuple[int, int]:
        """Row and column of a flat cell index."""
        if not 0 <= index < self.size:
            raise ValueError(f"Cell index {index} is outside the {self.rows}x{self.cols} grid.")
        return divmod(index, self.cols)

    def position(self, index: int) -> np.ndarray:
        """(x, y) world position of a flat cell index."""
        row, col = self.cell(index)
        xs = np.linspace(*self.x_range, self.rows)
        ys = np.linspace(*self.y_range, self.cols)
        return np.array([xs[row], ys[col]])

    @property
    def spacing(self) -> np.ndarray:
        """(dx, dy) distance between neighbouring cells (0 along an axis with a single cell)."""
        return np.array(
            [
                (self.x_range[1] - self.x_range[0]) / max(self.rows - 1, 1),
                (self.y_range[1] - self.y_range[0]) / max(self.cols - 1, 1),
            ]
        )

    def jittered_position(self, index: int, offset: np.ndarray) -> np.ndarray:
        """The cell's position moved by `offset` (in units of the spacing, each in [-1, 1] times
        JITTER_FRACTION), kept inside the grid's bounds."""
        low, high = np.array([self.x_range[0], self.y_range[0]]), np.array([self.x_range[1], self.y_range[1]])
        return np.clip(self.position(index) + offset * self.spacing, low, high)


@dataclass(frozen=True)
class Scene:
    """One scene setup: the object's cell on the object grid and the target's cell on the target grid."""

    object_cell: int
    target_cell: int


def split_scenes(scenes: list[Scene]) -> dict[str, list[Scene]]:
    """Deterministically partition scenes into disjoint train / val / test lists."""
    order = np.random.default_rng(_SPLIT_PERMUTATION_SEED).permutation(len(scenes))
    n_val = round(SPLIT_FRACTIONS["val"] * len(scenes))
    n_test = round(SPLIT_FRACTIONS["test"] * len(scenes))
    test = sorted((scenes[i] for i in order[:n_test]), key=_scene_key)
    val = sorted((scenes[i] for i in order[n_test : n_test + n_val]), key=_scene_key)
    train = sorted((scenes[i] for i in order[n_test + n_val :]), key=_scene_key)
    return {"train": train, "val": val, "test": test}


def _scene_key(scene: Scene) -> tuple[int, int]:
    return scene.object_cell, scene.target_cell


@cache
def _cached_splits(scenes: tuple[Scene, ...]) -> dict[str, tuple[Scene, ...]]:
    return {name: tuple(items) for name, items in split_scenes(list(scenes)).items()}


def scenes_of_split(all_scenes: tuple[Scene, ...], split: str) -> tuple[Scene, ...]:
    """The scenes of one split ("train", "val", "test") or of all of them ("all")."""
    if split == "all":
        return all_scenes
    if split not in SPLITS:
        raise ValueError(f"Unknown scene split {split!r}; choose one of {SPLITS + ('all',)}.")
    return _cached_splits(all_scenes)[split]


def cell_jitter(seed: int, num_scenes: int) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (in grid spacings) of the object and the target for episode seed `seed` of a split of
    `num_scenes` setups: zero for seeds below `num_scenes` (exact grid positions), else uniform in
    [-JITTER_FRACTION, JITTER_FRACTION] per axis, drawn from the seed alone."""
    if seed < num_scenes:
        return np.zeros(2), np.zeros(2)
    rng = np.random.default_rng([_JITTER_STREAM, seed])
    offsets = rng.uniform(-JITTER_FRACTION, JITTER_FRACTION, size=(2, 2))
    return offsets[0], offsets[1]
