"""A study from its config: the preset and flags parsed into a `PipelineConfig`, and the stages run (or
resumed) in the study's folder with the results written as they grow; the library of
`lerobot-ivmc-pipeline` (`scripts/lerobot_ivmc_pipeline.py`)."""

from __future__ import annotations

import json
import time

import draccus

from lerobot_ivmc.pipeline.config import PRESETS_DIR, PipelineConfig
from lerobot_ivmc.pipeline.results import RESULTS_DIR, adds_results, write_results
from lerobot_ivmc.pipeline.runner import StageResult, claim_root, run_stages, study_lock
from lerobot_ivmc.pipeline.stages import build_stages


def available_presets() -> list[str]:
    return sorted(p.stem for p in PRESETS_DIR.glob("*.yaml"))


def parse_config(argv: list[str]) -> PipelineConfig:
    """The preset named by `--preset` (default lite) with the other flags applied on top."""
    preset, rest = "lite", []
    for i, arg in enumerate(argv):
        if arg.startswith("--preset="):
            preset = arg.split("=", 1)[1]
        elif arg == "--preset" and i + 1 < len(argv):
            preset = argv[i + 1]
        elif not (i > 0 and argv[i - 1] == "--preset"):
            rest.append(arg)
    path = PRESETS_DIR / f"{preset}.yaml"
    if not path.is_file():
        raise ValueError(
            f"Unknown preset {preset!r}: choose --preset from {available_presets()} ({PRESETS_DIR})."
        )
    cfg = draccus.parse(config_class=PipelineConfig, config_path=path, args=rest)
    if not cfg.task:
        raise ValueError("Give the task: --task=push|pick_place|pick_reach.")
    cfg.preset = preset
    return cfg


def run_pipeline(cfg: PipelineConfig, log=print) -> dict:
    """Run (or resume) the study; returns the results JSON."""
    root = cfg.root
    claim_root(root, {"task": cfg.task, "preset": cfg.preset})
    stages = build_stages(cfg)
    start = time.perf_counter()
    out = root / RESULTS_DIR

    def write_when_results_grow(timings: list[StageResult]) -> None:
        if adds_results(cfg, timings):
            write_results(cfg, stages, timings)
            log(f"Results so far in {out}")

    with study_lock(root):
        timings = run_stages(root, stages, log, on_stage_end=write_when_results_grow)
    log(f"\nStage wall times ({cfg.task}, preset {cfg.preset}; skipped stages show their earlier time):")
    for t in timings:
        log(f"  {t.name:<28} {t.status:<8} {t.wall_s:8.0f} s")
    log(f"  {'this run':<28} {'':<8} {time.perf_counter() - start:8.0f} s")
    log(f"\n{(out / 'table.md').read_text()}\nResults in {out}")
    return json.loads((out / f"{cfg.task}.json").read_text())
