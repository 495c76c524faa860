"""Paired comparison of two evaluations on the same scenes (`lerobot-ivmc-compare`)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from lerobot_ivmc.evaluation.compare import paired_outcomes, pooled_outcomes, rescue_record


def run(flags: list[bool], seeds: list[int] | None = None, task: str = "pick_place", split: str = "test"):
    """An eval record as `lerobot-ivmc-eval` writes it (the parts the comparison reads)."""
    seeds = seeds or list(range(len(flags)))
    episodes = [
        {"seed": s, "subtasks": {"reach": True, "place": f}} for s, f in zip(seeds, flags, strict=True)
    ]
    return {"run": {"task": task, "split": split, "seed": seeds[0]}, "per_episode": episodes}


def test_counts_and_exact_mcnemar() -> None:
    a = run([True, True, False, False, False, False, False, False])
    b = run([True, False, True, True, True, True, True, False])
    result = paired_outcomes(a, b, "place")
    assert (result["both"], result["only_first"], result["only_second"], result["neither"]) == (1, 1, 5, 1)
    # 6 discordant pairs, 5 for b: two-sided binomial p = 2 * P(X >= 5 | n=6, 1/2) = 2 * 7/64
    assert result["mcnemar_exact_p"] == pytest.approx(14 / 64)


def test_runs_on_other_scenes_are_refused() -> None:
    with pytest.raises(ValueError, match="share no scene"):
        paired_outcomes(run([True]), run([True], seeds=[5]), "place")


@pytest.mark.parametrize("key, other", [("split", {"split": "val"}), ("task", {"task": "push"})])
def test_runs_of_another_split_or_task_are_refused(key: str, other: dict) -> None:
    with pytest.raises(ValueError, match=f"different {key}s"):
        paired_outcomes(run([True, False]), run([True, False], **other), "place")


def test_runs_of_different_lengths_compare_the_scenes_they_share() -> None:
    longer = run([True, False, True, False], seeds=[0, 1, 2, 3])
    shorter = run([True, True], seeds=[0, 1])
    result = paired_outcomes(longer, shorter, "place")
    assert (result["episodes"], result["episodes_first"], result["episodes_second"]) == (2, 4, 2)
    assert (result["both"], result["only_second"]) == (1, 1)


def test_an_unknown_milestone_is_refused_naming_the_milestones() -> None:
    with pytest.raises(ValueError, match=r"--milestone=bogus is not a milestone of pick_place: choose from"):
        paired_outcomes(run([True]), run([True]), "bogus")


def test_the_cli_names_a_truncated_record_in_one_line(tmp_path: Path) -> None:
    good, bad = tmp_path / "good", tmp_path / "bad"
    for folder in (good, bad):
        folder.mkdir()
    (good / "eval_info.json").write_text(json.dumps(run([True, False])))
    (bad / "eval_info.json").write_text(json.dumps(run([True, False]))[:40])
    command = [sys.executable, "-m", "lerobot_ivmc.scripts.lerobot_ivmc_compare", str(good), str(bad)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert f"{bad / 'eval_info.json'} is not a complete lerobot-ivmc-eval record" in result.stderr
    command = [sys.executable, "-m", "lerobot_ivmc.scripts.lerobot_ivmc_compare", str(good), str(good)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0 and "2 paired scenes)" in result.stdout


def test_rescue_counts_the_failures_a_recovery_turned_into_successes() -> None:
    bvmc = run([False, False, False, True, True], seeds=[0, 1, 2, 3, 4])
    for episode, u in zip(bvmc["per_episode"], [2.0, 0.5, 3.0, 0.1, 2.5], strict=True):
        episode["max_uncertainty"] = u
    recovered = run([True, False, False, True, False], seeds=[0, 1, 2, 3, 4])
    recovered["recovery"] = {"threshold": 1.0}
    rescue = rescue_record(bvmc, recovered, "place")
    # 3 failures, 2 of them above C = 1.0; scene 0 rescued, scene 4 lost: (1 - 1) / 3.
    assert (rescue["failures"], rescue["flagged"], rescue["rescued"], rescue["lost"]) == (3, 2, 1, 1)
    assert rescue["rescue_rate"] == 0.0 and rescue["mcnemar_exact_p"] == 1.0
    # A threshold of the time-conditioned score against u the paper's way: no count of flagged failures.
    recovered["recovery"]["threshold_source"] = "checkpoint (argmax), time-conditioned (quantile 1.0)"
    rescue = rescue_record(bvmc, recovered, "place")
    assert rescue["flagged"] is None and (rescue["rescued"], rescue["lost"]) == (1, 1)
    bvmc["recovery"] = {"threshold_source": recovered["recovery"]["threshold_source"]}
    assert rescue_record(bvmc, recovered, "place")["flagged"] == 2
    # A deadline fires recoveries whatever u: u above C no longer says which failures a recovery met.
    recovered["recovery"]["settings"] = {"deadline": 80}
    assert rescue_record(bvmc, recovered, "place")["flagged"] is None
    recovered["recovery"]["settings"] = {"deadline": 0, "grasp_miss": 30}  # so does a missed grasp
    assert rescue_record(bvmc, recovered, "place")["flagged"] is None
    never_failed = run([True, True])
    assert (
        rescue_record(never_failed, {**run([True, True]), "recovery": {"threshold": 1.0}}, "place")[
            "rescue_rate"
        ]
        is None
    )


def test_pooled_pairs_sum_their_counts_and_test_the_sums(tmp_path: Path) -> None:
    """One pair per training seed: each compared on its own scenes, then pooled; an odd count refused."""
    folders = []
    for name, outcomes in [
        ("none_a", [False, False, True]),
        ("retry_a", [True, False, True]),
        ("none_b", [False, True, False]),
        ("retry_b", [True, True, True]),
    ]:
        folder = tmp_path / name
        folder.mkdir()
        (folder / "eval_info.json").write_text(json.dumps(run(outcomes, seeds=[0, 1, 2])))
        folders.append(str(folder))
    pooled = pooled_outcomes(
        [
            paired_outcomes(run([False, False, True]), run([True, False, True]), "place"),
            paired_outcomes(run([False, True, False]), run([True, True, True]), "place"),
        ]
    )
    assert (pooled["pairs"], pooled["episodes"], pooled["only_first"], pooled["only_second"]) == (2, 6, 0, 3)
    assert pooled["mcnemar_exact_p"] == pytest.approx(0.25)
    script = [sys.executable, "-m", "lerobot_ivmc.scripts.lerobot_ivmc_compare", "--pooled"]
    result = subprocess.run([*script, *folders], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert (
        "pooled over 2 pairs (place, 6 paired scenes): both 2, only baseline 0, only other 3, neither 1"
        in result.stdout
    )
    odd = subprocess.run([*script, *folders[:3]], capture_output=True, text=True, timeout=120)
    assert odd.returncode == 2 and "--pooled takes (baseline, other) pairs of folders, got 3" in odd.stderr
    # One baseline against two modes is two comparisons, not a pool.
    command = [*script, *folders[:2], folders[0], folders[3]]
    twice = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert twice.returncode == 2 and f"{folders[0]} appears twice" in twice.stderr
