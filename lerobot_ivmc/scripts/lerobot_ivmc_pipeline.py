"""`lerobot-ivmc-pipeline`: one task's whole study, from nothing to Table I, Fig. 3 and detection metrics.

    lerobot-ivmc-pipeline --task=push --preset=lite [--output_dir=...] [--train.steps=4000 ...]
    lerobot-ivmc-pipeline --task=[push,pick_place,pick_reach] --preset=lite --executor.type=ray

Presets are `lerobot_ivmc/pipeline/presets/<preset>.yaml` (smoke, lite, paper; shipped with the package);
any field can be overridden with the draccus flags of `PipelineConfig` (a field that does not exist is
refused). Rerun the same command to resume: finished stages are skipped, a killed stage is continued where
it can be (demo collection, a training from its last checkpoint) or redone, and a changed stage reruns with
everything after it. Results: `<output_dir>/results/` (`<task>.json`, `table.md`, plots, videos), written as
each #fc finishes (and as each extra training seed's evaluations do, `--train.extra_seeds=[2000]`).
With `--regime.demo_budgets=[...]` (or `--regime.train_steps=[...]`) the study first chooses its number of
demos (or training steps) by the data-budget rule (`lerobot_ivmc/pipeline/regime.py`) and runs in
`<output_dir>/demos<n>/` (or `steps<n>/`). Several tasks make one study each
(`<output_dir>/<task>`), one after the other, or side by side on one Ray cluster with `--executor.type=ray`.
"""

import sys

from lerobot_ivmc.cli import run_cli
from lerobot_ivmc.pipeline.regime import run_regime
from lerobot_ivmc.pipeline.runner import PipelineError
from lerobot_ivmc.pipeline.study import parse_config, run_pipeline, run_studies, split_tasks


def main(argv: list[str] | None = None) -> None:
    """Console entry point: bad input exits 2 with one line; a failed stage exits 1 naming its log."""
    argv = sys.argv[1:] if argv is None else argv

    def run_study(cfg, log) -> dict:
        if cfg.regime.budget:
            return run_regime(cfg, lambda study: run_pipeline(study, log), log)
        return run_pipeline(cfg, log)

    def run() -> None:
        cfgs = [parse_config(study) for study in split_tasks(argv)]  # every study's flags checked first
        try:
            run_studies(cfgs, run_study)
        except PipelineError as error:
            print(f"error: {error}", file=sys.stderr)
            sys.exit(1)

    run_cli(run)


if __name__ == "__main__":
    main()
