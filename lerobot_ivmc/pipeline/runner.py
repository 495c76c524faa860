"""Run stages in order, resumable: a stage is skipped when its record says it finished with the same
fingerprint (its command, environment and its dependencies' fingerprints) and its done file exists.

Records live in `<root>/stages/<name>.json`, written atomically. A stage killed midway has a "running"
record: when its config is unchanged and it can be continued (the collector keeps its staged demos; a
training with a checkpoint continues from it) its resume command runs on its partial output, otherwise it is
redone from a clean output folder. Changing a stage's config changes its fingerprint and therefore
its successors' too: they rerun, the stages before it do not. `<root>/pipeline.json` names the task and
preset; a folder of another study, or one that is not a study, is refused and left untouched.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from lerobot_ivmc.atomic_files import write_json_atomic
from lerobot_ivmc.datasets.root_lock import RootLock
from lerobot_ivmc.pipeline.stages import Stage, console_script

MANIFEST_FILE = "pipeline.json"
LOCK_FILE = ".pipeline.lock"
STAGES_DIR = "stages"
LOGS_DIR = "logs"
# While a stage runs, its log's modification time is refreshed this often (seconds), so that a killed run's
# time counts up to its kill even when the command writes nothing for a long while (a quiet collection).
HEARTBEAT_S = 30.0


class PipelineError(RuntimeError):
    """A stage failed; the message names its log and says what to do."""


class OutputFolderError(ValueError):
    """The output folder holds another study or foreign files; it is left untouched."""


@dataclass
class StageResult:
    name: str
    status: str  # "ran" or "skipped"
    wall_s: float


def claim_root(root: Path, identity: dict) -> None:
    """Make `root` this study's folder, or refuse (touching nothing) if it holds something else."""
    manifest = root / MANIFEST_FILE
    if manifest.is_file():
        found = json.loads(manifest.read_text())
        if {k: found.get(k) for k in identity} != identity:
            raise OutputFolderError(
                f"{root} holds the study {found}, not {identity}: choose another --output_dir (nothing was "
                "changed there)."
            )
        return
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise OutputFolderError(
            f"{root} exists and is not a pipeline folder (no {MANIFEST_FILE}): choose a new or empty "
            "--output_dir (nothing was changed there)."
        )
    write_json_atomic(manifest, identity)


def study_lock(root: Path) -> RootLock:
    """An exclusive lock on the study folder while a pipeline runs in it (the kernel releases it if the
    process dies, so a killed run never leaves it locked); a second run is refused, naming the first."""
    return RootLock(root, LOCK_FILE, "pipeline", "--output_dir", OutputFolderError)


def fingerprint(stage: Stage, upstream: dict[str, str]) -> str:
    """Hash of what decides a stage's outputs: its command, its environment, its other settings, its inputs'
    fingerprints."""
    payload = {
        "argv": stage.argv,
        "env": stage.env,
        "depends": {name: upstream[name] for name in stage.depends},
    }
    if stage.settings:  # (only then, so that the stages without any keep their fingerprints)
        payload["settings"] = stage.settings
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:16]


def run_stages(
    root: Path,
    stages: list[Stage],
    log=print,
    on_stage_end: Callable[[list[StageResult]], None] | None = None,
) -> list[StageResult]:
    """Run the stages not yet done with their current fingerprint; return what ran and what was skipped.

    `on_stage_end`, if given, is called with the results so far after every stage, run or skipped."""
    fingerprints: dict[str, str] = {}
    results = []
    for index, stage in enumerate(stages, start=1):
        fingerprints[stage.name] = fp = fingerprint(stage, fingerprints)
        record_path = root / STAGES_DIR / f"{stage.name}.json"
        record = json.loads(record_path.read_text()) if record_path.is_file() else {}
        prefix = f"[{index}/{len(stages)}] {stage.name}"
        if record.get("fingerprint") == fp and record.get("status") == "done" and stage.done_file.exists():
            log(f"{prefix}: done earlier ({record['wall_s']:.0f} s), skipped")
            results.append(StageResult(stage.name, "skipped", record["wall_s"]))
        else:
            resume = record.get("fingerprint") == fp and stage.output.exists() and stage.can_resume()
            if stage.output.exists() and not resume:
                shutil.rmtree(stage.output)
            log_path = root / LOGS_DIR / f"{stage.name}.log"
            earlier = killed_wall_s(record, log_path) if resume else 0.0
            log(f"{prefix}: {'resuming' if resume else 'running'} (log {log_path})")
            write_json_atomic(
                record_path,
                {
                    "fingerprint": fp,
                    "status": "running",
                    "argv": stage.argv,
                    "started": time.time(),
                    "wall_s_before": earlier,
                },
            )
            wall = earlier + run_command(stage, log_path, resume)
            write_json_atomic(
                record_path, {"fingerprint": fp, "status": "done", "wall_s": wall, "argv": stage.argv}
            )
            log(f"{prefix}: done in {wall:.0f} s")
            results.append(StageResult(stage.name, "ran", wall))
        if on_stage_end is not None:
            on_stage_end(results)
    return results


def killed_wall_s(record: dict, log_path: Path) -> float:
    """Wall time the killed runs of a stage spent, from their record's start to their log's last write or
    heartbeat (at most `HEARTBEAT_S` before the kill)."""
    if "started" not in record or not log_path.exists():
        return record.get("wall_s_before", 0.0)
    return record.get("wall_s_before", 0.0) + max(0.0, log_path.stat().st_mtime - record["started"])


def run_command(stage: Stage, log_path: Path, resume: bool = False) -> float:
    """Run the stage's command (its resume command if `resume`, the log appended to) with its output in
    `log_path`; its wall time, or PipelineError."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    command = stage.resume_argv if resume else stage.argv
    argv = [console_script(command[0]), *command[1:]]
    start = time.perf_counter()
    with log_path.open("a" if resume else "w") as log_file:
        env = [f"{key}={value}" for key, value in stage.env.items()]
        log_file.write(("\n[resumed] " if resume else "") + " ".join([*env, *command]) + "\n\n")
        log_file.flush()
        returncode = wait_with_heartbeat(
            subprocess.Popen(
                argv, stdout=log_file, stderr=subprocess.STDOUT, env={**os.environ, **stage.env}
            ),
            log_path,
        )
    wall = time.perf_counter() - start
    if returncode != 0:
        tail = log_path.read_text().splitlines()[-5:]
        raise PipelineError(
            f"Stage {stage.name} failed (exit {returncode}); its log is {log_path}. Last lines:\n  "
            + "\n  ".join(tail)
            + "\nFix the cause and rerun the same command: finished stages are kept."
        )
    if not stage.done_file.exists():
        raise PipelineError(f"Stage {stage.name} exited without writing {stage.done_file}; see {log_path}.")
    return wall


def wait_with_heartbeat(process: subprocess.Popen, log_path: Path) -> int:
    """Wait for `process`, touching `log_path` every `HEARTBEAT_S`; kill it if the wait is interrupted."""
    try:
        while True:
            try:
                return process.wait(timeout=HEARTBEAT_S)
            except subprocess.TimeoutExpired:
                os.utime(log_path)
    except BaseException:
        process.kill()
        process.wait()
        raise
