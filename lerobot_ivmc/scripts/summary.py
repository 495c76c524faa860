"""`lerobot-ivmc-summary`: the reproduction across tasks, Table I next to the paper's and the goals checked.

    lerobot-ivmc-summary --results_dir=docs/results [--output_dir=docs]

Reads the `<task>.json` of each task's study in `results_dir` (what `lerobot-ivmc-pipeline` writes to
`<out>/results/`; copy them into one folder) and writes `reproduction.md` and `reproduction.json` to
`output_dir` (default: `results_dir`): per task and #fc, BVMC + min unc against BVMC and VMC on the task's
last milestone (paired scene counts, McNemar's p), Fig. 3's Spearman rho against -0.8, the AUROC of the
maximum uncertainty, and the study's wall time against 3 hours; then each task's Table I rows.
"""

import json
from dataclasses import dataclass
from pathlib import Path

from lerobot.configs import parser

from lerobot_ivmc.pipeline.summary import find_results, summarize
from lerobot_ivmc.scripts.errors import cli_main

MARKDOWN_FILE = "reproduction.md"
JSON_FILE = "reproduction.json"


@dataclass
class SummaryConfig:
    """Args:
    results_dir: the folder holding the studies' `<task>.json` files.
    output_dir: where reproduction.md and reproduction.json go; default: `results_dir`.
    """

    results_dir: Path | None = None
    output_dir: Path | None = None


def write_summary(cfg: SummaryConfig) -> tuple[Path, Path]:
    if cfg.results_dir is None:
        raise ValueError("Give --results_dir=<folder with the studies' <task>.json files>.")
    markdown, summary = summarize(find_results(Path(cfg.results_dir)))
    out = Path(cfg.output_dir or cfg.results_dir)
    out.mkdir(parents=True, exist_ok=True)
    (out / MARKDOWN_FILE).write_text(markdown)
    (out / JSON_FILE).write_text(json.dumps(summary, indent=2))
    return out / MARKDOWN_FILE, out / JSON_FILE


@parser.wrap()
def summary_main(cfg: SummaryConfig) -> None:
    markdown_path, json_path = write_summary(cfg)
    print(markdown_path.read_text())
    print(f"Written: {markdown_path}, {json_path}")


def main() -> None:
    cli_main(summary_main)


if __name__ == "__main__":
    main()
