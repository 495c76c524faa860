"""A pipeline stage of every kind the other fault-injection tests do not kill (perception check, foresight,
threshold, evaluation, detection), SIGKILLed midway with the pipeline and rerun: the study ends as the
uninterrupted one (`stage_kills.py`). Its own smoke study of #fc = 1, so that it runs beside the pipeline's
end-to-end test on another worker; run on a local Ray cluster (`--executor.type=ray`) and redone with the
local executor, so the redone stages' files and the results equal to the byte (wall times aside) also show
that both executors give the same study."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from stage_kills import redo_with_a_kill_in_each

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow


@pytest.mark.long
def test_a_study_killed_in_any_stage_reruns_to_the_uninterrupted_study(tmp_path: Path) -> None:
    out = tmp_path / "push_smoke"
    args = ["--task=push", "--preset=smoke", f"--output_dir={out}"]
    on_ray = [*args, "--executor.type=ray", "--executor.num_cpus=2"]
    script = Path(sys.executable).with_name("lerobot-ivmc-pipeline")
    study = subprocess.run([str(script), *on_ray], capture_output=True, text=True, timeout=1200)
    assert study.returncode == 0, study.stdout[-3000:] + study.stderr[-3000:]
    assert "ran side by side: " in study.stdout and "(ray executor)" in study.stdout, study.stdout[-3000:]
    redo_with_a_kill_in_each(out, args)
