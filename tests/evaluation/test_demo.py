"""`lerobot-ivmc-demo` on the shipped checkpoint: both evaluations, the table, Fig. 3, a video, the page."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from lerobot_ivmc.evaluation.demo import SHIPPED_CHECKPOINT

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow


def test_demo_runs_on_the_shipped_checkpoint_and_writes_its_page(tmp_path: Path) -> None:
    assert (SHIPPED_CHECKPOINT / "recovery_threshold.json").is_file()
    assert (SHIPPED_CHECKPOINT / "README.md").is_file()  # the model card
    demo = Path(sys.executable).with_name("lerobot-ivmc-demo")
    out = tmp_path / "demo"
    # Test scenes 0 and 1: the shipped BVMC fails both and recovers (a video of it is written).
    done = subprocess.run(
        [str(demo), f"--output_dir={out}", "--n_episodes=2"], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert "| BVMC + anchor |" in done.stdout and f"The page: {out / 'demo.md'}" in done.stdout
    page = (out / "demo.md").read_text()
    assert "| BVMC, no recovery |" in page and "uncertainty_vs_success.png" in page
    assert (out / "uncertainty_vs_success.png").stat().st_size > 0
    videos = list(out.glob("recovery_episode_*.mp4"))
    assert videos and f"({videos[0].name})" in page
    again = subprocess.run(
        [str(demo), f"--output_dir={out}", "--n_episodes=2"], capture_output=True, text=True
    )
    assert again.returncode == 2 and "exists: pass a new folder" in again.stderr
