"""The paper's Table I (rates in %, mean and standard error over 100 test setups), for side-by-side tables."""

from __future__ import annotations

# PAPER_TABLE[task][num_fc_layers][method] = {subtask: (rate, stderr)}; method "vmc" is the VMC row.
PAPER_TABLE: dict[str, dict[int, dict[str, dict[str, tuple[float, float]]]]] = {
    "push": {
        1: {
            "vmc": {"reach": (97.0, 1.62), "push": (49.0, 4.74)},
            "none": {"reach": (91.0, 2.71), "push": (50.0, 4.75)},
            "rand": {"reach": (93.0, 2.42), "push": (56.0, 4.71)},
            "init": {"reach": (93.0, 2.42), "push": (55.0, 4.72)},
            "min_unc": {"reach": (94.0, 2.25), "push": (58.0, 4.68)},
        },
        2: {
            "vmc": {"reach": (96.0, 1.86), "push": (50.0, 4.75)},
            "none": {"reach": (88.0, 3.08), "push": (53.0, 4.74)},
            "rand": {"reach": (88.0, 3.08), "push": (60.0, 4.65)},
            "init": {"reach": (93.0, 2.42), "push": (58.0, 4.68)},
            "min_unc": {"reach": (91.0, 2.71), "push": (62.0, 4.61)},
        },
    },
    "pick_place": {
        1: {
            "vmc": {"reach": (99.0, 0.94), "pick": (77.0, 3.99), "place": (52.0, 4.74)},
            "none": {"reach": (99.0, 0.94), "pick": (84.0, 3.48), "place": (60.0, 4.65)},
            "rand": {"reach": (99.0, 0.94), "pick": (85.0, 3.39), "place": (68.0, 4.43)},
            "init": {"reach": (99.0, 0.94), "pick": (88.0, 3.08), "place": (67.0, 4.46)},
            "min_unc": {"reach": (99.0, 0.94), "pick": (90.0, 2.85), "place": (70.0, 4.35)},
        },
        2: {
            "vmc": {"reach": (97.0, 1.62), "pick": (79.0, 3.86), "place": (60.0, 4.65)},
            "none": {"reach": (100.0, 0.0), "pick": (87.0, 3.19), "place": (69.0, 4.39)},
            "rand": {"reach": (100.0, 0.0), "pick": (91.0, 2.71), "place": (74.0, 4.16)},
            "init": {"reach": (100.0, 0.0), "pick": (89.0, 2.97), "place": (76.0, 4.05)},
            "min_unc": {"reach": (100.0, 0.0), "pick": (89.0, 2.97), "place": (82.0, 3.64)},
        },
    },
    "pick_reach": {
        1: {
            "vmc": {"reach": (99.0, 0.94), "pick": (77.0, 3.99), "task": (69.0, 4.39)},
            "none": {"reach": (99.0, 0.94), "pick": (88.0, 3.08), "task": (78.0, 3.93)},
            "rand": {"reach": (99.0, 0.94), "pick": (89.0, 2.97), "task": (81.0, 3.72)},
            "init": {"reach": (99.0, 0.94), "pick": (93.0, 2.42), "task": (79.0, 3.86)},
            "min_unc": {"reach": (99.0, 0.94), "pick": (93.0, 2.42), "task": (82.0, 3.64)},
        },
        2: {
            "vmc": {"reach": (99.0, 0.94), "pick": (79.0, 3.86), "task": (70.0, 3.64)},
            "none": {"reach": (99.0, 0.94), "pick": (89.0, 2.97), "task": (79.0, 3.86)},
            "rand": {"reach": (99.0, 0.94), "pick": (91.0, 2.71), "task": (82.0, 3.64)},
            "init": {"reach": (99.0, 0.94), "pick": (93.0, 2.42), "task": (83.0, 3.56)},
            "min_unc": {"reach": (99.0, 0.94), "pick": (94.0, 2.25), "task": (85.0, 3.39)},
        },
    },
}
