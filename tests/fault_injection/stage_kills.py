"""Fault injection for the pipeline: SIGKILL a finished study's stages of each kind again mid-run, then rerun.

    redo_with_a_kill_in_each(root, pipeline_args)

Runs the stages of `KILLED_STAGES` (one of every kind of stage that `test_collect_kills.py` and
`test_train_kill.py` do not kill: the perception check, foresight, threshold, an evaluation and detection)
once more in a finished study, by removing their records, and kills the pipeline's whole process group (the
runner and the stage's command, as the OOM killer or a pulled plug would) in the middle of each; then reruns
it to the end. The study must end as the uninterrupted run left it: every file of those stages and the
results, wall times aside. The smoke study of `tests/pipeline/test_pipeline.py` calls it on its finished
#fc = 1 study, so the kills cost no study of their own.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

KILLED_STAGES = ("check_bvmc_fc1", "foresight_fc1", "threshold_fc1", "eval_vmc_fc1", "detect_fc1")
# A stage is killed once its output folder appears or this fraction of its uninterrupted wall time has
# passed (its command's start-up done, its work not), whichever comes first.
KILL_AT_FRACTION = 0.6
# Keys of wall times, which differ from run to run.
WALL_TIME_KEYS = {"eval_s", "eval_ep_s", "stage_wall_s", "total_wall_s"}


def _pipeline_command(args: list[str]) -> list[str]:
    script = Path(sys.executable).with_name("lerobot-ivmc-pipeline")
    return [str(script), *args]


def _without_wall_times(value):
    if isinstance(value, dict):
        return {k: _without_wall_times(v) for k, v in value.items() if k not in WALL_TIME_KEYS}
    if isinstance(value, list):
        return [_without_wall_times(v) for v in value]
    return value


def _content(path: Path):
    """What a file says, wall times aside: JSON as text (NaN equal to NaN), arrays of an npz, else bytes."""
    if path.suffix == ".json":
        return json.dumps(_without_wall_times(json.loads(path.read_text())), sort_keys=True)
    if path.suffix == ".npz":
        with np.load(path) as arrays:
            return {key: arrays[key].tobytes() for key in arrays.files}
    return path.read_bytes()


def stage_outputs(root: Path) -> dict[str, Path]:
    """The folder each of `KILLED_STAGES` writes (the `--output_dir=` of its recorded command)."""
    folders = {}
    for name in KILLED_STAGES:
        argv = json.loads((root / "stages" / f"{name}.json").read_text())["argv"]
        folders[name] = Path(next(arg for arg in argv if arg.startswith("--output_dir=")).split("=", 1)[1])
    return folders


def outputs(root: Path, folders: dict[str, Path]) -> dict[str, object]:
    """The files of the stages' output `folders` and of the study's results, by path under `root`."""
    return {
        str(path.relative_to(root)): _content(path)
        for folder in [*folders.values(), root / "results"]
        for path in sorted(folder.rglob("*"))
        if path.is_file()
    }


def _kill_midway(root: Path, name: str, output: Path, args: list[str], wall_s: float) -> None:
    """Run the pipeline until stage `name` (writing `output`) is midway, then SIGKILL its process group."""
    record_path = root / "stages" / f"{name}.json"
    process = subprocess.Popen(
        _pipeline_command(args), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 600
        started = None
        while process.poll() is None and time.monotonic() < deadline:
            record = json.loads(record_path.read_text()) if record_path.is_file() else {}
            if record.get("status") == "running" and started is None:
                started = time.monotonic()  # the runner removed the old output just before
            if started is not None and (
                output.exists() or time.monotonic() - started > KILL_AT_FRACTION * wall_s
            ):
                break
            time.sleep(0.05)
        ended = process.poll()
    finally:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=60)
    assert ended is None, f"the pipeline ended (exit {ended}) before {name} could be killed midway"
    assert started is not None and json.loads(record_path.read_text())["status"] == "running", name


def redo_with_a_kill_in_each(root: Path, args: list[str]) -> None:
    """Redo `KILLED_STAGES` of the finished study in `root` (run by `lerobot-ivmc-pipeline *args`), killed
    midway one after the other, then finish it; check it ends as it was."""
    folders = stage_outputs(root)
    expected = outputs(root, folders)
    wall = {}
    for name in KILLED_STAGES:
        record_path = root / "stages" / f"{name}.json"
        wall[name] = json.loads(record_path.read_text())["wall_s"]
        record_path.unlink()  # as if never run: the next pipeline run redoes it
    for name in KILLED_STAGES:
        _kill_midway(root, name, folders[name], args, wall[name])
    finished = subprocess.run(_pipeline_command(args), capture_output=True, text=True, timeout=1200)
    assert finished.returncode == 0, finished.stdout[-3000:] + finished.stderr[-3000:]
    assert finished.stdout.count(": running") == 1, finished.stdout  # only the last killed stage
    found = outputs(root, folders)
    assert found.keys() == expected.keys()
    assert [path for path in found if found[path] != expected[path]] == []
