"""MetaWorld's tasks pooled: each task's row "chosen" on validation scenes (per training seed, the mode and
trigger that know no task), its test rescue summed over the seeds, then over the tasks, with the exact
matched-pairs test of rescued against lost.

A task comes from a study's results JSON (`--study`, its per-seed rows "chosen") or from the per-task entry
of an earlier pooled record (`--record`, where a task's candidates ran outside its study):

python -m diagnostics.metaworld_pool \
    --study door-open-v3=<out>/results/door-open-v3.json \
    --record "pick-place-v3=<record>.json#pick-place-v3 (framed, 150 demos)" \
    --output docs/results/metaworld/<name>.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from lerobot_ivmc.pipeline.recovery_choice import CHOSEN
from lerobot_ivmc.pipeline.seed_pool import study_seed_rows, summed_rescue


def study_task(path: Path) -> dict:
    """A study's rows "chosen", one per training seed, summed: failures, rescued, lost, the chosen modes."""
    results = json.loads(path.read_text())
    _, recovery_rows = study_seed_rows(results)
    chosen = [r for r in recovery_rows if r["method"] == CHOSEN]
    if not chosen:
        raise ValueError(f"{path} has no row {CHOSEN!r}: run its study with --recovery_choice.")
    summed = summed_rescue([r["rescue"] for r in chosen])
    return {
        **{key: summed[key] for key in ("failures", "rescued", "lost")},
        "chosen": {str(r["train_seed"]): r["choice"]["chosen_mode"] for r in chosen},
        "source": str(path),
    }


def record_task(spec: str) -> dict:
    """`<record>.json#<task key>`: that task's entry of an earlier record's `pooled_chosen.per_task`."""
    path, key = spec.split("#", 1)
    entry = json.loads(Path(path).read_text())["pooled_chosen"]["per_task"][key]
    return {
        **{k: entry[k] for k in ("failures", "rescued", "lost")},
        "chosen": entry["chosen"],
        "source": spec,
    }


def with_test(record: dict) -> dict:
    summed = summed_rescue([{**record, "flagged": None}])
    return {**record, "rescue_rate": summed["rescue_rate"], "exact_p": summed["exact_p"]}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--study", action="append", default=[], help="NAME=<study>/results/<task>.json")
    parser.add_argument("--record", action="append", default=[], help="NAME=<record>.json#<task key>")
    parser.add_argument("--output", type=Path, required=True)
    args = parser.parse_args()
    if args.output.exists():
        raise SystemExit(f"{args.output} exists: remove it or write another --output.")
    per_task = {}
    for kind, specs in (("study", args.study), ("record", args.record)):
        for spec in specs:
            name, source = spec.split("=", 1)
            per_task[name] = with_test(study_task(Path(source)) if kind == "study" else record_task(source))
    total = summed_rescue([{**t, "flagged": None} for t in per_task.values()])
    del total["flagged"]
    pooled = {"per_task": per_task, "all_tasks": total}
    command = shlex.join(["python", "-m", "diagnostics.metaworld_pool", *sys.argv[1:]])
    args.output.write_text(json.dumps({"command": command, "pooled_chosen": pooled}, indent=1) + "\n")
    for name, task in per_task.items():
        print(f"{name}: {task['rescued']} / {task['lost']} of {task['failures']} ({task['rescue_rate']:.1%})")
    print(
        f"all tasks: {total['rescued']} / {total['lost']} of {total['failures']} "
        f"({total['rescue_rate']:.1%}, p = {total['exact_p']:.2g})"
    )


if __name__ == "__main__":
    main()
