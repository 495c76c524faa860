"""The pipeline's resumable runner on stand-in stages (small Python commands): skip, redo, rerun, refuse."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from lerobot_ivmc.pipeline.runner import (
    STAGES_DIR,
    OutputFolderError,
    PipelineError,
    claim_root,
    plan_stages,
    run_stages,
    study_lock,
)
from lerobot_ivmc.pipeline.stages import Stage

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

PYTHON = Path(sys.executable).name


def write_stage(root: Path, name: str, depends: list[str], config: str = "a", sleep: float = 0.0) -> Stage:
    """A stage that writes a partial file, optionally sleeps, then its done file, and logs its run."""
    out = root / name
    code = (
        "import pathlib, sys, time; out = pathlib.Path(sys.argv[1]); out.mkdir(parents=True, exist_ok=True); "
        "(out / 'partial').write_text('x'); time.sleep(float(sys.argv[2])); "
        "(out / 'done').write_text(sys.argv[3]); "
        "open(sys.argv[4], 'a').write(out.name + '\\n')"
    )
    argv = [PYTHON, "-c", code, str(out), str(sleep), config, str(root.parent / "runs.log")]
    return Stage(name, argv, output=out, done_file=out / "done", depends=depends)


def chain(
    root: Path, configs: dict[str, str] | None = None, sleep: dict[str, float] | None = None
) -> list[Stage]:
    configs, sleep = configs or {}, sleep or {}
    names = ["collect", "train", "eval"]
    return [
        write_stage(root, name, names[:i][-1:], configs.get(name, "a"), sleep.get(name, 0.0))
        for i, name in enumerate(names)
    ]


def runs(root: Path) -> list[str]:
    log = root.parent / "runs.log"
    names = log.read_text().split() if log.exists() else []
    log.unlink(missing_ok=True)
    return names


def statuses(results) -> dict[str, str]:
    return {r.name: r.status for r in results}


def test_finished_stages_are_skipped_and_a_changed_stage_reruns_with_its_successors(tmp_path: Path) -> None:
    root = tmp_path / "study"
    root.mkdir()
    assert statuses(run_stages(root, chain(root), log=lambda _: None)) == dict.fromkeys(
        ["collect", "train", "eval"], "ran"
    )
    assert runs(root) == ["collect", "train", "eval"]
    assert statuses(run_stages(root, chain(root), log=lambda _: None)) == dict.fromkeys(
        ["collect", "train", "eval"], "skipped"
    )
    assert runs(root) == []
    # A changed train config: train and eval rerun, collect does not.
    results = run_stages(root, chain(root, {"train": "b"}), log=lambda _: None)
    assert statuses(results) == {"collect": "skipped", "train": "ran", "eval": "ran"}
    assert runs(root) == ["train", "eval"]
    assert (root / "train" / "done").read_text() == "b"
    # Same command, another setting outside it (a changed policy default): train and eval rerun too.
    stages = chain(root, {"train": "b"})
    stages[1].settings = {"optimizer_lr": 6e-4}
    results = run_stages(root, stages, log=lambda _: None)
    assert statuses(results) == {"collect": "skipped", "train": "ran", "eval": "ran"}
    assert statuses(run_stages(root, stages, log=lambda _: None))["train"] == "skipped"


def test_the_plan_says_what_a_run_would_do_and_runs_nothing(tmp_path: Path) -> None:
    root = tmp_path / "study"
    root.mkdir()
    assert plan_stages(root, chain(root)) == [("collect", "new"), ("train", "new"), ("eval", "new")]
    assert runs(root) == [] and not (root / "collect").exists()
    run_stages(root, chain(root), log=lambda _: None)
    runs(root)
    assert plan_stages(root, chain(root)) == [("collect", "done"), ("train", "done"), ("eval", "done")]
    # A changed train config: train and its successor would run again, as `run_stages` then does.
    changed = chain(root, {"train": "b"})
    assert plan_stages(root, changed) == [("collect", "done"), ("train", "redo"), ("eval", "redo")]
    assert runs(root) == []
    run_stages(root, changed, log=lambda _: None)
    assert runs(root) == ["train", "eval"]
    # A stage whose done file is gone (killed after its record) and that cannot resume is redone.
    (root / "eval" / "done").unlink()
    assert plan_stages(root, changed)[-1] == ("eval", "redo")
    # While a pipeline holds the study, the stage its record says is running is that run's.
    record = root / STAGES_DIR / "eval.json"
    record.write_text(json.dumps({**json.loads(record.read_text()), "status": "running"}))
    assert plan_stages(root, changed)[-1] == ("eval", "redo")  # nobody runs it: a killed run
    with study_lock(root):
        assert plan_stages(root, changed)[-1] == ("eval", "running")
    assert plan_stages(root, changed)[-1] == ("eval", "redo")


def test_a_killed_stage_is_redone_from_a_clean_folder_and_finished_ones_are_kept(tmp_path: Path) -> None:
    root = tmp_path / "study"
    root.mkdir()
    script = tmp_path / "run.py"
    script.write_text(
        f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})\n"
        "from pathlib import Path\n"
        "from test_runner import chain\n"
        "from lerobot_ivmc.pipeline.runner import run_stages\n"
        "root = Path(sys.argv[1]); run_stages(root, chain(root, sleep={'train': float(sys.argv[2])}))\n"
    )
    process = subprocess.Popen([sys.executable, str(script), str(root), "60"], start_new_session=True)
    record = root / STAGES_DIR / "train.json"
    deadline = time.monotonic() + 120
    while not (root / "train" / "partial").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=30)
    assert json.loads(record.read_text())["status"] == "running"
    collect_done = (root / "collect" / "done").stat().st_mtime_ns
    assert runs(root) == ["collect"]

    results = run_stages(root, chain(root), log=lambda _: None)
    assert statuses(results) == {"collect": "skipped", "train": "ran", "eval": "ran"}
    assert runs(root) == ["train", "eval"]
    assert (root / "collect" / "done").stat().st_mtime_ns == collect_done
    assert json.loads(record.read_text())["status"] == "done"


def resumable_train(root: Path, sleep: float) -> list[Stage]:
    """The chain, its train stage continuable from a checkpoint file: the resume command keeps what the
    killed run wrote and finishes it."""
    stages = chain(root, sleep={"train": sleep})
    train = stages[1]
    out = train.output
    code = (
        "import pathlib, sys; out = pathlib.Path(sys.argv[1]); "
        "print('resumed from', (out / 'ckpt').read_text()); (out / 'done').write_text('resumed'); "
        "open(sys.argv[2], 'a').write('train-resume\\n')"
    )
    # Half a second of work, a checkpoint and a log line, then the rest of the run.
    train.argv[2] = train.argv[2].replace(
        "(out / 'partial').write_text('x');",
        "(out / 'partial').write_text('x'); time.sleep(0.5); (out / 'ckpt').write_text('7'); "
        "print('checkpoint 7', flush=True);",
    )
    train.resume_argv = [PYTHON, "-c", code, str(out), str(root.parent / "runs.log")]
    train.resume_marker = out / "ckpt"
    return stages


def kill_during_train(tmp_path: Path, root: Path, script_body: str, after: float = 0.2) -> None:
    """Run `script_body` (a run of the chain in `root`) in a process and SIGKILL it while train runs,
    `after` seconds past its checkpoint."""
    script = tmp_path / "run.py"
    script.write_text(
        f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r})\n"
        "from pathlib import Path\n"
        "from test_runner import chain, resumable_train\n"
        "from lerobot_ivmc.pipeline.runner import run_stages\n"
        "root = Path(sys.argv[1])\n" + script_body
    )
    process = subprocess.Popen([sys.executable, str(script), str(root)], start_new_session=True)
    deadline = time.monotonic() + 120
    while not (root / "train" / "ckpt").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(after)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=30)


def test_a_killed_stage_with_a_checkpoint_is_continued_not_redone(tmp_path: Path) -> None:
    root = tmp_path / "study"
    root.mkdir()
    kill_during_train(tmp_path, root, "run_stages(root, resumable_train(root, 60))\n")
    assert runs(root) == ["collect"]
    lines = []
    results = run_stages(root, resumable_train(root, 60), log=lines.append)
    assert statuses(results) == {"collect": "skipped", "train": "ran", "eval": "ran"}
    assert runs(root) == ["train-resume", "eval"]
    assert "[2/3] train: resuming" in "\n".join(lines)
    assert (root / "train" / "partial").exists() and (root / "train" / "done").read_text() == "resumed"
    log = (root / "logs" / "train.log").read_text()
    assert log.index("[resumed]") < log.index("resumed from 7"), "the killed run's log is kept, then appended"
    record = json.loads((root / STAGES_DIR / "train.json").read_text())
    # The killed run's time up to its last log line counts.
    assert record["status"] == "done" and record["wall_s"] >= 0.5

    # A changed config is never continued from another config's checkpoint: redone from a clean folder.
    changed = resumable_train(root, 0)
    changed[1].argv[5] = "b"
    (root / STAGES_DIR / "train.json").write_text(json.dumps({**record, "status": "running"}))
    assert statuses(run_stages(root, changed, log=lambda _: None))["train"] == "ran"
    assert runs(root) == ["train", "eval"]
    assert (root / "train" / "done").read_text() == "b"
    # Same command, another setting outside it (a changed policy default): train and eval rerun too.
    stages = chain(root, {"train": "b"})
    stages[1].settings = {"optimizer_lr": 6e-4}
    results = run_stages(root, stages, log=lambda _: None)
    assert statuses(results) == {"collect": "skipped", "train": "ran", "eval": "ran"}
    assert statuses(run_stages(root, stages, log=lambda _: None))["train"] == "skipped"


def test_a_killed_quiet_stage_counts_its_time_up_to_the_kill(tmp_path: Path) -> None:
    """A command that writes nothing for a long while (a collection without progress output) still has its
    killed run's time counted: the runner refreshes the log's time while the command runs."""
    root = tmp_path / "study"
    root.mkdir()
    body = "import lerobot_ivmc.pipeline.runner as r; r.HEARTBEAT_S = 0.1\n"
    kill_during_train(tmp_path, root, body + "run_stages(root, resumable_train(root, 60))\n", after=2.0)
    run_stages(root, resumable_train(root, 60), log=lambda _: None)
    record = json.loads((root / STAGES_DIR / "train.json").read_text())
    # 0.5 s to its checkpoint's log line, then 2 s without output before the kill.
    assert record["status"] == "done" and record["wall_s"] >= 2.0


def test_a_killed_stage_without_its_checkpoint_is_redone(tmp_path: Path) -> None:
    root = tmp_path / "study"
    root.mkdir()
    kill_during_train(tmp_path, root, "run_stages(root, resumable_train(root, 60))\n")
    (root / "train" / "ckpt").unlink()  # killed before its first checkpoint
    assert runs(root) == ["collect"]
    results = run_stages(root, resumable_train(root, 0), log=lambda _: None)
    assert statuses(results) == {"collect": "skipped", "train": "ran", "eval": "ran"}
    assert runs(root) == ["train", "eval"]
    assert (root / "train" / "done").read_text() == "a"


def test_a_failing_stage_stops_the_run_and_names_its_log(tmp_path: Path) -> None:
    root = tmp_path / "study"
    root.mkdir()
    stages = chain(root)
    stages[1].argv = [PYTHON, "-c", "import sys; print('no demos found'); sys.exit(3)"]
    with pytest.raises(
        PipelineError, match=r"(?s)Stage train failed \(exit 3\).*logs/train.log.*no demos found"
    ):
        run_stages(root, stages, log=lambda _: None)
    assert runs(root) == ["collect"]
    assert not (root / "eval").exists()


def test_a_folder_of_another_study_or_of_no_study_is_refused_untouched(tmp_path: Path) -> None:
    root = tmp_path / "study"
    claim_root(root, {"task": "push", "preset": "smoke"})
    claim_root(root, {"task": "push", "preset": "smoke"})  # the same study: fine
    (root / "result.txt").write_text("mine")
    before = sorted((p.name, p.read_bytes()) for p in root.iterdir())
    for other in ({"task": "pick_place", "preset": "smoke"}, {"task": "push", "preset": "lite"}):
        with pytest.raises(OutputFolderError, match="holds the study.*choose another --output_dir"):
            claim_root(root, other)
    assert sorted((p.name, p.read_bytes()) for p in root.iterdir()) == before
    foreign = tmp_path / "photos"
    foreign.mkdir()
    (foreign / "cat.jpg").write_text("meow")
    with pytest.raises(OutputFolderError, match="not a pipeline folder"):
        claim_root(foreign, {"task": "push", "preset": "smoke"})
    assert [p.name for p in foreign.iterdir()] == ["cat.jpg"]


def test_a_second_run_on_a_folder_in_use_is_refused_until_the_first_ends(tmp_path: Path) -> None:
    root = tmp_path / "study"
    with study_lock(root):
        with pytest.raises(
            OutputFolderError, match=rf"being written by another pipeline \(pid {os.getpid()} "
        ):
            with study_lock(root):
                pass
    with study_lock(root):  # released when the first run ends (or dies): the next one takes it
        pass
