"""`lerobot-ivmc-pipeline`: one task's whole study, from nothing to Table I, Fig. 3 and detection metrics.

    lerobot-ivmc-pipeline --task=push --preset=lite [--output_dir=...] [--train.steps=4000 ...]

Presets are `lerobot_ivmc/pipeline/presets/<preset>.yaml` (smoke, lite, paper; shipped with the package);
any field can be overridden with the draccus flags of `PipelineConfig` (a field that does not exist is
refused). Rerun the same command to resume: finished stages are skipped, a killed stage is continued where
it can be (demo collection, a training from its last checkpoint) or redone, and a changed stage reruns with
everything after it. Results: `<output_dir>/results/` (`<task>.json`, `table.md`, plots, videos), written as
each #fc finishes (and as each extra training seed's evaluations do, `--train.extra_seeds=[2000]`).
With `--regime.demo_budgets=[...]` the study first chooses its number of demos by the data-budget rule
(`lerobot_ivmc/pipeline/regime.py`) and runs in `<output_dir>/demos<n>/`.
"""

from __future__ import annotations

import json
import sys
import time

import draccus

from lerobot_ivmc.pipeline.config import PRESETS_DIR, PipelineConfig
from lerobot_ivmc.pipeline.regime import run_regime
from lerobot_ivmc.pipeline.results import RESULTS_DIR, adds_results, write_results
from lerobot_ivmc.pipeline.runner import PipelineError, StageResult, claim_root, run_stages, study_lock
from lerobot_ivmc.pipeline.stages import build_stages
from lerobot_ivmc.scripts.errors import run_cli


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


def main(argv: list[str] | None = None) -> None:
    """Console entry point: bad input exits 2 with one line; a failed stage exits 1 naming its log."""
    argv = sys.argv[1:] if argv is None else argv

    def run() -> None:
        cfg = parse_config(argv)
        try:
            if cfg.regime.demo_budgets:
                run_regime(cfg, run_pipeline)
            else:
                run_pipeline(cfg)
        except PipelineError as error:
            print(f"error: {error}", file=sys.stderr)
            sys.exit(1)

    run_cli(run)


if __name__ == "__main__":
    main()
