"""The reproduction across tasks: the studies' results next to the paper's Table I, and the goals checked.

Reads the `<task>.json` each study writes (`lerobot-ivmc-pipeline`, `<out>/results/`) and builds, per task
and #fc, the Table I rows with the paper's values, and one line of goals: BVMC + min unc above BVMC and
above VMC on the task's last milestone (with the paired scene counts and McNemar's exact p), Fig. 3's
Spearman rho at most -0.8, the AUROC of the maximum uncertainty, and the study's wall time within 3 hours.
Where a study trained extra seeds (`--train.extra_seeds`), the training noise: VMC's and BVMC's rate per
training seed next to min unc's, so a reader sees whether a margin exceeds what another seed changes.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from lerobot_ivmc.envs import TASKS
from lerobot_ivmc.evaluation.success_by_uncertainty import most_negative_rho
from lerobot_ivmc.pipeline.config import CONTROL_ROWS
from lerobot_ivmc.pipeline.results import finite
from lerobot_ivmc.pipeline.seed_pool import summed_rescue
from lerobot_ivmc.pipeline.tables import rescue_cells

RHO_GOAL = -0.8
WALL_TIME_GOAL_S = 3 * 3600.0


class ResultsError(ValueError):
    """A results file that is missing or not a study's results JSON; the message names it."""


@dataclass
class GoalCheck:
    """The goals of one task and #fc (None where the study has no such row or value)."""

    task: str
    num_fc_layers: int
    milestone: str
    vmc: float | None
    bvmc: float | None
    min_unc: float | None
    vs_bvmc: dict | None  # paired counts of min unc against BVMC
    vs_vmc: dict | None
    spearman_rho: float | None
    spearman_rho_best: float | None  # the most negative rho the bins' success rates allow (ties bound it)
    auroc: float | None
    wall_s: float | None
    complete: bool

    @property
    def above_bvmc(self) -> bool | None:
        return None if self.min_unc is None or self.bvmc is None else self.min_unc > self.bvmc

    @property
    def above_vmc(self) -> bool | None:
        return None if self.min_unc is None or self.vmc is None else self.min_unc > self.vmc

    @property
    def rho_met(self) -> bool | None:
        return None if self.spearman_rho is None else self.spearman_rho <= RHO_GOAL

    @property
    def wall_time_met(self) -> bool | None:
        return None if self.wall_s is None or not self.complete else self.wall_s <= WALL_TIME_GOAL_S

    def as_dict(self) -> dict:
        out = {name: getattr(self, name) for name in self.__dataclass_fields__}
        for name in ("above_bvmc", "above_vmc", "rho_met", "wall_time_met"):
            out[name] = getattr(self, name)
        return out


def load_results(path: Path) -> dict:
    """A study's results JSON, checked for the fields the summary reads."""
    if not path.is_file():
        raise ResultsError(f"{path} does not exist: run `lerobot-ivmc-pipeline --task=<task>` first.")
    try:
        results = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise ResultsError(f"{path} is not valid JSON ({error}).") from error
    missing = [key for key in ("task", "rows", "per_fc") if key not in results]
    if missing:
        raise ResultsError(f"{path} is not a study's results JSON (no {', '.join(missing)}).")
    return results


def find_results(results_dir: Path) -> list[Path]:
    """The `<task>.json` files of the known tasks in `results_dir`, in the paper's task order."""
    if not results_dir.is_dir():
        raise ResultsError(f"--results_dir {results_dir} is not a folder.")
    paths = [results_dir / f"{task}.json" for task in TASKS if (results_dir / f"{task}.json").is_file()]
    if not paths:
        raise ResultsError(f"{results_dir} holds none of {', '.join(f'{t}.json' for t in TASKS)}.")
    return paths


def main_rows(results: dict) -> list[dict]:
    """The Table I rows: the main training seed's (the study keeps extra seeds' under `training_seeds`)."""
    return results["rows"]


def goal_checks(results: dict) -> list[GoalCheck]:
    """One `GoalCheck` per #fc of the study."""
    checks = []
    rows = main_rows(results)
    for fc in sorted({row["num_fc_layers"] for row in rows}):
        by_method = {row["method"]: row for row in rows if row["num_fc_layers"] == fc}
        milestone = list(next(iter(by_method.values()))["subtasks"])[-1]

        def rate(method: str, milestone: str = milestone, by_method: dict = by_method) -> float | None:
            row = by_method.get(method)
            return None if row is None else row["subtasks"][milestone]["rate"]

        paired = by_method.get("min_unc", {}).get("paired", {})
        per_fc = results["per_fc"].get(str(fc), {})
        fig3 = per_fc.get("fig3", {})
        best = (
            most_negative_rho(fig3["mean_u"], fig3["success_rate"])
            if "mean_u" in fig3 and "success_rate" in fig3
            else None
        )
        checks.append(
            GoalCheck(
                task=results["task"],
                num_fc_layers=fc,
                milestone=milestone,
                vmc=rate("vmc"),
                bvmc=rate("none"),
                min_unc=rate("min_unc"),
                vs_bvmc=paired.get("vs_none"),
                vs_vmc=paired.get("vs_vmc"),
                spearman_rho=finite(fig3.get("spearman_rho")),
                spearman_rho_best=finite(best),
                auroc=per_fc.get("detection", {}).get("auroc"),
                wall_s=results.get("total_wall_s"),
                complete=bool(results.get("complete")),
            )
        )
    return checks


def training_noise(results: dict, checks: list[GoalCheck]) -> list[dict]:
    """Per #fc with extra training seeds (`checks`: the study's `goal_checks`): VMC's and BVMC's
    last-milestone rate per seed, and min unc's (main seed) with whether it is above every seed's VMC and
    BVMC."""
    seed_rows = results.get("training_seeds", {}).get("rows", [])
    lines = []
    for check in checks:
        per_model: dict[str, dict[int, float]] = {"VMC": {}, "BVMC": {}}
        for row in seed_rows:
            if row["num_fc_layers"] == check.num_fc_layers and row["model"] in per_model:
                per_model[row["model"]][row["train_seed"]] = row["subtasks"][check.milestone]["rate"]
        if not any(len(rates) > 1 for rates in per_model.values()):
            continue
        no_recovery = [*per_model["VMC"].values(), *per_model["BVMC"].values()]
        lines.append(
            {
                "task": check.task,
                "num_fc_layers": check.num_fc_layers,
                "milestone": check.milestone,
                "vmc_per_seed": per_model["VMC"],
                "bvmc_per_seed": per_model["BVMC"],
                "min_unc": check.min_unc,
                "min_unc_above_every_seed": None
                if check.min_unc is None
                else check.min_unc > max(no_recovery),
            }
        )
    return lines


# The goal of recovery that rescues: of the failures of the same policy without recovery, at least this
# share rescued net of those lost, with a paired test below `RESCUE_P`.
RESCUE_GOAL = 0.5
RESCUE_P = 0.05


def rescue_goal_met(rate: float | None, p: float, method: str = "") -> bool | None:
    """The rescue goal's verdict (None: no failures to rescue, or a control row, which no goal is set for)."""
    return None if rate is None or method in CONTROL_ROWS else rate >= RESCUE_GOAL and p < RESCUE_P


def rescue_lines(results: dict) -> list[dict]:
    """Per #fc and recovery mode: the rescue over every training seed whose chain ended (the study's pooled
    record) or, in a study without extra seeds, the main seed's; with the goal's verdict."""
    pooled = results.get("training_seeds", {}).get("pooled_rescue")
    if pooled:
        records = [{**r, "p": r["exact_p"]} for r in pooled]
    else:
        records = [
            {
                "num_fc_layers": row["num_fc_layers"],
                "method": row["method"],
                "train_seeds": [row["train_seed"]],
                **row["rescue"],
                "p": row["rescue"]["mcnemar_exact_p"],
            }
            for row in main_rows(results)
            if "rescue" in row
        ]
    lines = []
    for record in records:
        rate = record["rescue_rate"]
        lines.append(
            {
                "task": results["task"],
                "num_fc_layers": record["num_fc_layers"],
                "method": record["method"],
                "train_seeds": record["train_seeds"],
                "failures": record["failures"],
                "flagged": record["flagged"],
                "rescued": record["rescued"],
                "lost": record["lost"],
                "rescue_rate": rate,
                "p": record["p"],
                "goal_met": rescue_goal_met(rate, record["p"], record["method"]),
            }
        )
    return lines


def pooled_over_tasks(lines: list[dict]) -> list[dict]:
    """Per #fc and recovery mode present in more than one task: the rescue counts summed over the tasks'
    lines (each a task's seeds pooled already), with the exact test of rescued against lost and the goal's
    verdict; task "all tasks"."""
    pooled = []
    for key in dict.fromkeys((line["num_fc_layers"], line["method"]) for line in lines):
        group = [line for line in lines if (line["num_fc_layers"], line["method"]) == key]
        if len({line["task"] for line in group}) < 2:
            continue
        summed = summed_rescue(group)
        p = summed.pop("exact_p")
        pooled.append(
            {
                "task": "all tasks",
                "num_fc_layers": key[0],
                "method": key[1],
                "train_seeds": sorted({seed for line in group for seed in line["train_seeds"]}),
                **summed,
                "p": p,
                "goal_met": rescue_goal_met(summed["rescue_rate"], p, key[1]),
            }
        )
    return pooled


def rescue_table(lines: list[dict]) -> str:
    """One line per task, #fc and recovery mode."""
    table = [
        f"| task | #fc | mode | training seeds | failures (flagged) | rescued / lost | rescue rate | p | "
        f">= {RESCUE_GOAL:.0%} with p < {RESCUE_P} |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for line in lines:
        table.append(
            f"| {line['task']} | {line['num_fc_layers']} | {line['method']} | "
            f"{', '.join(map(str, line['train_seeds']))} | {rescue_cells(line)} | {line['p']:.2g} | "
            f"{_verdict(line['goal_met'])} |"
        )
    return "\n".join(table)


def noise_table(lines: list[dict]) -> str:
    """One line per task and #fc with extra training seeds."""

    def per_seed(rates: dict[int, float]) -> str:
        return ", ".join(f"{rate:.0f} (seed {seed})" for seed, rate in rates.items()) or "-"

    table = [
        "| task | #fc | milestone | VMC [%] per training seed | BVMC [%] per training seed | min unc [%] "
        "(main seed) | above every seed's VMC and BVMC |",
        "|---|---|---|---|---|---|---|",
    ]
    for line in lines:
        table.append(
            f"| {line['task']} | {line['num_fc_layers']} | {line['milestone']} | "
            f"{per_seed(line['vmc_per_seed'])} | {per_seed(line['bvmc_per_seed'])} | "
            f"{_pc(line['min_unc'])} | {_verdict(line['min_unc_above_every_seed'])} |"
        )
    return "\n".join(table)


def _verdict(value: bool | None) -> str:
    return "-" if value is None else ("met" if value else "**not met**")


def _paired(counts: dict | None) -> str:
    if counts is None:
        return "-"
    return f"{counts['only_second']} / {counts['only_first']}, p {counts['mcnemar_exact_p']:.2f}"


def _pc(value: float | None) -> str:
    return "-" if value is None else f"{value:.0f}"


def table_i(results: dict) -> str:
    """The study's Table I rows in the paper's layout: per #fc, each subtask's rate (the paper's value)."""
    rows = main_rows(results)
    subtasks = list(rows[0]["subtasks"])
    lines = [
        f"### {results['task']}",
        "",
        "| model | #fc | " + " | ".join(f"{s} [%] (paper)" for s in subtasks) + " |",
        "|---|---|" + "---|" * len(subtasks),
    ]
    for row in rows:
        cells = []
        for subtask in subtasks:
            ours = row["subtasks"][subtask]
            paper = row.get("paper", {}).get(subtask)
            cell = f"{ours['rate']:.0f} +- {ours['stderr']:.1f}"
            cells.append(cell + (f" ({paper['rate']:.0f})" if paper else ""))
        lines.append(f"| {row['label']} | {row['num_fc_layers']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def goals_table(checks: list[GoalCheck]) -> str:
    """One line per task and #fc: the goals, each with its figures and verdict."""
    lines = [
        "| task | #fc | milestone | VMC / BVMC / min unc [%] | min unc > BVMC (gained / lost, p) | "
        "min unc > VMC (gained / lost, p) | Fig. 3 rho <= -0.8 | AUROC | study <= 3 h |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for c in checks:
        rho = "-" if c.spearman_rho is None else f"{c.spearman_rho:.2f}: {_verdict(c.rho_met)}"
        if c.spearman_rho is not None and c.spearman_rho_best is not None:
            rho += f" (best attainable {c.spearman_rho_best:.2f})"
        auroc = "-" if c.auroc is None else f"{c.auroc:.3f}"
        wall = "-" if c.wall_s is None else f"{c.wall_s / 3600:.2f} h: {_verdict(c.wall_time_met)}"
        if c.wall_s is not None and not c.complete:
            wall = f"{c.wall_s / 3600:.2f} h so far"
        rates = f"{_pc(c.vmc)} / {_pc(c.bvmc)} / {_pc(c.min_unc)}"
        above_bvmc = f"{_verdict(c.above_bvmc)} ({_paired(c.vs_bvmc)})"
        above_vmc = f"{_verdict(c.above_vmc)} ({_paired(c.vs_vmc)})"
        lines.append(
            f"| {c.task} | {c.num_fc_layers} | {c.milestone} | {rates} | {above_bvmc} | {above_vmc} | "
            f"{rho} | {auroc} | {wall} |"
        )
    return "\n".join(lines)


def summarize(paths: list[Path]) -> tuple[str, dict]:
    """Markdown and JSON of the reproduction over the given results files."""
    studies = [load_results(path) for path in paths]
    checks_per_study = [goal_checks(study) for study in studies]
    checks = [check for study_checks in checks_per_study for check in study_checks]
    noise = [
        line
        for study, study_checks in zip(studies, checks_per_study, strict=True)
        for line in training_noise(study, study_checks)
    ]
    noise_section = (
        [
            "## Training noise: the rate without recovery per training seed",
            noise_table(noise),
        ]
        if noise
        else []
    )
    rescues = [line for study in studies for line in rescue_lines(study)]
    rescues += pooled_over_tasks(rescues)
    rescue_section = (
        [
            "## Recovery that rescues: BVMC's failures rescued net of those lost, per mode (pooled over the "
            'training seeds, and over the tasks in the lines "all tasks", exact matched-pairs test)',
            rescue_table(rescues),
        ]
        if rescues
        else []
    )
    markdown = "\n\n".join(
        [
            "# The reproduction: Table I and the goals",
            "## Goals per task and #fc",
            goals_table(checks),
            *rescue_section,
            *noise_section,
            "## Table I (main training seed; the paper's value in brackets)",
            *[table_i(study) for study in studies],
        ]
    )
    summary = {
        "studies": [
            {"task": s["task"], "preset": s.get("preset"), "complete": s.get("complete"), "file": str(p)}
            for s, p in zip(studies, paths, strict=True)
        ],
        "goals": [check.as_dict() for check in checks],
        "training_noise": noise,
        "rescue": rescues,
    }
    return markdown + "\n", summary


MARKDOWN_FILE = "reproduction.md"
JSON_FILE = "reproduction.json"


@dataclass
class SummaryConfig:
    """Args:
    results_dir: the folder holding the studies' `<task>.json` files.
    results: instead of `results_dir`, the studies' results JSONs by path (any names, one per task).
    output_dir: where reproduction.md and reproduction.json go; default: `results_dir`, or the folder of
        the first of `results`.
    """

    results_dir: Path | None = None
    results: list[Path] = field(default_factory=list)
    output_dir: Path | None = None


def given_results(paths: list[Path]) -> list[Path]:
    """`paths` in the paper's task order, refused where a task comes twice."""
    tasks = [load_results(Path(path))["task"] for path in paths]
    twice = sorted({task for task in tasks if tasks.count(task) > 1})
    if twice:
        raise ResultsError(f"--results holds more than one study of {', '.join(twice)}: give one per task.")
    order = {task: index for index, task in enumerate(TASKS)}
    return [
        Path(path) for _, path in sorted(zip(tasks, paths, strict=True), key=lambda p: order.get(p[0], 99))
    ]


def write_summary(cfg: SummaryConfig) -> tuple[Path, Path]:
    if (cfg.results_dir is None) == (not cfg.results):
        raise ValueError(
            "Give --results_dir=<folder with the studies' <task>.json files> or "
            "--results='[<a study's results JSON>,...]', not both."
        )
    paths = given_results(cfg.results) if cfg.results else find_results(Path(cfg.results_dir))
    markdown, summary = summarize(paths)
    out = Path(cfg.output_dir or cfg.results_dir or paths[0].parent)
    out.mkdir(parents=True, exist_ok=True)
    (out / MARKDOWN_FILE).write_text(markdown)
    (out / JSON_FILE).write_text(json.dumps(summary, indent=2))
    return out / MARKDOWN_FILE, out / JSON_FILE
