"""`lerobot-ivmc-pool-seeds`: training seeds run as separate studies (other machines, other sessions) pooled
into one results JSON, as one study with `--train.extra_seeds` would have written it.

    lerobot-ivmc-pool-seeds --results='[run_a/results/push.json,run_b/results/push.json]' \
        --output=docs/results/push_training_seeds.json

Each study is a `lerobot-ivmc-pipeline` run of the same task, preset and setup with its own `--train.seed`
(or `--train.extra_seeds`). The output holds the first study's Table I rows and figures, and under
`training_seeds` every seed's rows, their mean and standard deviation, and each recovery mode's rescue
pooled over the seeds with its exact test (docs/pipeline.md, "The study pipeline: Table I and Fig. 3 in one
command"); the markdown goes beside it.
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.

import json
from pathlib import Path

from lerobot.configs import parser

from lerobot_ivmc.atomic_files import write_json_atomic
from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.pipeline.seed_pool import PoolSeedsConfig, pool_studies, seeds_markdown


@parser.wrap()
def pool_seeds_main(cfg: PoolSeedsConfig) -> None:
    cfg.validate()
    studies = {str(path): json.loads(Path(path).read_text()) for path in cfg.results}
    pooled, notes = pool_studies(studies)
    output = Path(cfg.output)
    output.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(output, pooled)
    markdown = seeds_markdown(pooled)
    output.with_suffix(".md").write_text(markdown)
    print(markdown)
    for note in notes:
        print(f"Note: {note}")
    print(f"Written: {output}, {output.with_suffix('.md')}")


def main() -> None:
    cli_main(pool_seeds_main)


if __name__ == "__main__":
    main()
