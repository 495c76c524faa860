"""`lerobot-ivmc-perception`: did a trained policy learn where the object is? A check in seconds, run
before hours of foresight distillation and evaluations are spent on a policy that did not.

A vmc or bvmc network predicts the object's position with an auxiliary head. On each of `--n_scenes`
scenes (seeds `seed`, `seed + 1`, ... of `--env.split`) it measures, over the episode's first `--steps`
steps, how far that estimate is from the true position (cm), twice: watching the scripted expert act (the
demos' distribution) and acting itself (closed loop, what the evaluations see). The scene's error is the
median over its steps, the policy's the median over scenes.

Some training runs never learn to find the object on their own (docs/archive/RESULTS_superseded.md,
"pick_place: the perception check (which training runs learned where the cube is)": a second training
seed of the lite recipe, acting error 12.5-15.5 cm against 0.9-2.0 for the runs that learned; it placed in
2-9% of test scenes). With `--max_object_error_cm` > 0 the record says whether the acting error stays
within it, and the command exits 1 when it does not (after writing its record; `--fail_above_limit=false`
only records the verdict), so a pipeline stops there.

    lerobot-ivmc-perception --policy.path=<checkpoint> --env.type=ivmc --env.task=pick_place \\
        --env.split=val --n_scenes=20 --seed=0 --output_dir=outputs/perception
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.
import sys
from pathlib import Path

from lerobot.configs import parser

from lerobot_ivmc.atomic_files import write_json_atomic
from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.evaluation.perception_check import (
    DRIVERS,
    RECORD_FILE,
    PerceptionCheckConfig,
    check_perception,
    failure_message,
)


@parser.wrap()
def perception_main(cfg: PerceptionCheckConfig) -> dict:
    record = check_perception(cfg)
    out = Path(cfg.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / RECORD_FILE, record, indent=1)
    for driver in DRIVERS:
        m = record[driver]
        print(
            f"{driver}: object {m['object_cm']:.2f} cm, grip {m['grip_cm']:.2f} cm (median of scene medians)"
        )
    print(f"wrote {out / RECORD_FILE}")
    if record["passed"] is False and cfg.fail_above_limit:
        sys.exit(failure_message(record, out / RECORD_FILE))
    return record


def main() -> None:
    cli_main(perception_main)


if __name__ == "__main__":
    main()
