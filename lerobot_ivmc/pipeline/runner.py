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

import contextlib
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from lerobot_ivmc.atomic_files import write_json_atomic
from lerobot_ivmc.datasets.root_lock import RootLock, lock_holder
from lerobot_ivmc.pipeline import stage_process
from lerobot_ivmc.pipeline.stages import Stage, console_script, find_stage

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
    """A stage's outcome in one run: "ran" or "skipped", its wall time (over every run of it), and for a
    stage that ran, when it started and ended in this run (seconds from the run's start)."""

    name: str
    status: str
    wall_s: float
    started_s: float | None = None
    ended_s: float | None = None


class Executor(Protocol):
    """Runs stage commands for `run_stages`, which decides what runs and writes every record.

    `parallel`: whether it runs several stages at once (else `run_stages` starts one stage at a time, in
    the stages' order). `start` hands it a stage's command; `wait_any` blocks until one started stage
    ends and returns its name, its wall time or the `PipelineError` it failed with, and when its command
    started (`time.time()`; None: when it was handed over); `cancel` stops every started stage (the driver
    was interrupted)."""

    parallel: bool

    def start(self, stage: Stage, log_path: Path, resume: bool) -> None: ...

    def wait_any(self) -> tuple[str, float | PipelineError, float | None]: ...

    def cancel(self) -> None: ...


class LocalExecutor:
    """One stage at a time, in this process's machine (the default)."""

    parallel = False

    def __init__(self) -> None:
        self._next: tuple[Stage, Path, bool] | None = None

    def start(self, stage: Stage, log_path: Path, resume: bool) -> None:
        self._next = (stage, log_path, resume)

    def wait_any(self) -> tuple[str, float | PipelineError, float | None]:
        stage, log_path, resume = self._next
        self._next = None
        try:
            return stage.name, run_command(stage, log_path, resume), None
        except PipelineError as error:
            return stage.name, error, None

    def cancel(self) -> None:
        self._next = None


def check_root(root: Path, identity: dict) -> bool:
    """Whether `root` is already this study's folder (False: new or empty); refuse (touching nothing) one
    that holds something else."""
    manifest = root / MANIFEST_FILE
    if manifest.is_file():
        found = json.loads(manifest.read_text())
        if {k: found.get(k) for k in identity} != identity:
            raise OutputFolderError(
                f"{root} holds the study {found}, not {identity}: choose another --output_dir (nothing was "
                "changed there)."
            )
        return True
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise OutputFolderError(
            f"{root} exists and is not a pipeline folder (no {MANIFEST_FILE}): choose a new or empty "
            "--output_dir (nothing was changed there)."
        )
    return False


def claim_root(root: Path, identity: dict) -> None:
    """Make `root` this study's folder, or refuse (touching nothing) if it holds something else."""
    if not check_root(root, identity):
        write_json_atomic(root / MANIFEST_FILE, identity)


def study_holder(root: Path) -> str | None:
    """The pipeline running in `root` now (pid, host, start and command), or None."""
    return lock_holder(root, LOCK_FILE)


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


def plan_stages(root: Path, stages: list[Stage]) -> list[tuple[str, str]]:
    """What `run_stages` would do with each stage, in order: "done" (skipped), "new" (never run), "resume"
    (killed, continued where it can be), "redo" (its settings or an upstream stage changed since it ran, or
    it was killed and cannot resume); "running" for the stage a pipeline running in `root` now runs."""
    running_now = study_holder(root) is not None
    fingerprints: dict[str, str] = {}
    plan = []
    for stage in stages:
        fp = fingerprints[stage.name] = fingerprint(stage, fingerprints)
        path = record_file(root, stage.name)
        record = json.loads(path.read_text()) if path.is_file() else {}
        if not record:
            state = "new"
        elif record.get("fingerprint") != fp:
            state = "redo"
        elif record.get("status") == "done" and stage.done_file.exists():
            state = "done"
        elif record.get("status") == "running" and running_now:
            state = "running"
        else:
            state = "resume" if stage.output.exists() and stage.can_resume() else "redo"
        plan.append((stage.name, state))
    return plan


def check_order(stages: list[Stage]) -> None:
    """Refuse a list whose stages wait for a stage that is not before them."""
    seen: set[str] = set()
    for stage in stages:
        missing = [name for name in stage.prerequisites if name not in seen]
        if missing:
            raise ValueError(
                f"Stage {stage.name} waits for {missing}, which are not earlier stages of the study."
            )
        seen.add(stage.name)


def run_stages(
    root: Path,
    stages: list[Stage],
    log=print,
    on_stage_end: Callable[[list[StageResult]], None] | None = None,
    executor: Executor | None = None,
) -> list[StageResult]:
    """Run the stages not yet done with their current fingerprint; return what ran and what was skipped.

    A stage starts once every stage it waits for (`Stage.prerequisites`) has finished; the executor runs
    one at a time in the list's order (local) or every startable one side by side (ray). The first failure
    stops new starts; the stages already running finish and are recorded, then the failure is raised.
    `on_stage_end`, if given, is called with the results so far after every stage, run or skipped."""
    check_order(stages)
    executor = executor or LocalExecutor()
    fingerprints: dict[str, str] = {}
    for stage in stages:
        fingerprints[stage.name] = fingerprint(stage, fingerprints)
    position = {stage.name: index for index, stage in enumerate(stages, start=1)}
    prefix = {name: f"[{index}/{len(stages)}] {name}" for name, index in position.items()}
    waiting, running = list(stages), {}
    finished: set[str] = set()
    results: list[StageResult] = []
    failures: list[PipelineError] = []
    run_start = time.time()

    def ended(result: StageResult) -> None:
        results.append(result)
        finished.add(result.name)
        if on_stage_end is not None:
            on_stage_end(results)

    try:
        while waiting or running:
            for stage in list(waiting):
                if failures or (running and not executor.parallel):
                    break
                if not finished.issuperset(stage.prerequisites):
                    if executor.parallel:
                        continue
                    break
                waiting.remove(stage)
                begun = begin_stage(root, stage, fingerprints[stage.name], prefix[stage.name], log)
                if isinstance(begun, StageResult):
                    ended(begun)
                    continue
                log_path, resume, earlier = begun
                executor.start(stage, log_path, resume)
                running[stage.name] = (time.time(), earlier)
            if not running:
                break
            name, outcome, started_at = executor.wait_any()
            handed_over, earlier = running.pop(name)
            if isinstance(outcome, PipelineError):
                log(f"{prefix[name]}: failed")
                failures.append(outcome)
                continue
            wall = earlier + outcome
            record = {"fingerprint": fingerprints[name], "status": "done", "wall_s": wall}
            write_json_atomic(record_file(root, name), {**record, "argv": find_stage(stages, name).argv})
            log(f"{prefix[name]}: done in {wall:.0f} s")
            started_s = (started_at or handed_over) - run_start
            ended(StageResult(name, "ran", wall, started_s, time.time() - run_start))
    except BaseException:
        executor.cancel()
        raise
    if failures:
        raise failures[0]
    return results


def record_file(root: Path, name: str) -> Path:
    """The record of stage `name` of the study in `root`."""
    return root / STAGES_DIR / f"{name}.json"


def begin_stage(
    root: Path, stage: Stage, fp: str, prefix: str, log
) -> StageResult | tuple[Path, bool, float]:
    """Skip `stage` (its record says it finished with fingerprint `fp` and its done file exists: its
    result), or prepare it to run (a clean output folder unless it resumes, a "running" record): its log's
    path, whether it resumes, and the wall time its killed runs spent."""
    record_path = record_file(root, stage.name)
    record = json.loads(record_path.read_text()) if record_path.is_file() else {}
    if record.get("fingerprint") == fp and record.get("status") == "done" and stage.done_file.exists():
        log(f"{prefix}: done earlier ({record['wall_s']:.0f} s), skipped")
        return StageResult(stage.name, "skipped", record["wall_s"])
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
    return log_path, resume, earlier


def killed_wall_s(record: dict, log_path: Path) -> float:
    """Wall time the killed runs of a stage spent, from their record's start to their log's last write or
    heartbeat (at most `HEARTBEAT_S` before the kill)."""
    if "started" not in record or not log_path.exists():
        return record.get("wall_s_before", 0.0)
    return record.get("wall_s_before", 0.0) + max(0.0, log_path.stat().st_mtime - record["started"])


def run_command(
    stage: Stage,
    log_path: Path,
    resume: bool = False,
    extra_env: dict[str, str] | None = None,
    tied_to_parent: bool = False,
) -> float:
    """Run the stage's command (its resume command if `resume`, the log appended to) with its output in
    `log_path`; its wall time, or PipelineError. `extra_env` adds variables that do not decide its outputs
    (threads); with `tied_to_parent` the command runs in its own process group under `stage_process`, which
    kills the group when this process dies (a Ray worker)."""
    log_path.parent.mkdir(parents=True, exist_ok=True)
    command = stage.resume_argv if resume else stage.argv
    argv = [console_script(command[0]), *command[1:]]
    env = {**os.environ, **(extra_env or {}), **stage.env}
    if tied_to_parent:
        argv = [sys.executable, stage_process.__file__, *argv]  # (a script: none of the package's imports)
        env[stage_process.PARENT_PID_VARIABLE] = str(os.getpid())
    start = time.perf_counter()
    with log_path.open("a" if resume else "w") as log_file:
        shown_env = [f"{key}={value}" for key, value in stage.env.items()]
        log_file.write(("\n[resumed] " if resume else "") + " ".join([*shown_env, *command]) + "\n\n")
        log_file.flush()
        process = subprocess.Popen(
            argv, stdout=log_file, stderr=subprocess.STDOUT, env=env, start_new_session=tied_to_parent
        )
        returncode = wait_with_heartbeat(process, log_path, kill_group=tied_to_parent)
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


def wait_with_heartbeat(process: subprocess.Popen, log_path: Path, kill_group: bool = False) -> int:
    """Wait for `process`, touching `log_path` every `HEARTBEAT_S`; kill it (with `kill_group`, its whole
    process group) if the wait is interrupted."""
    try:
        while True:
            try:
                return process.wait(timeout=HEARTBEAT_S)
            except subprocess.TimeoutExpired:
                os.utime(log_path)
    except BaseException:
        if kill_group:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
        else:
            process.kill()
        process.wait()
        raise
