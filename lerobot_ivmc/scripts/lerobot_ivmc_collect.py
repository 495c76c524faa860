"""`lerobot-ivmc-collect`: record N successful expert demonstrations of a task as a LeRobotDataset.

Example, in LeRobot's draccus style (`lerobot-record`'s `--dataset.*`; the flags are those of
`record_config.RecordDemosConfig`, listed by ``--help``)::

    lerobot-ivmc-collect --env.task=pick_place --dataset.num_episodes=1000 \\
        --dataset.root=data/ivmc_pick_place --dataset.repo_id=local/ivmc_pick_place --num_workers=2 --seed=0

The short flags of earlier versions (``--task pick_place --num-episodes 1000``) are refused in one line that
names the flag replacing each.

Attempt k replays the scene drawn by seed `attempt_seed(seed, k)` from the `--env.split` scenes; the
dataset keeps the successful attempts in attempt order, so the same arguments always give the same episodes.
Workers record attempts in parallel and stage each one durably; this process assembles the staged episodes
in order into a LeRobotDataset with LeRobot's own writer. Killed at any moment and rerun with the same
arguments, it continues from what was staged (see `lerobot_ivmc.datasets.staging`). One collector writes a
root at a time (`lerobot_ivmc.datasets.root_lock`), and a dataset is called complete only after its data
and metadata are checked to agree (`lerobot_ivmc.datasets.verify`).

Where the scene setup is recorded: every frame carries `scene.seed`, `scene.object_cell` and
`scene.target_cell`; `meta/ivmc_collection.json` holds the collection spec (task, scene split, base seed,
image size, features) and each episode's attempt index and scene. (LeRobot's own `info.json` "splits"
entry is its episode range, always "train", unrelated to the scene split.)

Called from Python, `collect_demos` starts its workers with a fork server, so the calling script needs the
usual ``if __name__ == "__main__":`` guard.
"""

from __future__ import annotations

import logging
import sys
from typing import NoReturn

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.collect import collect_demos
from lerobot_ivmc.datasets.collect_config import CollectConfig
from lerobot_ivmc.datasets.record_config import RecordDemosConfig, short_flag_replacements

logger = logging.getLogger(__name__)

PROG = "lerobot-ivmc-collect"


def _refuse(message: str) -> NoReturn:
    """End the command on a bad command line as argparse does: one line on stderr, exit status 2."""
    print(message, file=sys.stderr)
    raise SystemExit(2)


def parse_config(argv: list[str]) -> CollectConfig:
    """The command line, in LeRobot's draccus style (`record_config.RecordDemosConfig`; ``--help`` lists it),
    as a validated `CollectConfig`. A short flag of earlier versions, an unknown flag or a bad value ends the
    command with one line and exit status 2."""
    import draccus
    from draccus.utils import DecodingError, ParsingError

    replacements = short_flag_replacements(argv)
    if replacements:
        uses = ", ".join(f"{new} instead of {old}" for new, old in replacements)
        _refuse(f"{PROG} takes LeRobot's flags: use {uses} ({PROG} --help lists them).")
    try:
        return draccus.parse(config_class=RecordDemosConfig, args=argv, prog=PROG).to_collect_config()
    except (ValueError, ParsingError, DecodingError) as error:
        _refuse(f"{PROG}: error: {error}")


def main(argv: list[str] | None = None) -> int:
    """Console entry point of `lerobot-ivmc-collect`."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(asctime)s %(name)s: %(message)s")
    cfg = parse_config(sys.argv[1:] if argv is None else argv)
    try:
        summary = collect_demos(cfg)
    except (ValueError, staging.CollectionError) as error:
        logger.error("%s", error)
        return 2
    except KeyboardInterrupt:
        logger.warning("Interrupted: staged episodes are kept; rerun the same command to resume.")
        return 130
    status = "already complete" if summary.already_complete else f"{summary.elapsed_s:.1f} s"
    print(
        f"{summary.num_episodes} {summary.task} demos ({summary.num_frames} frames, {summary.split} scenes) "
        f"in {summary.root} as {summary.repo_id}: {summary.attempts} attempts, {summary.failed_attempts} "
        f"failed, {summary.resumed_episodes} resumed from staging; {status}"
        + ("; pushed to the hub" if summary.pushed else "")
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
