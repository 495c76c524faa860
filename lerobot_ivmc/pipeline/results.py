"""The study's results in the layout of the paper's Table I: JSON for programs, markdown for people, the
Fig. 3 plot and detection metrics per #fc, a few recovery videos, the training seeds' spread and each
policy's perception check, gathered in `<root>/results/`."""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import asdict
from pathlib import Path

from lerobot_ivmc.atomic_files import write_json_atomic
from lerobot_ivmc.evaluation.compare import EVAL_INFO_FILE, paired_outcomes, rescue_record
from lerobot_ivmc.evaluation.perception_check import DRIVERS as PERCEPTION_DRIVERS
from lerobot_ivmc.evaluation.success_by_uncertainty import most_negative_rho
from lerobot_ivmc.pipeline.config import PipelineConfig
from lerobot_ivmc.pipeline.paper_table import PAPER_TABLE
from lerobot_ivmc.pipeline.recovery_choice import CHOSEN, chain_choice, no_recovery_record
from lerobot_ivmc.pipeline.runner import StageResult
from lerobot_ivmc.pipeline.seed_pool import WITHOUT_RECOVERY, spread_over_seeds, study_setup
from lerobot_ivmc.pipeline.stage_names import (
    detect_stage_name,
    eval_stage_name,
    fig3_stage_name,
    perception_stage_name,
    threshold_stage_name,
    train_stage_name,
)
from lerobot_ivmc.pipeline.stages import PERCEPTION_RECORD, Stage, find_stage, stage_output
from lerobot_ivmc.pipeline.tables import (
    METHOD_LABELS,
    markdown_table,
    perception_table,
    pooled_rescue_table,
    row_label,
    training_seed_table,
)
from lerobot_ivmc.recovery.threshold import ThresholdRecord

RESULTS_DIR = "results"
# The data-budget rule's record (`pipeline/regime.py`), in the chosen study's results folder.
REGIME_FILE = "regime.json"
MAX_VIDEOS = 3


def table_rows(cfg: PipelineConfig, stages: list[Stage], fcs: list[int]) -> list[dict]:
    """One row per (#fc, method) for the #fc values `fcs`: each subtask's rate, standard error and n, and
    the recoveries."""
    rows = []
    for fc in fcs:
        infos = {
            method: load_eval_info(stage_output(stages, eval_row_stage(fc, method)))
            for method in table_methods(cfg)
        }
        for method, info in infos.items():
            row = {
                "task": cfg.task,
                "model": "VMC" if method == "vmc" else "BVMC",
                "num_fc_layers": fc,
                "method": method,
                "label": row_label(method),
                "train_seed": cfg.train.seed,
                "subtasks": subtask_rates(info),
                "paper": {
                    sub: {"rate": v[0], "stderr": v[1]}
                    for sub, v in PAPER_TABLE.get(cfg.task, {}).get(fc, {}).get(method, {}).items()
                },
            }
            success = list(row["subtasks"])[-1]
            if method not in ("vmc", "none") and "recovery" in info:
                row["recoveries"] = info["recovery"]["num_recoveries"]
                row["episodes_with_recovery"] = info["recovery"]["episodes_with_recovery"]
                row["threshold"] = info["recovery"]["threshold"]
                if "none" in infos:
                    row["rescue"] = rescue_record(infos["none"], info, success)
            # The rows saw the same scenes: paired task outcomes against VMC and BVMC (exact McNemar).
            row["paired"] = {
                f"vs_{other}": paired_outcomes(infos[other], info, success)
                for other in ("vmc", "none")
                if other in infos and other != method
            }
            rows.append(row)
        if cfg.recovery_choice:
            rows.append(chosen_row(rows, chain_choice(cfg, stages, fc, None), fc, infos["none"]))
    return rows


def chosen_row(rows: list[dict], choice: dict, fc: int, bvmc: dict) -> dict:
    """The row "chosen": the test row of the mode `choice` chose on validation scenes, with the choice;
    where it chose "none", BVMC's own test episodes `bvmc` (an eval info), nothing rescued or lost."""
    mode = choice["chosen_mode"]
    if mode == "none":
        success = list(bvmc["aggregated_subtasks"])[-1]
        base = next(r for r in rows if r["num_fc_layers"] == fc)
        source = {k: base[k] for k in ("task", "num_fc_layers", "train_seed")} | {
            "model": "BVMC",
            "subtasks": subtask_rates(bvmc),
            "paired": {},
            "recoveries": 0,
            "episodes_with_recovery": 0,
            "rescue": no_recovery_record(bvmc, success),
        }
    else:
        source = next(r for r in rows if r["num_fc_layers"] == fc and r.get("method") == mode)
    label = f"{METHOD_LABELS[CHOSEN]}: {mode}"
    return {**source, "method": CHOSEN, "label": label, "paper": {}, "choice": choice}


def subtask_rates(info: dict) -> dict:
    """Each subtask's rate [%], standard error and n from an `eval_info.json`."""
    return {
        sub: {"rate": r["pc"], "stderr": r["stderr"], "n": r["n"]}
        for sub, r in info["aggregated_subtasks"].items()
    }


def chain_ended(cfg: PipelineConfig, fc: int, train_seed: int, ended: set[str]) -> bool:
    """Whether a training seed's chain of #fc `fc` has finished (its last stage is the detection)."""
    main = train_seed == cfg.train.seed
    return detect_stage_name(fc, None if main else train_seed) in ended


def training_seed_rows(
    cfg: PipelineConfig, stages: list[Stage], fcs: list[int], ended: set[str]
) -> tuple[list[dict], list[dict]]:
    """Every training seed's rows whose chain has ended, for the #fc values `fcs`.

    Returns:
        rows: VMC and BVMC without recovery per seed; recovery_rows: each recovery mode per seed, with its
        `rescue` against that seed's own BVMC (`seed_pool.spread_over_seeds` pools them).
    """
    rows, recovery_rows = [], []
    for fc in fcs:
        seeds = [s for s in cfg.train.seeds if chain_ended(cfg, fc, s, ended)]
        for method in table_methods(cfg):
            for train_seed in seeds:
                extra = None if train_seed == cfg.train.seed else train_seed
                info = load_eval_info(stage_output(stages, eval_row_stage(fc, method, extra)))
                row = {
                    "task": cfg.task,
                    "model": "VMC" if method == "vmc" else "BVMC",
                    "num_fc_layers": fc,
                    "train_seed": train_seed,
                    "subtasks": subtask_rates(info),
                }
                if method in WITHOUT_RECOVERY:
                    rows.append(row)
                    continue
                bvmc = load_eval_info(stage_output(stages, eval_row_stage(fc, "none", extra)))
                success = list(row["subtasks"])[-1]
                recovery_rows.append({**row, "method": method, "rescue": rescue_record(bvmc, info, success)})
        if cfg.recovery_choice:
            for train_seed in seeds:
                extra = None if train_seed == cfg.train.seed else train_seed
                own = [r for r in recovery_rows if r["num_fc_layers"] == fc and r["train_seed"] == train_seed]
                bvmc = load_eval_info(stage_output(stages, eval_row_stage(fc, "none", extra)))
                recovery_rows.append(chosen_row(own, chain_choice(cfg, stages, fc, extra), fc, bvmc))
    return rows, recovery_rows


def perception_rows(cfg: PipelineConfig, stages: list[Stage], ended: set[str]) -> list[dict]:
    """Per trained policy whose check has ended: how far its estimate of the object's position is from the
    truth on validation scenes (cm), watching the expert and acting, and whether it passed the limit."""
    rows = []
    for fc in cfg.train.num_fc_layers:
        for policy_type in cfg.train.policy_types:
            for train_seed in cfg.train.seeds:
                seed = None if train_seed == cfg.train.seed else train_seed
                name = perception_stage_name(train_stage_name(policy_type, fc, seed))
                if name not in ended:
                    continue
                record = json.loads((stage_output(stages, name) / PERCEPTION_RECORD).read_text())
                rows.append(
                    {
                        "model": policy_type.upper(),
                        "num_fc_layers": fc,
                        "train_seed": train_seed,
                        "scenes": len(record["scene_seeds"]),
                        "split": record["split"],
                        "steps": record["steps"],
                        **{driver: record[driver] for driver in PERCEPTION_DRIVERS},
                        "max_object_error_cm": record["max_object_error_cm"],
                        "passed": record["passed"],
                    }
                )
    return rows


def table_methods(cfg: PipelineConfig) -> list[str]:
    """The study's Table I rows: "vmc" (where it trains VMC), then each BVMC row of `recovery_modes`."""
    return [*(["vmc"] if cfg.train.vmc else []), *cfg.recovery_modes]


def load_eval_info(folder: Path) -> dict:
    return json.loads((folder / EVAL_INFO_FILE).read_text())


def eval_row_stage(fc: int, method: str, train_seed: int | None = None) -> str:
    """The eval stage of a Table I row: VMC, or BVMC with a recovery mode (of an extra training seed)."""
    if method == "vmc":
        return eval_stage_name("vmc", fc, None, train_seed)
    return eval_stage_name("bvmc", fc, method, train_seed)


def finished_fcs(cfg: PipelineConfig, timings: list[StageResult]) -> list[int]:
    """The #fc values whose Table I stages have all finished (the last of them is the detection)."""
    ended = {t.name for t in timings}
    return [fc for fc in cfg.train.num_fc_layers if detect_stage_name(fc) in ended]


def adds_results(cfg: PipelineConfig, timings: list[StageResult]) -> bool:
    """Whether the stage that ended last completes results: the detection that ends a chain."""
    return timings[-1].name.startswith("detect_fc")


def write_results(cfg: PipelineConfig, stages: list[Stage], timings: list[StageResult]) -> Path:
    """Write `<root>/results/`: `<task>.json`, `table.md`, Fig. 3 and detection plots, recovery videos, for
    every #fc whose stages have finished (`complete` in the JSON says whether that is all of them), so a
    study stopped midway keeps the results of its finished halves."""
    root = cfg.root
    out = root / RESULTS_DIR
    out.mkdir(parents=True, exist_ok=True)
    fcs = finished_fcs(cfg, timings)
    rows = table_rows(cfg, stages, fcs)
    per_fc = {}
    for fc in fcs:
        fig3_dir = stage_output(stages, fig3_stage_name(cfg, fc))
        fig3_info = load_eval_info(fig3_dir)
        fig3_png = out / f"fig3_fc{fc}.png"
        shutil.copyfile(fig3_dir / fig3_info["uncertainty_vs_success"]["plot"], fig3_png)
        detection_dir = stage_output(stages, detect_stage_name(fc))
        detection = json.loads((detection_dir / "detection.json").read_text())
        for plot in detection.get("plots", []):
            shutil.copyfile(detection_dir / plot, out / f"fc{fc}_{plot}")
        videos = (
            sorted(
                (stage_output(stages, eval_stage_name("bvmc", fc, "min_unc")) / "recovery_videos").glob(
                    "*.mp4"
                )
            )
            if "min_unc" in cfg.recovery_modes
            else []
        )
        for video in videos[:MAX_VIDEOS]:
            shutil.copyfile(video, out / f"fc{fc}_min_unc_{video.name}")
        binned = fig3_info["uncertainty_vs_success"]
        per_fc[str(fc)] = {
            "fig3": {
                "episodes": fig3_info["run"]["n_episodes"],
                "spearman_rho": finite(binned["spearman_rho"]),
                "spearman_rho_best": finite(most_negative_rho(binned["mean_u"], binned["success_rate"])),
                "mean_u": binned["mean_u"],
                "success_rate": binned["success_rate"],
                "count": binned["count"],
                "plot": fig3_png.name,
            },
            "detection": {
                **{k: detection[k] for k in ("episodes", "failures", "argmax", "conformal")},
                "auroc": finite(detection["auroc"]),
            },
            "videos": [f"fc{fc}_min_unc_{v.name}" for v in videos[:MAX_VIDEOS]],
            "threshold": threshold_record(stages, fc),
        }
    ended = {t.name for t in timings}
    seed_rows, seed_recovery_rows = (
        training_seed_rows(cfg, stages, fcs, ended) if cfg.train.extra_seeds else ([], [])
    )
    seed_summary, seed_pooled = spread_over_seeds(seed_rows, seed_recovery_rows)
    seeds_done = all(
        chain_ended(cfg, fc, train_seed, ended)
        for fc in cfg.train.num_fc_layers
        for train_seed in cfg.train.seeds
    )
    perception = perception_rows(cfg, stages, ended)
    payload = {
        "task": cfg.task,
        "preset": cfg.preset,
        "complete": fcs == cfg.train.num_fc_layers and seeds_done,
        "setup": study_setup(cfg),
        "rows": rows,
        "per_fc": per_fc,
        "perception": perception,
        **(
            {
                "training_seeds": {
                    "rows": seed_rows,
                    "summary": seed_summary,
                    "recovery_rows": seed_recovery_rows,
                    "pooled_rescue": seed_pooled,
                }
            }
            if cfg.train.extra_seeds
            else {}
        ),
        **({"regime": json.loads(regime.read_text())} if (regime := out / REGIME_FILE).is_file() else {}),
        "stage_wall_s": {t.name: round(t.wall_s, 1) for t in timings},
        "total_wall_s": round(sum(t.wall_s for t in timings), 1),
    }
    write_json_atomic(out / f"{cfg.task}.json", payload)
    pending = [fc for fc in cfg.train.num_fc_layers if fc not in fcs]
    status = f"\n(#fc = {', '.join(map(str, pending))} not finished yet)\n" if pending else ""
    lines = [f"# {cfg.task}, preset {cfg.preset}\n", markdown_table(rows), status]
    for fc, entry in per_fc.items():
        det, rho = entry["detection"], entry["fig3"]["spearman_rho"]
        rho_text = "n/a" if rho is None else f"{rho:.2f}"
        if rho is not None and entry["fig3"]["spearman_rho_best"] is not None:
            rho_text += (
                f" (the most negative its bins' rates allow: {entry['fig3']['spearman_rho_best']:.2f})"
            )
        auroc_text = "n/a" if det["auroc"] is None else f"{det['auroc']:.3f}"
        lines.append(
            f"\n#fc = {fc}: Fig. 3 over {entry['fig3']['episodes']} test episodes, Spearman rho {rho_text} "
            f"({entry['fig3']['plot']}); failure prediction AUROC {auroc_text} "
            f"({det['failures']} failures in {det['episodes']}).\n"
        )
    if seed_rows:
        waiting = sorted({s for s in cfg.train.extra_seeds if s not in {r["train_seed"] for r in seed_rows}})
        lines.append(
            "\n## Training seeds: every row's chain trained from each seed, the same test scenes\n\n"
            + training_seed_table(seed_rows + seed_recovery_rows, seed_summary)
            + pooled_rescue_table(seed_pooled)
            + (f"\n(training seeds {', '.join(map(str, waiting))} not evaluated yet)\n" if waiting else "")
        )
    if perception:
        lines.append(
            "\n## Perception check: did each policy learn where the object is? (median estimate errors)\n\n"
            + perception_table(perception)
        )
    (out / "table.md").write_text("".join(lines))
    return out


def threshold_record(stages: list[Stage], fc: int) -> dict | None:
    """The picked threshold with its validation episodes (seed, u, success), so it can be re-picked."""
    record = ThresholdRecord.load(find_stage(stages, threshold_stage_name(fc)).done_file.parent)
    return asdict(record) if record is not None else None


def finite(value: float | None) -> float | None:
    """None for NaN (undefined: one class only, or a constant), so the JSON stays standard."""
    return None if value is None or math.isnan(value) else value
