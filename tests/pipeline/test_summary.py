"""`lerobot-ivmc-summary`: the studies' results across tasks, Table I next to the paper's, goals checked."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from lerobot_ivmc.pipeline.reproduction import ResultsError, SummaryConfig, goal_checks, write_summary
from lerobot_ivmc.pipeline.stages import console_script

METHODS = {
    "vmc": "VMC",
    "none": "BVMC",
    "rand": "BVMC + rand",
    "init": "BVMC + init",
    "min_unc": "BVMC + min unc",
}


def row(task: str, fc: int, method: str, rates: dict[str, float], seed: int = 1000, vs: dict | None = None):
    """A Table I row as `lerobot-ivmc-pipeline` writes it to `<task>.json`."""
    return {
        "task": task,
        "model": "VMC" if method == "vmc" else "BVMC",
        "num_fc_layers": fc,
        "method": method,
        "label": METHODS[method],
        "train_seed": seed,
        "subtasks": {name: {"rate": rate, "stderr": 4.5, "n": 100} for name, rate in rates.items()},
        "paper": {name: {"rate": 50.0, "stderr": 4.7} for name in rates},
        "paired": vs or {},
    }


def paired(only_first: int, only_second: int, p: float) -> dict:
    return {
        "both": 50,
        "only_first": only_first,
        "only_second": only_second,
        "neither": 10,
        "mcnemar_exact_p": p,
    }


def study(task: str, fcs: dict[int, dict[str, float]], complete: bool, wall_s: float, rho: float) -> dict:
    """A study whose #fc `fc` has task rates `fcs[fc]` per method (reach 100), with Fig. 3 and AUROC."""
    rows = []
    for fc, rates in fcs.items():
        for method, rate in rates.items():
            vs = (
                {"vs_none": paired(1, 6, 0.12), "vs_vmc": paired(13, 22, 0.18)}
                if method == "min_unc"
                else None
            )
            rows.append(row(task, fc, method, {"reach": 100.0, "place": rate}, vs=vs))
    per_fc = {str(fc): {"fig3": {"spearman_rho": rho}, "detection": {"auroc": 0.99}} for fc in fcs}
    return {
        "task": task,
        "preset": "lite",
        "complete": complete,
        "rows": rows,
        "per_fc": per_fc,
        "total_wall_s": wall_s,
        # An extra training seed's rows, kept apart by the study: not Table I rows.
        "training_seeds": {"rows": [row(task, 1, "vmc", {"reach": 100.0, "place": 0.0}, seed=2000)]},
    }


def test_goals_and_table_i_per_task_and_fc(tmp_path: Path) -> None:
    results = tmp_path / "results"
    results.mkdir()
    good = {"vmc": 66.0, "none": 70.0, "rand": 69.0, "init": 73.0, "min_unc": 75.0}
    weak = {"vmc": 72.0, "none": 65.0, "rand": 64.0, "init": 71.0, "min_unc": 70.0}
    (results / "pick_place.json").write_text(
        json.dumps(study("pick_place", {1: weak, 2: good}, True, 9980, -0.88))
    )
    (results / "push.json").write_text(json.dumps(study("push", {1: good}, False, 4000, -0.5)))
    (results / "notes.json").write_text("{}")  # not a task's results: ignored

    markdown_path, json_path = write_summary(SummaryConfig(results_dir=results, output_dir=tmp_path / "out"))
    goals = json.loads(json_path.read_text())["goals"]
    assert [(g["task"], g["num_fc_layers"]) for g in goals] == [
        ("push", 1),
        ("pick_place", 1),
        ("pick_place", 2),
    ]
    push, pp1, pp2 = goals
    assert (pp2["vmc"], pp2["bvmc"], pp2["min_unc"]) == (66.0, 70.0, 75.0)  # the main seed's rows only
    assert (pp2["above_bvmc"], pp2["above_vmc"], pp2["rho_met"], pp2["wall_time_met"]) == (
        True,
        True,
        True,
        True,
    )
    assert (pp1["above_bvmc"], pp1["above_vmc"]) == (True, False)
    # An unfinished study has no wall-time verdict yet; rho -0.5 misses the goal.
    assert (push["wall_time_met"], push["rho_met"]) == (None, False)

    markdown = markdown_path.read_text()
    assert (
        "| pick_place | 2 | place | 66 / 70 / 75 | met (6 / 1, p 0.12) | met (22 / 13, p 0.18) |" in markdown
    )
    assert "| push | 1 | place | 66 / 70 / 75 |" in markdown and "1.11 h so far" in markdown
    assert "| BVMC + min unc | 2 | 100 +- 4.5 (50) | 75 +- 4.5 (50) |" in markdown
    assert "| VMC | 1 | 100 +- 4.5 (50) | 0 +- 4.5 (50) |" not in markdown  # the extra seed's row


def test_missing_or_foreign_results_are_refused_with_what_to_do(tmp_path: Path) -> None:
    with pytest.raises(ResultsError, match="is not a folder"):
        write_summary(SummaryConfig(results_dir=tmp_path / "nowhere"))
    with pytest.raises(ResultsError, match="holds none of push.json"):
        write_summary(SummaryConfig(results_dir=tmp_path))
    (tmp_path / "push.json").write_text("{not json")
    with pytest.raises(ResultsError, match="push.json is not valid JSON"):
        write_summary(SummaryConfig(results_dir=tmp_path))
    (tmp_path / "push.json").write_text(json.dumps({"task": "push"}))
    with pytest.raises(ResultsError, match="not a study's results JSON \\(no rows, per_fc\\)"):
        write_summary(SummaryConfig(results_dir=tmp_path))
    with pytest.raises(ValueError, match="--results_dir"):
        write_summary(SummaryConfig())


def test_a_study_without_recovery_rows_leaves_those_goals_open() -> None:
    only_policies = study("pick_reach", {1: {"vmc": 100.0, "none": 100.0}}, True, 6000, -0.9)
    (check,) = goal_checks(only_policies)
    assert check.min_unc is None and check.above_bvmc is None and check.above_vmc is None


def test_the_console_script_writes_the_summary_or_ends_with_one_line(tmp_path: Path) -> None:
    results = tmp_path / "results"
    results.mkdir()
    good = {"vmc": 66.0, "none": 70.0, "rand": 69.0, "init": 73.0, "min_unc": 75.0}
    (results / "pick_place.json").write_text(json.dumps(study("pick_place", {2: good}, True, 9980, -0.88)))
    script = console_script("lerobot-ivmc-summary")
    done = subprocess.run([script, f"--results_dir={results}"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "| pick_place | 2 | place | 66 / 70 / 75 |" in done.stdout
    assert (results / "reproduction.md").is_file() and (results / "reproduction.json").is_file()
    bad = subprocess.run([script, f"--results_dir={tmp_path / 'nowhere'}"], capture_output=True, text=True)
    assert bad.returncode == 2
    assert (
        bad.stderr.strip().splitlines()[-1] == f"error: --results_dir {tmp_path / 'nowhere'} is not a folder."
    )


def test_training_noise_sets_min_unc_against_every_seed_without_recovery(tmp_path: Path) -> None:
    good = {"vmc": 66.0, "none": 70.0, "rand": 69.0, "init": 73.0, "min_unc": 75.0}
    results = study("pick_place", {1: good, 2: good}, True, 9980, -0.88)
    results["training_seeds"] = {
        "rows": [
            row("pick_place", 2, "vmc", {"reach": 100.0, "place": 66.0}),
            row("pick_place", 2, "vmc", {"reach": 100.0, "place": 60.0}, seed=2000),
            row("pick_place", 2, "none", {"reach": 100.0, "place": 70.0}),
            row("pick_place", 2, "none", {"reach": 100.0, "place": 76.0}, seed=2000),
        ]
    }
    (tmp_path / "pick_place.json").write_text(json.dumps(results))
    markdown_path, json_path = write_summary(SummaryConfig(results_dir=tmp_path))

    # Only #fc = 2 had a second seed; min unc's 75 is above the main seed's BVMC but not the other seed's.
    (noise,) = json.loads(json_path.read_text())["training_noise"]
    assert (noise["num_fc_layers"], noise["min_unc"], noise["min_unc_above_every_seed"]) == (2, 75.0, False)
    assert noise["vmc_per_seed"] == {"1000": 66.0, "2000": 60.0}
    assert (
        "| pick_place | 2 | place | 66 (seed 1000), 60 (seed 2000) | 70 (seed 1000), 76 (seed 2000) | 75 | "
        "**not met** |" in markdown_path.read_text()
    )


def test_no_training_noise_section_without_extra_seeds(tmp_path: Path) -> None:
    good = {"vmc": 66.0, "none": 70.0, "min_unc": 75.0}
    (tmp_path / "push.json").write_text(json.dumps(study("push", {1: good}, True, 9000, -0.9)))
    markdown_path, json_path = write_summary(SummaryConfig(results_dir=tmp_path))
    assert json.loads(json_path.read_text())["training_noise"] == []
    assert "Training noise" not in markdown_path.read_text()


def test_rho_is_shown_with_the_bound_its_bins_allow(tmp_path: Path) -> None:
    good = {"vmc": 66.0, "none": 70.0, "min_unc": 75.0}
    results = study("push", {1: good}, True, 9000, -0.7977)
    # A perfect split, 7 bins at 100% and 3 at 0%: rho cannot go below -0.80 with these ties.
    results["per_fc"]["1"]["fig3"].update(mean_u=list(range(10)), success_rate=[1.0] * 7 + [0.0] * 3)
    (tmp_path / "push.json").write_text(json.dumps(results))
    markdown_path, json_path = write_summary(SummaryConfig(results_dir=tmp_path))
    (goal,) = json.loads(json_path.read_text())["goals"]
    assert goal["rho_met"] is False and goal["spearman_rho_best"] == pytest.approx(-0.7977, abs=1e-4)
    assert "| -0.80: **not met** (best attainable -0.80) |" in markdown_path.read_text()


def test_rescue_per_mode_pooled_over_seeds_with_the_goal(tmp_path: Path) -> None:
    results = study("pick_place", {1: {"vmc": 53.0, "none": 71.0, "min_unc": 73.0}}, True, 9000, -0.86)
    rescue = {"failures": 29, "flagged": 25, "rescued": 2, "lost": 0, "rescue_rate": 2 / 29}
    results["rows"][2]["rescue"] = {**rescue, "mcnemar_exact_p": 0.5}
    (tmp_path / "pick_place.json").write_text(json.dumps(results))
    markdown_path, json_path = write_summary(SummaryConfig(results_dir=tmp_path))
    (line,) = json.loads(json_path.read_text())["rescue"]
    assert (line["method"], line["train_seeds"], line["rescued"], line["goal_met"]) == (
        "min_unc",
        [1000],
        2,
        False,
    )
    assert "| pick_place | 1 | min_unc | 1000 | 29 (25) | 2 / 0 | 7% | 0.5 | **not met** |" in (
        markdown_path.read_text()
    )
    # With extra seeds the pooled record counts: 40 of 60 failures rescued net, p far below 0.05.
    pooled = {**rescue, "failures": 60, "rescued": 41, "lost": 1, "rescue_rate": 40 / 60, "exact_p": 1e-9}
    results["training_seeds"]["pooled_rescue"] = [
        {"num_fc_layers": 1, "method": "min_unc", "train_seeds": [1000, 2000], **pooled}
    ]
    (tmp_path / "pick_place.json").write_text(json.dumps(results))
    _, json_path = write_summary(SummaryConfig(results_dir=tmp_path, output_dir=tmp_path / "again"))
    (line,) = json.loads(json_path.read_text())["rescue"]
    assert (line["train_seeds"], line["rescue_rate"], line["goal_met"]) == ([1000, 2000], 40 / 60, True)


def test_studies_given_by_path_are_summarised_in_the_paper_s_task_order(tmp_path: Path) -> None:
    """`--results` takes the studies' results JSONs under any names (the records' descriptive ones), puts
    them in the paper's order and refuses two of one task."""
    good = {"vmc": 66.0, "none": 70.0, "rand": 69.0, "init": 73.0, "min_unc": 75.0}
    place = tmp_path / "pick_place_lite_fast_fc1.json"
    push = tmp_path / "push_lite_fast_fc1.json"
    place.write_text(json.dumps(study("pick_place", {1: good}, True, 9980, -0.88)))
    push.write_text(json.dumps(study("push", {1: good}, True, 9980, -0.9)))
    markdown_path, json_path = write_summary(
        SummaryConfig(results=[place, push], output_dir=tmp_path / "out")
    )
    assert [goal["task"] for goal in json.loads(json_path.read_text())["goals"]] == ["push", "pick_place"]
    assert "| pick_place | 1 | place | 66 / 70 / 75 |" in markdown_path.read_text()
    with pytest.raises(ResultsError, match="more than one study of pick_place"):
        write_summary(SummaryConfig(results=[place, place]))
    with pytest.raises(ValueError, match="not both"):
        write_summary(SummaryConfig(results_dir=tmp_path, results=[place]))


def test_a_mode_measured_on_several_tasks_is_pooled_over_them(tmp_path: Path) -> None:
    """The goal "rescues 40% of BVMC's failures pooled over tasks" reads one line: each task's rescued and
    lost counts summed, with the exact test on the sums; a mode measured on one task only gets none."""
    rates = {"vmc": 53.0, "none": 71.0, "min_unc": 73.0}
    place = study("pick_place", {1: rates}, True, 9000, -0.86)
    push = study("push", {1: rates}, True, 9000, -0.86)
    place["rows"][2]["rescue"] = {
        "failures": 29,
        "flagged": 25,
        "rescued": 12,
        "lost": 0,
        "rescue_rate": 12 / 29,
        "mcnemar_exact_p": 5e-4,
    }
    push["rows"][2]["rescue"] = {
        "failures": 21,
        "flagged": 20,
        "rescued": 9,
        "lost": 1,
        "rescue_rate": 8 / 21,
        "mcnemar_exact_p": 0.02,
    }
    push["rows"].append({**push["rows"][2], "method": "rand", "rescue": {**push["rows"][2]["rescue"]}})
    paths = [tmp_path / "place.json", tmp_path / "push.json"]
    for path, results in zip(paths, (place, push), strict=True):
        path.write_text(json.dumps(results))
    markdown_path, json_path = write_summary(SummaryConfig(results=paths, output_dir=tmp_path / "out"))
    pooled = [line for line in json.loads(json_path.read_text())["rescue"] if line["task"] == "all tasks"]
    assert [(line["method"], line["failures"], line["rescued"], line["lost"]) for line in pooled] == [
        ("min_unc", 50, 21, 1)
    ]
    assert pooled[0]["rescue_rate"] == 20 / 50 and pooled[0]["p"] < 1e-4
    assert "| all tasks | 1 | min_unc | 1000 | 50 (45) | 21 / 1 | 40% |" in markdown_path.read_text()


def test_anchor_s_control_row_is_reported_without_a_goal_verdict(tmp_path: Path) -> None:
    """The control row (anchor's planner at threshold 0) measures the introspection's timing: its rescue is
    listed, with no goal of its own."""
    results = study("pick_place", {1: {"vmc": 53.0, "none": 71.0}}, True, 9000, -0.86)
    control = row("pick_place", 1, "none", {"reach": 100.0, "place": 91.0})
    control["method"] = "anchor_control"
    control["rescue"] = {"failures": 29, "flagged": 29, "rescued": 27, "lost": 7, "rescue_rate": 20 / 29}
    control["rescue"]["mcnemar_exact_p"] = 0.0008
    results["rows"].append(control)
    (tmp_path / "pick_place.json").write_text(json.dumps(results))
    markdown_path, json_path = write_summary(SummaryConfig(results_dir=tmp_path))
    (line,) = json.loads(json_path.read_text())["rescue"]
    assert (line["method"], line["rescued"], line["lost"], line["goal_met"]) == (
        "anchor_control",
        27,
        7,
        None,
    )
