"""README.md's commands run as written from a fresh clone (with small counts): `tests/readme_commands.py`.

The check runs the collect, train, foresight, threshold, eval, compare, detect, inspect and summary commands
of the README's ```bash blocks in a temporary folder, with the episodes, steps, batch sizes and trajectories
made small (about a minute on 2 cores); the pipeline's command (a study of hours) is parsed and its stages
built without running them; `bash scripts/run.sh` and `scripts/test.sh` are checked for syntax only (they
reinstall the package; the demo that run.sh starts is run by tests/recovery/test_demo.py). What each
command is checked for is in that file's docstring.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

sys.path.insert(0, str(Path(__file__).parent))

from readme_commands import REPO, extract_commands, plan_for, with_small_counts  # noqa: E402

MARKDOWN = """# A project

```bash
# a comment line
lerobot-ivmc-eval --policy.path=a \\
  --eval.n_episodes=100   # an inline comment
```

```
not-a-command --in a plain block
```

```bash
lerobot-ivmc-compare a b
```
"""


def test_commands_are_extracted_with_their_readme_line() -> None:
    commands = extract_commands(MARKDOWN)
    assert [(c.line, c.argv) for c in commands] == [
        (5, ["lerobot-ivmc-eval", "--policy.path=a", "--eval.n_episodes=100"]),
        (14, ["lerobot-ivmc-compare", "a", "b"]),
    ]
    assert "README.md line 5" in commands[0].where


def test_small_counts_in_both_styles_of_collect() -> None:
    short = ["lerobot-ivmc-collect", "--task", "pick_place", "--num-episodes", "2000", "--root", "d"]
    assert with_small_counts(short) == [*short[:4], "2", "--root", "d", "--num-workers=0"]
    draccus = ["lerobot-ivmc-collect", "--env.task=pick_place", "--dataset.num_episodes=2000"]
    assert with_small_counts(draccus) == [*draccus[:2], "--dataset.num_episodes=2", "--num_workers=0"]
    threshold = ["lerobot-ivmc-threshold", "--env.type=ivmc", "--eval.n_episodes=100"]
    assert with_small_counts(threshold) == [
        *threshold[:2],
        "--eval.n_episodes=2",
        "--env.episode_length=30",
        "--eval.batch_size=2",
    ]


def test_every_readme_command_has_a_plan() -> None:
    commands = extract_commands((REPO / "README.md").read_text())
    assert len(commands) >= 10
    unknown = [c.where for c in commands if plan_for(c) is None]
    assert not unknown, f"commands the README check does not know (tests/readme_commands.py): {unknown}"


def test_readme_commands_run_as_written(tmp_path: Path) -> None:
    report = tmp_path / "report.json"
    check = Path(__file__).with_name("readme_commands.py")
    done = subprocess.run(
        [sys.executable, str(check), f"--workdir={tmp_path / 'clone'}", f"--report={report}"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    log = (done.stdout + done.stderr)[-4000:]
    assert report.is_file(), f"the README check did not finish:\n{log}"
    outcomes = json.loads(report.read_text())
    failed = [o for o in outcomes if not o["ok"]]
    assert not failed, (
        f"README.md line {failed[0]['line']}: `{failed[0]['command']}`: {failed[0]['message']}\n{log}"
    )
    assert done.returncode == 0, log
    assert {o["how"] for o in outcomes} == {"run", "dry parse", "syntax"}
