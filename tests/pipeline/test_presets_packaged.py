"""The pipeline's presets ship in the wheel, so `--preset` works after a plain (non-editable) install."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

from lerobot_ivmc.pipeline.config import PRESETS_DIR

ROOT = Path(__file__).resolve().parents[2]


def test_the_wheel_holds_every_preset(tmp_path: Path) -> None:
    presets = sorted(p.name for p in PRESETS_DIR.glob("*.yaml"))
    assert presets == ["lite.yaml", "metaworld.yaml", "metaworld_smoke.yaml", "paper.yaml", "smoke.yaml"]
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            str(ROOT),
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path),
        ],
        check=True,
        capture_output=True,
    )
    (wheel,) = tmp_path.glob("*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {f"lerobot_ivmc/pipeline/presets/{name}" for name in presets} <= names
