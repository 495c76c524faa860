"""Training seeds over studies: the mean and spread of each row, and each recovery mode's rescue pooled over
the seeds, from one study's seeds or from several studies' results (seeds trained on other machines or in
other sessions, on the same test scenes, demos and recipe)."""

from __future__ import annotations

import statistics
from dataclasses import asdict, dataclass, field
from pathlib import Path

from lerobot_ivmc.evaluation.compare import exact_mcnemar_p
from lerobot_ivmc.pipeline.config import PipelineConfig
from lerobot_ivmc.pipeline.recovery_choice import CHOSEN, CHOSEN_OVER_SEEDS, choose_mode
from lerobot_ivmc.pipeline.tables import pooled_rescue_table, row_label, row_sort_key, training_seed_table

WITHOUT_RECOVERY = ("vmc", "none")


def study_setup(cfg: PipelineConfig) -> dict:
    """What the training seeds of one pooled table must share: the test scenes, the demos, the training
    recipe, the foresight and threshold settings (not the seeds, the device or the precision)."""
    return {
        "test_scenes": {
            "split": "test",
            "seed": cfg.seed,
            "n_episodes": cfg.eval.n_episodes,
            "episode_length": cfg.episode_length,
        },
        "demos": {
            "seed": cfg.collect.seed,
            "num_episodes": cfg.collect.dataset.num_episodes,
            "action_noise": cfg.collect.action_noise,
            **({"expert_after_success": a} if (a := cfg.collect.expert_after_success) != "hold" else {}),
            "env": asdict(cfg.collect.env),
            "regime": {"demo_budgets": cfg.regime.demo_budgets, "failure_range": cfg.regime.failure_range},
        },
        "training": {
            "steps": cfg.train.steps,
            "batch_size": cfg.train.batch_size,
            "policy": cfg.train.policy.given(),
        },
        "foresight": {"num_trajectories": cfg.foresight.foresight.num_trajectories},
        "threshold": {"n_episodes": cfg.threshold.n_episodes, "method": cfg.threshold.method},
    }


def row_method(row: dict) -> str:
    """A per-seed row's method: its recovery mode, or "vmc" / "none" for the rows without recovery."""
    return row.get("method") or ("vmc" if row["model"] == "VMC" else "none")


def spread_over_seeds(rows: list[dict], recovery_rows: list[dict]) -> tuple[list[dict], list[dict]]:
    """The seed-averaged rows and the pooled rescue of per-seed rows.

    Args:
        rows: VMC and BVMC without recovery, one per (#fc, training seed); recovery_rows: one per
            (#fc, recovery mode, training seed), each with its `rescue` against its own seed's BVMC.

    Returns:
        summary: per (#fc, row) with at least two seeds, each subtask's mean and sample standard deviation
        over the seeds; pooled: per (#fc, recovery mode) the rescue counts summed over the seeds, the
        pooled rescue rate, and the exact test of rescued against lost over every seed's paired scenes (a
        matched pair per scene and seed: the Mantel-Haenszel test for matched pairs); after the row
        "chosen", the row "chosen over the seeds" (`chosen_over_seeds`) where it can be made.
    """
    groups: dict[tuple[int, str], list[dict]] = {}
    for row in [*rows, *recovery_rows]:
        groups.setdefault((row["num_fc_layers"], row_method(row)), []).append(row)
    summary, pooled = [], []
    for (fc, method), per_seed in sorted(groups.items(), key=lambda kv: (kv[0][0], row_sort_key(kv[0][1]))):
        if method not in WITHOUT_RECOVERY:
            pooled.append(pooled_rescue(fc, method, per_seed))
        if method == CHOSEN and (over_seeds := chosen_over_seeds(fc, recovery_rows)) is not None:
            pooled.append(over_seeds)
        if len(per_seed) < 2:
            continue
        spread = {}
        for sub in per_seed[0]["subtasks"]:
            rates = [r["subtasks"][sub]["rate"] for r in per_seed]
            spread[sub] = {"mean": statistics.mean(rates), "std": statistics.stdev(rates), "rates": rates}
        summary.append(
            {
                "model": row_label(method),
                "method": method,
                "num_fc_layers": fc,
                "train_seeds": [r["train_seed"] for r in per_seed],
                "subtasks": spread,
            }
        )
    return summary, pooled


def summed_rescue(records: list[dict]) -> dict:
    """Rescue records (each with failures, flagged, rescued, lost) summed, with the rescue rate net of the
    lost and the exact test of rescued against lost on the sums (`exact_p`)."""
    total = {k: sum(r[k] for r in records) for k in ("failures", "rescued", "lost")}
    # Flagged counts only where every seed's has one (none where a deadline, a grasp miss or no recovery ran).
    flagged = [r["flagged"] for r in records]
    total["flagged"] = None if None in flagged else sum(flagged)
    return {
        **total,
        "rescue_rate": (total["rescued"] - total["lost"]) / total["failures"] if total["failures"] else None,
        "exact_p": exact_mcnemar_p(total["lost"], total["rescued"]),
    }


def pooled_rescue(fc: int, method: str, per_seed: list[dict]) -> dict:
    """A recovery mode's rescue counts summed over the seeds' rows, with the pooled exact test."""
    return {
        "num_fc_layers": fc,
        "method": method,
        "train_seeds": [r["train_seed"] for r in per_seed],
        **summed_rescue([r["rescue"] for r in per_seed]),
    }


def chosen_over_seeds(fc: int, recovery_rows: list[dict]) -> dict | None:
    """The row "chosen over the seeds": one mode for every training seed, by the choice rule
    (`choose_mode`) on each candidate's validation rescue summed over the seeds, so that one seed's margin
    of a rescue or two does not decide; its test rescue summed over the seeds. Made from the seeds' "chosen"
    rows (each keeps its own choice); None with fewer than two of them, with different candidates, or where
    a seed lacks the chosen mode's test row."""
    choices = [
        r for r in recovery_rows if r["num_fc_layers"] == fc and row_method(r) == CHOSEN and "choice" in r
    ]
    if len(choices) < 2:
        return None
    candidates = list(choices[0]["choice"]["validation"])
    if any(list(r["choice"]["validation"]) != candidates for r in choices):
        return None
    validation = {m: summed_rescue([r["choice"]["validation"][m] for r in choices]) for m in candidates}
    mode = choose_mode(validation)
    seeds = [r["train_seed"] for r in choices]
    if mode == "none":  # no recovery: nothing rescued or lost of each seed's failures
        tests = [
            {"failures": r["rescue"]["failures"], "flagged": None, "rescued": 0, "lost": 0} for r in choices
        ]
    else:
        rows = {
            r["train_seed"]: r for r in recovery_rows if r["num_fc_layers"] == fc and row_method(r) == mode
        }
        if any(seed not in rows for seed in seeds):
            return None
        tests = [rows[seed]["rescue"] for seed in seeds]
    return {
        "num_fc_layers": fc,
        "method": CHOSEN_OVER_SEEDS,
        "train_seeds": seeds,
        "chosen_mode": mode,
        "validation": validation,
        **summed_rescue(tests),
    }


def study_seed_rows(results: dict) -> tuple[list[dict], list[dict]]:
    """A study's per-seed rows (without recovery, with recovery): its `training_seeds` section, or, for a
    study of one training seed, its Table I rows."""
    if "training_seeds" in results:
        return results["training_seeds"]["rows"], results["training_seeds"]["recovery_rows"]
    rows, recovery_rows = [], []
    for row in results["rows"]:
        seed_row = {k: row[k] for k in ("task", "model", "num_fc_layers", "train_seed", "subtasks")}
        if row["method"] in WITHOUT_RECOVERY:
            rows.append(seed_row)
        elif "rescue" in row:
            choice = {"choice": row["choice"]} if "choice" in row else {}  # the row "chosen"'s validation
            recovery_rows.append({**seed_row, "method": row["method"], "rescue": row["rescue"], **choice})
    return rows, recovery_rows


def pool_studies(studies: dict[str, dict]) -> tuple[dict, list[str]]:
    """One results JSON whose `training_seeds` section holds the training seeds of every study.

    Args:
        studies: each study's results JSON (`<out>/results/<task>.json`) by a name for messages; the first
            gives the Table I rows and Fig. 3 of its main seed.

    Returns:
        the pooled results (the first study's, its `training_seeds` replaced, `pooled_from` added) and
        notes for the reader (studies that recorded no setup, so their scenes could not be compared).

    Raises:
        ValueError: studies of different tasks or presets, a training seed in two studies, or setups (test
            scenes, demos, recipe) that differ.
    """
    names = list(studies)
    first = studies[names[0]]
    kinds = {(s["task"], s["preset"]) for s in studies.values()}
    if len(kinds) > 1:
        raise ValueError(f"Pool studies of one task and preset, got {sorted(kinds)}.")
    setups = {name: s["setup"] for name, s in studies.items() if "setup" in s}
    reference_name = next(iter(setups), None)
    for name, setup in setups.items():
        differing = [
            key
            for key in setup.keys() | setups[reference_name].keys()
            if setup.get(key) != setups[reference_name].get(key)
        ]
        if differing:
            raise ValueError(
                f"{name} and {reference_name} differ in their setup's {sorted(differing)}: pool only seeds "
                "trained and evaluated alike."
            )
    notes = [
        f"{name} records no setup (written before the record existed): its test scenes, demos and recipe "
        "are taken to be its preset's, like the others'."
        for name in names
        if name not in setups
    ]
    rows, recovery_rows, seen, sources = [], [], {}, []
    for name, results in studies.items():
        study_rows, study_recovery = study_seed_rows(results)
        for row in [*study_rows, *study_recovery]:
            key = (row["num_fc_layers"], row_method(row), row["train_seed"])
            if key in seen:
                raise ValueError(
                    f"Training seed {row['train_seed']} (#fc = {row['num_fc_layers']}) is in both "
                    f"{seen[key]} and {name}: pool each seed once."
                )
            seen[key] = name
        rows += study_rows
        recovery_rows += study_recovery
        sources.append(
            {
                "results": name,
                "train_seeds": sorted({r["train_seed"] for r in study_rows}),
                "setup_recorded": name in setups,
                "complete": results["complete"],
                "per_fc": results["per_fc"],
                "total_wall_s": results.get("total_wall_s"),
                # the data-budget rule's record, where the study chose its demos by it
                **({"regime": results["regime"]} if "regime" in results else {}),
            }
        )
    episodes = {sub["n"] for row in [*rows, *recovery_rows] for sub in row["subtasks"].values()}
    if len(episodes) > 1:
        raise ValueError(
            f"The rows hold different numbers of test scenes {sorted(episodes)}: pool equal runs."
        )
    summary, pooled = spread_over_seeds(rows, recovery_rows)
    payload = {
        **first,
        "complete": all(s["complete"] for s in studies.values()),
        "perception": [p for s in studies.values() for p in s.get("perception", [])],
        "training_seeds": {
            "rows": rows,
            "summary": summary,
            "recovery_rows": recovery_rows,
            "pooled_rescue": pooled,
        },
        "pooled_from": sources,
    }
    return payload, notes


def seeds_markdown(pooled_results: dict) -> str:
    """The pooled study's per-seed rows, seed means and pooled rescue as markdown."""
    section = pooled_results["training_seeds"]
    return (
        f"# {pooled_results['task']}, preset {pooled_results['preset']}: training seeds\n\n"
        + training_seed_table(section["rows"] + section["recovery_rows"], section["summary"])
        + pooled_rescue_table(section["pooled_rescue"])
    )


@dataclass
class PoolSeedsConfig:
    """Args:
    results: the studies' results JSONs (`<out>/results/<task>.json`), the first giving Table I's rows.
    output: the pooled JSON to write; its markdown goes beside it (`.md`). Refused if it is one of
        `results` or exists, unless `overwrite`.
    overwrite: replace an existing `output`.
    """

    results: list[Path] = field(default_factory=list)
    output: Path | None = None
    overwrite: bool = False

    def validate(self) -> None:
        if len(self.results) < 2:
            raise ValueError(
                "Give two or more studies: --results='[a/results/push.json,b/results/push.json]'."
            )
        missing = [str(p) for p in self.results if not Path(p).is_file()]
        if missing:
            raise FileNotFoundError(
                f"No results JSON at {missing}: pass each study's <out>/results/<task>.json."
            )
        if self.output is None:
            raise ValueError("Give where the pooled JSON goes: --output=<file>.json.")
        output = Path(self.output)
        if output.suffix != ".json":
            raise ValueError(f"--output={output} must end in .json (its markdown goes beside it).")
        if any(output.resolve() == Path(p).resolve() for p in self.results):
            raise ValueError(f"--output={output} is one of the studies' results: write the pool elsewhere.")
        if output.exists() and not self.overwrite:
            raise FileExistsError(
                f"{output} exists: pass --overwrite=true to replace it, or another --output."
            )
