"""`lerobot-ivmc-summary`: the reproduction across tasks, Table I next to the paper's and the goals checked.

    lerobot-ivmc-summary --results_dir=docs/results [--output_dir=docs]

Reads the `<task>.json` of each task's study in `results_dir` (what `lerobot-ivmc-pipeline` writes to
`<out>/results/`; copy them into one folder) and writes `reproduction.md` and `reproduction.json` to
`output_dir` (default: `results_dir`): per task and #fc, BVMC + min unc against BVMC and VMC on the task's
last milestone (paired scene counts, McNemar's p), Fig. 3's Spearman rho against -0.8, the AUROC of the
maximum uncertainty, and the study's wall time against 3 hours; then each task's Table I rows.
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.

from lerobot.configs import parser

from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.pipeline.reproduction import SummaryConfig, write_summary


@parser.wrap()
def summary_main(cfg: SummaryConfig) -> None:
    markdown_path, json_path = write_summary(cfg)
    print(markdown_path.read_text())
    print(f"Written: {markdown_path}, {json_path}")


def main() -> None:
    cli_main(summary_main)


if __name__ == "__main__":
    main()
