"""`lerobot-ivmc-pool-seeds`: training seeds run as separate studies pooled as one study's seeds."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pytest

from lerobot_ivmc.pipeline.regime import budget_config
from lerobot_ivmc.pipeline.seed_pool import PoolSeedsConfig, pool_studies, study_setup
from lerobot_ivmc.pipeline.stages import console_script
from lerobot_ivmc.pipeline.study import parse_config

SETUP = {"test_scenes": {"split": "test", "seed": 0, "n_episodes": 100}, "training": {"steps": 16000}}


def seed_row(seed: int, model: str, rate: float, method: str | None = None, rescue: dict | None = None):
    """A per-seed row as a study writes it (Table I row fields or `training_seeds` rows)."""
    row = {
        "task": "push",
        "model": model,
        "num_fc_layers": 1,
        "train_seed": seed,
        "subtasks": {
            "reach": {"rate": 100.0, "stderr": 0.0, "n": 100},
            "push": {"rate": rate, "stderr": 4.5, "n": 100},
        },
    }
    if method is not None:
        row["method"] = method
    if rescue is not None:
        row["rescue"] = rescue
    return row


def rescue(failures: int, rescued: int, lost: int) -> dict:
    return {
        "failures": failures,
        "flagged": failures,
        "rescued": rescued,
        "lost": lost,
        "rescue_rate": (rescued - lost) / failures,
        "mcnemar_exact_p": 0.5,
    }


def one_seed_study(seed: int, vmc: float, bvmc: float, anchor: float, anchor_rescue: dict, setup=SETUP):
    """A study of one training seed: its Table I rows (no `training_seeds` section)."""
    rows = [
        seed_row(seed, "VMC", vmc, "vmc"),
        seed_row(seed, "BVMC", bvmc, "none"),
        seed_row(seed, "BVMC", anchor, "anchor", anchor_rescue),
    ]
    study = {"task": "push", "preset": "lite", "complete": True, "rows": rows, "per_fc": {"1": {}}}
    return {**study, "setup": setup} if setup is not None else study


def test_two_one_seed_studies_pool_into_seed_means_and_one_rescue_test() -> None:
    first = one_seed_study(1000, 70.0, 80.0, 95.0, rescue(20, 16, 1))
    second = one_seed_study(3000, 60.0, 70.0, 85.0, rescue(30, 16, 1))
    second["regime"] = {"chosen_demos": 500}  # its demos chosen by the data-budget rule
    pooled, notes = pool_studies({"a.json": first, "b.json": second})

    section = pooled["training_seeds"]
    means = {e["method"]: (e["subtasks"]["push"]["mean"], e["train_seeds"]) for e in section["summary"]}
    assert means == {
        "vmc": (65.0, [1000, 3000]),
        "none": (75.0, [1000, 3000]),
        "anchor": (90.0, [1000, 3000]),
    }
    assert section["summary"][0]["subtasks"]["push"]["std"] == pytest.approx(math.sqrt(50))
    (anchor,) = section["pooled_rescue"]
    assert (anchor["failures"], anchor["rescued"], anchor["lost"]) == (50, 32, 2)
    assert anchor["rescue_rate"] == pytest.approx(0.6)
    # Hand-worked: 2 lost against 32 rescued, two-sided binomial(34, 1/2) tail.
    assert anchor["exact_p"] == pytest.approx(2 * (1 + 34 + 561) / 2**34)
    # The first study gives Table I; every source is named with its seeds.
    assert pooled["rows"] == first["rows"]
    assert [(s["results"], s["train_seeds"]) for s in pooled["pooled_from"]] == [
        ("a.json", [1000]),
        ("b.json", [3000]),
    ]
    assert [s.get("regime") for s in pooled["pooled_from"]] == [None, {"chosen_demos": 500}]
    assert notes == []


def test_a_study_with_extra_seeds_pools_its_seeds_with_another_study_s() -> None:
    two_seeds = one_seed_study(1000, 70.0, 80.0, 95.0, rescue(20, 16, 1))
    two_seeds["training_seeds"] = {
        "rows": [seed_row(s, m, r) for s, m, r in [(1000, "VMC", 70.0), (2000, "VMC", 64.0)]]
        + [seed_row(s, "BVMC", r) for s, r in [(1000, 80.0), (2000, 70.0)]],
        "recovery_rows": [
            seed_row(1000, "BVMC", 95.0, "anchor", rescue(20, 16, 1)),
            seed_row(2000, "BVMC", 85.0, "anchor", rescue(30, 16, 1)),
        ],
    }
    del two_seeds["setup"]  # written before studies recorded their setup
    pooled, notes = pool_studies(
        {"old.json": two_seeds, "new.json": one_seed_study(3000, 61, 75, 90, rescue(25, 9, 0))}
    )

    summary = {e["method"]: e for e in pooled["training_seeds"]["summary"]}
    assert summary["vmc"]["subtasks"]["push"]["rates"] == [70.0, 64.0, 61.0]
    assert summary["anchor"]["train_seeds"] == [1000, 2000, 3000]
    (anchor,) = pooled["training_seeds"]["pooled_rescue"]
    assert (anchor["failures"], anchor["rescued"], anchor["lost"]) == (75, 41, 2)
    # The study without a setup record is named in a note, not compared silently.
    assert len(notes) == 1 and notes[0].startswith("old.json records no setup")


def test_refuses_a_seed_twice_other_setups_other_tasks() -> None:
    study = one_seed_study(1000, 70.0, 80.0, 95.0, rescue(20, 16, 1))
    with pytest.raises(ValueError, match="Training seed 1000 .* is in both a.json and b.json"):
        pool_studies({"a.json": study, "b.json": study})
    other_scenes = {**SETUP, "test_scenes": {"split": "test", "seed": 500, "n_episodes": 100}}
    other = one_seed_study(3000, 60.0, 70.0, 85.0, rescue(30, 16, 1), setup=other_scenes)
    with pytest.raises(ValueError, match=r"differ in their setup's \['test_scenes'\]"):
        pool_studies({"a.json": study, "b.json": other})
    with pytest.raises(ValueError, match="one task and preset"):
        pool_studies({"a.json": study, "b.json": {**other, "setup": SETUP, "task": "pick_place"}})


def test_command_writes_the_pool_and_its_table_and_never_overwrites(tmp_path: Path) -> None:
    paths = []
    for seed, study in [
        (1000, one_seed_study(1000, 70.0, 80.0, 95.0, rescue(20, 16, 1))),
        (3000, one_seed_study(3000, 60.0, 70.0, 85.0, rescue(30, 16, 1))),
    ]:
        paths.append(tmp_path / f"seed{seed}" / "push.json")
        paths[-1].parent.mkdir()
        paths[-1].write_text(json.dumps(study))
    output = tmp_path / "pooled" / "push_seeds.json"
    command = [
        console_script("lerobot-ivmc-pool-seeds"),
        f"--results=[{paths[0]},{paths[1]}]",
        f"--output={output}",
    ]
    done = subprocess.run(command, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert json.loads(output.read_text())["training_seeds"]["pooled_rescue"][0]["rescued"] == 32
    assert "| BVMC + anchor (beyond the paper) | 1 | 1000, 3000 | 50 (50) | 32 / 2 | 60% |" in (
        output.with_suffix(".md").read_text()
    )
    before = output.read_text()
    again = subprocess.run(command, capture_output=True, text=True)
    assert again.returncode != 0 and "pass --overwrite=true" in again.stderr.strip().splitlines()[-1]
    assert output.read_text() == before


def test_config_refuses_one_study_and_a_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="two or more studies"):
        PoolSeedsConfig(results=[tmp_path / "a.json"], output=tmp_path / "o.json").validate()
    with pytest.raises(FileNotFoundError, match="No results JSON"):
        PoolSeedsConfig(
            results=[tmp_path / "a.json", tmp_path / "b.json"], output=tmp_path / "o.json"
        ).validate()


def test_a_regime_study_pools_with_plain_studies_of_its_chosen_demos() -> None:
    """More seeds of a data-budget study elsewhere: a plain study of the demos the rule chose, with another
    training seed, records the same setup, so the two pool; one of another demo count does not."""
    lite = ["--task=pick_reach", "--preset=lite", "--train.num_fc_layers=[1]"]
    regime = parse_config([*lite, "--regime.demo_budgets=[1000,500,250]", "--train.seed=1000"])
    chosen = study_setup(budget_config(regime, 500))

    def plain(demos: int) -> dict:
        return study_setup(
            parse_config([*lite, f"--collect.dataset.num_episodes={demos}", "--train.seed=2000"])
        )

    assert chosen == plain(500) and chosen != plain(250)


def chosen_row(seed: int, mode: str, validation: dict[str, tuple[int, int]], failures: int) -> dict:
    """A seed's row "chosen" (its test rescue is `mode`'s) with its candidates' validation rescued / lost."""
    records = {m: rescue(40, *counts) for m, counts in validation.items()}
    row = seed_row(seed, "BVMC", 80.0, "chosen", rescue(failures, 0, 0))
    return {**row, "choice": {"chosen_mode": mode, "validation": records}}


def test_one_choice_over_the_seeds_sums_their_validation_rescue_and_takes_that_mode_s_test_rows() -> None:
    """Each seed's choice went by a margin of one or two validation rescues (retry 13 / 3 against reach
    12 / 0 on one seed, 15 / 0 against 13 / 1 on the other); summed over both, retry rescues 25 net against
    24, and the row "chosen over the seeds" reports retry's test rows on both seeds."""
    first = {"retry": (13, 3), "reach_place_frame": (12, 0), "none": (0, 0)}
    second = {"retry": (15, 0), "reach_place_frame": (13, 1), "none": (0, 0)}
    study = {
        "task": "push",
        "preset": "lite",
        "complete": True,
        "per_fc": {"1": {}},
        "setup": SETUP,
        "training_seeds": {
            "rows": [seed_row(1000, "BVMC", 81.0, "none"), seed_row(2000, "BVMC", 70.0, "none")],
            "recovery_rows": [
                chosen_row(1000, "reach_place_frame", first, 19),
                chosen_row(2000, "retry", second, 30),
                seed_row(1000, "BVMC", 90.0, "retry", rescue(19, 11, 2)),
                seed_row(2000, "BVMC", 76.0, "retry", rescue(30, 7, 1)),
                seed_row(1000, "BVMC", 85.0, "reach_place_frame", rescue(19, 4, 0)),
                seed_row(2000, "BVMC", 79.0, "reach_place_frame", rescue(30, 10, 1)),
            ],
        },
        "rows": [],
    }
    third = one_seed_study(3000, 70.0, 72.0, 80.0, rescue(28, 9, 1))
    third_choice = {"retry": (1, 2), "reach_place_frame": (0, 1), "none": (0, 0)}
    third["rows"] += [
        chosen_row(3000, "none", third_choice, 28),
        seed_row(3000, "BVMC", 79.0, "retry", rescue(28, 9, 1)),
        seed_row(3000, "BVMC", 72.0, "reach_place_frame", rescue(28, 0, 0)),
    ]
    pooled = pool_studies({"a": study, "b": third})[0]["training_seeds"]["pooled_rescue"]
    over = {e["method"]: e for e in pooled}["chosen_over_seeds"]
    assert over["chosen_mode"] == "retry" and over["train_seeds"] == [1000, 2000, 3000]
    validation = over["validation"]
    assert (validation["retry"]["rescued"], validation["retry"]["lost"]) == (29, 5)  # 24 net
    assert (validation["reach_place_frame"]["rescued"], validation["reach_place_frame"]["lost"]) == (25, 2)
    assert (over["failures"], over["rescued"], over["lost"]) == (77, 27, 4)  # retry's test rows
    assert [e["method"] for e in pooled].index("chosen_over_seeds") == [e["method"] for e in pooled].index(
        "chosen"
    ) + 1
    # A seed without the chosen mode's test row: no such row, rather than one made of other modes' rows.
    third["rows"] = [r for r in third["rows"] if r.get("method") != "retry"]
    pooled = pool_studies({"a": study, "b": third})[0]["training_seeds"]["pooled_rescue"]
    assert "chosen_over_seeds" not in {e["method"] for e in pooled}
