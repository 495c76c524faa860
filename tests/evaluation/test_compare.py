"""Paired comparison of two evaluations on the same scenes."""

from __future__ import annotations

import pytest

from lerobot_ivmc.evaluation.compare import paired_outcomes


def episodes(flags: list[bool], seeds: list[int] | None = None) -> list[dict]:
    seeds = seeds or list(range(len(flags)))
    return [{"seed": s, "subtasks": {"reach": True, "place": f}} for s, f in zip(seeds, flags, strict=True)]


def test_counts_and_exact_mcnemar() -> None:
    a = episodes([True, True, False, False, False, False, False, False])
    b = episodes([True, False, True, True, True, True, True, False])
    result = paired_outcomes(a, b, "place")
    assert (result["both"], result["only_first"], result["only_second"], result["neither"]) == (1, 1, 5, 1)
    # 6 discordant pairs, 5 for b: two-sided binomial p = 2 * P(X >= 5 | n=6, 1/2) = 2 * 7/64
    assert result["mcnemar_exact_p"] == pytest.approx(14 / 64)


def test_runs_on_other_scenes_are_refused() -> None:
    with pytest.raises(ValueError, match="same --seed"):
        paired_outcomes(episodes([True]), episodes([True], seeds=[5]), "place")
