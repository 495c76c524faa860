"""Stand-in stages for the executors' tests: small Python commands that record their pid and threads, sleep,
then write their done file (or fail).

    python tests/pipeline/fake_stages.py <root>   # runs `killable_study(root)` on a local Ray cluster
"""

from __future__ import annotations

import sys
from pathlib import Path

from lerobot_ivmc.pipeline.stages import Stage, StageResources

PYTHON = Path(sys.executable).name
CODE = (
    "import os, pathlib, sys, time; out = pathlib.Path(sys.argv[1]); out.mkdir(parents=True, exist_ok=True); "
    "(out / 'pid').write_text(str(os.getpid())); sleep = sys.argv[2]; "
    "time.sleep(float(pathlib.Path(sleep).read_text() if sleep.endswith('.txt') else sleep)); "
    "threads = os.environ.get('OMP_NUM_THREADS', ''); "
    "sys.exit(3) if sys.argv[3] == 'fail' else (out / 'done').write_text(threads)"
)


def fake_stage(
    root: Path,
    name: str,
    depends: tuple[str, ...] = (),
    after: tuple[str, ...] = (),
    sleep: float | Path = 0.0,
    fail: bool = False,
    cpus: float = 1.0,
) -> Stage:
    """A stage that writes `<root>/<name>/pid`, sleeps `sleep` seconds (or the number in the file `sleep`),
    then exits 3 (`fail`) or writes its done file holding its `OMP_NUM_THREADS`."""
    out = root / name
    argv = [PYTHON, "-c", CODE, str(out), str(sleep), "fail" if fail else "ok"]
    return Stage(
        name,
        argv,
        output=out,
        done_file=out / "done",
        depends=list(depends),
        after=list(after),
        resources=StageResources(cpus=cpus),
    )


def killable_study(root: Path) -> list[Stage]:
    """A quick stage, then a long one whose sleep is read from `<root>/long_sleep.txt`."""
    return [fake_stage(root, "quick"), fake_stage(root, "long", ("quick",), sleep=root / "long_sleep.txt")]


if __name__ == "__main__":
    from lerobot_ivmc.pipeline.ray_executor import RayExecutor
    from lerobot_ivmc.pipeline.runner import run_stages

    study = Path(sys.argv[1])
    run_stages(study, killable_study(study), executor=RayExecutor(num_cpus=2))
