"""door-open-v3's BVMC failures by how far the door moved, and which of them each recovery row rescued.

MetaWorld's door-open reward is 2 x (hand in place at the handle, gripper closed) + 8 x (0.2 once the door
has turned 2 degrees + 0.8 x how fully open it is), so an episode's highest reward tells how far it got:
below 3 the door never moved, 3 to 5 it moved a little (the 2-degree bonus), 5 and above it was pulled
part way open. Reads a study's `eval/bvmc_fc1_<row><_seedS>/eval_info.json` (the test scenes):

python -m diagnostics.door_open_failures --study <out> --rows init retry reach_carry_frame \
    --output docs/results/metaworld/<name>.json
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from collections import Counter
from pathlib import Path

KINDS = ("never moved", "moved a little", "part way open")


def failure_kind(max_reward: float) -> str:
    """The band of an episode's highest door-open reward (module docstring)."""
    return KINDS[0] if max_reward < 3.0 else KINDS[1] if max_reward < 5.0 else KINDS[2]


def seed_suffixes(study: Path) -> list[str]:
    """ "" for the main training seed, "_seed<S>" for each extra one the study evaluated."""
    found = sorted(p.name.removeprefix("bvmc_fc1_none") for p in (study / "eval").glob("bvmc_fc1_none*"))
    if not found:
        raise FileNotFoundError(
            f"{study}/eval has no bvmc_fc1_none*: give a door-open-v3 study's --output_dir."
        )
    return found


def episodes(study: Path, row: str, suffix: str) -> list[dict]:
    path = study / "eval" / f"bvmc_fc1_{row}{suffix}" / "eval_info.json"
    return json.loads(path.read_text())["per_episode"]


def tally(study: Path, rows: list[str]) -> dict:
    """Per training seed and summed: BVMC's failures by kind, and per row the failures it rescued by kind
    and the successes it lost."""
    per_seed, total = {}, {"failures": Counter(), **{row: {"rescued": Counter(), "lost": 0} for row in rows}}
    for suffix in seed_suffixes(study):
        bvmc = episodes(study, "none", suffix)
        failures = Counter(failure_kind(e["max_reward"]) for e in bvmc if not e["success"])
        entry = {"failures": dict(failures)}
        total["failures"] += failures
        for row in rows:
            recovered = episodes(study, row, suffix)
            rescued = Counter(
                failure_kind(a["max_reward"])
                for a, b in zip(bvmc, recovered, strict=True)
                if b["success"] > a["success"]
            )
            lost = sum(a["success"] > b["success"] for a, b in zip(bvmc, recovered, strict=True))
            entry[row] = {"rescued": dict(rescued), "lost": lost}
            total[row]["rescued"] += rescued
            total[row]["lost"] += lost
        per_seed[suffix.removeprefix("_seed") or "main"] = entry
    summed = {"failures": dict(total["failures"])}
    summed.update({row: {"rescued": dict(total[row]["rescued"]), "lost": total[row]["lost"]} for row in rows})
    return {"per_seed": per_seed, "summed": summed}


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--study", type=Path, required=True, help="a door-open-v3 study's --output_dir")
    parser.add_argument("--rows", nargs="*", default=["init"], help="recovery rows to tally")
    parser.add_argument("--output", type=Path, help="write the tally here as JSON")
    args = parser.parse_args()
    result = tally(args.study, args.rows)
    for seed, entry in {**result["per_seed"], "summed": result["summed"]}.items():
        counts = ", ".join(f"{kind} {entry['failures'].get(kind, 0)}" for kind in KINDS)
        print(f"{seed}: BVMC's failures: {counts}")
        for row in args.rows:
            rescued = ", ".join(f"{kind} {entry[row]['rescued'].get(kind, 0)}" for kind in KINDS)
            print(f"  {row}: rescued {rescued}; lost {entry[row]['lost']}")
    if args.output:
        command = "python -m diagnostics.door_open_failures " + shlex.join(sys.argv[1:])
        args.output.write_text(json.dumps({"command": command, **result}, indent=2) + "\n")


if __name__ == "__main__":
    main()
