"""Fault injection: two `lerobot-ivmc-eval` runs on one `--output_dir`.

The second starts while the first holds the folder: it is refused at once, naming the first, and touches
nothing; the first ends with exactly the results it gives alone (compared with a lone run of the same
command), so no row of a study can mix two runs' episodes or videos.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path
from unittest import mock

import numpy as np
import pytest

import lerobot_ivmc.checkpoints
from lerobot_ivmc.datasets.root_lock import EVAL_LOCK_FILE

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

# The shipped pick_place bvmc (threshold and foresight head included), on short episodes.
CHECKPOINT = Path(lerobot_ivmc.checkpoints.__file__).parent / "pick_place_bvmc"
FLAGS = [
    f"--policy.path={CHECKPOINT}",
    "--env.type=ivmc",
    "--env.task=pick_place",
    "--env.episode_length=30",
    "--eval.batch_size=2",
    "--seed=0",
    "--max_episodes_rendered=0",
]


def _console_script(name: str) -> str:
    script = Path(sys.executable).with_name(name)
    return str(script) if script.exists() else shutil.which(name)


def _eval_in_this_process(*args: str) -> dict:
    """`lerobot-ivmc-eval` as its console script runs it, minus the interpreter's start-up."""
    from lerobot_ivmc.scripts.lerobot_ivmc_eval import eval_main

    with mock.patch.object(sys, "argv", ["lerobot-ivmc-eval", *args]):
        return eval_main()


def _results(folder: Path) -> tuple[str, dict[str, np.ndarray]]:
    """What an evaluation decides: its episodes, rates and recoveries (not its wall times, its folder named
    `<out>`) as JSON text (NaN equals NaN there), and its uncertainty traces."""
    info = json.loads((folder / "eval_info.json").read_text().replace(str(folder), "<out>"))
    info["aggregated"] = {k: v for k, v in info["aggregated"].items() if k not in ("eval_s", "eval_ep_s")}
    with np.load(folder / "uncertainty_traces.npz") as traces:
        return json.dumps(info, sort_keys=True), {key: traces[key] for key in traces.files}


def test_a_second_eval_on_a_folder_in_use_is_refused_and_the_first_ends_as_if_alone(tmp_path: Path) -> None:
    out = tmp_path / "eval"
    first_args = [*FLAGS, "--eval.n_episodes=4", "--recovery.mode=min_unc", f"--output_dir={out}"]
    first = subprocess.Popen(
        [_console_script("lerobot-ivmc-eval"), *first_args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 300
        while not (out / EVAL_LOCK_FILE).exists() and first.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert first.poll() is None, "the first evaluation ended before the second could start"
        # Another command on the same folder (fewer episodes, no recovery): refused, naming the first.
        with pytest.raises(FileExistsError, match=rf"being written by another evaluation \(pid {first.pid} "):
            _eval_in_this_process(
                *FLAGS, "--eval.n_episodes=2", "--recovery.mode=none", f"--output_dir={out}"
            )
        _, stderr = first.communicate(timeout=600)
    finally:
        if first.poll() is None:
            first.kill()
    assert first.returncode == 0, stderr[-3000:]
    assert not (out / EVAL_LOCK_FILE).exists()

    alone = tmp_path / "alone"
    _eval_in_this_process(*first_args[:-1], f"--output_dir={alone}")
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == sorted(
        p.relative_to(alone) for p in alone.rglob("*")
    )
    (info, traces), (expected_info, expected_traces) = _results(out), _results(alone)
    assert info == expected_info
    assert traces.keys() == expected_traces.keys()
    for key, value in traces.items():
        np.testing.assert_array_equal(value, expected_traces[key], err_msg=key)
