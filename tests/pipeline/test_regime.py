"""The data-budget rule: its choice on scripted validation curves, its refusals, and its probes run for real
(smoke counts) ahead of the chosen budget's study."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from lerobot_ivmc.pipeline import regime
from lerobot_ivmc.pipeline.regime import REGIME_FILE, BudgetProbe, choose_budget, run_regime
from lerobot_ivmc.pipeline.study import parse_config

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow


def probes_for(curve: dict[int, int], episodes: int = 50) -> list[BudgetProbe]:
    """Probes from {demos: validation failures}, largest budget first."""
    return [BudgetProbe(demos, episodes, failures) for demos, failures in curve.items()]


def rule(curve: dict[int, int], budgets: list[int], low: float = 0.2, high: float = 0.4) -> tuple[int, int]:
    """Walk the budgets as the pipeline does, each probe read from `curve`: (chosen demos, probes used)."""
    probes = []
    for index, demos in enumerate(budgets):
        probes.append(BudgetProbe(demos, 50, curve[demos]))
        chosen = choose_budget(probes, low, high, exhausted=index == len(budgets) - 1)
        if chosen is not None:
            return chosen, len(probes)
    raise AssertionError("the rule never chose")


def test_the_rule_takes_the_first_budget_in_the_range_and_probes_no_further() -> None:
    # pick_reach-like: solved at full data, failing more as the demos shrink
    curve = {2000: 0, 1000: 3, 500: 14, 250: 30}
    assert rule(curve, [2000, 1000, 500, 250]) == (500, 3)  # 28% failures: in 20-40%; 250 never trained
    # push / pick_place-like: already in the range at full data
    assert rule({2000: 17, 1000: 25}, [2000, 1000]) == (2000, 1)


def test_past_the_range_the_rule_takes_the_nearer_of_the_last_two_budgets() -> None:
    # 1000 fails 8% (12 points short), 500 fails 70% (30 points over): 1000 is nearer
    assert rule({2000: 0, 1000: 4, 500: 35, 250: 45}, [2000, 1000, 500, 250]) == (1000, 3)
    # 1000 fails 2% (18 short), 500 fails 50% (10 over): 500
    assert rule({2000: 0, 1000: 1, 500: 25}, [2000, 1000, 500, 250]) == (500, 3)
    # a tie goes to the larger budget; the first budget already past the range is chosen alone
    assert rule({2000: 0, 1000: 5, 500: 25}, [2000, 1000, 500], low=0.2, high=0.4) == (1000, 3)
    assert rule({2000: 40}, [2000, 1000]) == (2000, 1)


def test_when_no_budget_reaches_the_range_the_smallest_is_taken() -> None:
    assert rule({2000: 0, 1000: 0, 500: 2}, [2000, 1000, 500]) == (500, 3)
    with pytest.raises(ValueError, match="at least one probe"):
        choose_budget([], 0.2, 0.4, exhausted=True)


def refusal(*overrides: str) -> str:
    """The message with which the pipeline's config refuses `overrides` (draccus wraps it)."""
    with pytest.raises(Exception) as refused:
        parse_config(["--task=pick_reach", "--preset=smoke", *overrides])
    return str(refused.value.__cause__ or refused.value)


def test_bad_budgets_and_ranges_are_refused_in_one_line() -> None:
    assert "demo_budgets must be positive and decreasing, each below --collect.dataset.num_episodes=4" in (
        refusal("--regime.demo_budgets=[8]")
    )
    assert "demo_budgets must be positive and decreasing" in refusal("--regime.demo_budgets=[2,3]")
    assert "--regime.failure_range must be [low,high]" in refusal("--regime.failure_range=[0.4,0.2]")
    too_many = refusal("--regime.demo_budgets=[2]", "--regime.n_episodes=2", "--regime.batch_size=4")
    assert "--regime.batch_size must be in [1, --regime.n_episodes=2]" in too_many


def test_probes_run_each_budget_s_study_start_then_the_chosen_study(tmp_path: Path, monkeypatch) -> None:
    """Smoke counts, every probe stage run for real (collection, training, validation episodes); only the
    failure counts are scripted, since 4-step policies fail every scene: 0 of 2 with 4 demos (below the
    range: go on), 1 of 2 with 2 demos (in it: chosen). A rerun reuses every probe."""
    out = tmp_path / "regime"
    args = ["--task=pick_reach", "--preset=smoke", f"--output_dir={out}", "--regime.demo_budgets=[2]"]
    args += ["--regime.n_episodes=2", "--regime.batch_size=2", "--regime.failure_range=[0.2,0.6]"]
    scripted_failures = {4: 0, 2: 1}
    read = regime.read_probe

    def scripted_read(stage, demos):
        probe = read(stage, demos)  # the real validation run, 2 episodes
        assert probe.episodes == 2
        return BudgetProbe(demos, probe.episodes, scripted_failures[demos])

    monkeypatch.setattr(regime, "read_probe", scripted_read)
    studies = []

    def run_study(cfg):  # the chosen study itself: the smoke study, tested end to end elsewhere
        studies.append(cfg)
        # the record is in place before the study's results JSON is first written
        assert (cfg.root / "results" / REGIME_FILE).is_file()
        return {"task": cfg.task}

    results = run_regime(parse_config(args), run_study, log=lambda line: None)
    record = json.loads((out / REGIME_FILE).read_text())
    assert [(p["demos"], p["failures"]) for p in record["probes"]] == [(4, 0), (2, 1)]
    assert record["chosen_demos"] == 2 and record["range_reached"]
    assert [s.root for s in studies] == [out / "demos2"] and studies[0].collect.dataset.num_episodes == 2
    assert results["regime"] == record and (out / "demos2" / "results" / REGIME_FILE).is_file()

    def scenes(demos: int) -> list:
        collection = json.loads(
            (out / f"demos{demos}" / "data" / "meta" / "ivmc_collection.json").read_text()
        )
        return collection["episodes"]

    assert len(scenes(4)) == 4 and scenes(2) == scenes(4)[:2]  # the first demos of the larger budget

    lines: list[str] = []
    run_regime(parse_config(args), run_study, log=lines.append)
    assert sum("regime_val: done earlier" in line for line in lines) == 2
    assert not any(": running" in line for line in lines)


def test_both_budgets_and_bad_training_lengths_are_refused_in_one_line() -> None:
    both = refusal("--regime.demo_budgets=[2]", "--regime.train_steps=[2]")
    assert (
        "--regime.demo_budgets and --regime.train_steps each set the budget the rule varies; give one."
        in both
    )
    too_long = refusal("--regime.train_steps=[8]")
    assert (
        "--regime.train_steps must be positive and decreasing, each below --train.steps=4, got [8]"
        in too_long
    )
    assert "--regime.train_steps must be positive and decreasing" in refusal("--regime.train_steps=[2,3]")


def test_the_training_length_rule_probes_shorter_trainings_on_all_the_demos(
    tmp_path: Path, monkeypatch
) -> None:
    """`--regime.train_steps`: each probe is the start of a study with all the demos and fewer training
    steps, in `steps<n>/`; the record names the budget `steps`. Stages are not run here (the probes' run is
    the demo-budget test's above); the failures are scripted: 0 of 50 at 4 steps, 3 at 2, 15 at 1."""
    out = tmp_path / "regime"
    args = ["--task=pick_reach", "--preset=smoke", f"--output_dir={out}", "--regime.train_steps=[2,1]"]
    cfg = parse_config(args)
    assert regime.budgets(cfg) == [4, 2, 1]
    two = regime.budget_config(cfg, 2)
    assert (two.root, two.train.steps) == (out / "steps2", 2)
    assert two.collect.dataset.num_episodes == cfg.collect.dataset.num_episodes
    assert not two.regime.budget  # the chosen study runs without the rule

    scripted_failures = {4: 0, 2: 3, 1: 15}
    monkeypatch.setattr(regime, "run_stages", lambda root, stages, log: None)
    monkeypatch.setattr(
        regime, "read_probe", lambda stage, steps: BudgetProbe(steps, 50, scripted_failures[steps])
    )
    trained_steps = [stage.name for stage in regime.probe_stages(two) if stage.name.startswith("train")]
    assert trained_steps == ["train_bvmc_fc1"]
    studies = []
    results = run_regime(cfg, lambda study: studies.append(study) or {}, log=lambda line: None)
    record = json.loads((out / REGIME_FILE).read_text())
    assert [(p["steps"], p["failures"]) for p in record["probes"]] == [(4, 0), (2, 3), (1, 15)]
    assert record["chosen_steps"] == 1 and record["range_reached"]  # 30% failures: in the default 20-40%
    assert [(s.root, s.train.steps) for s in studies] == [(out / "steps1", 1)]
    assert results["regime"] == record
