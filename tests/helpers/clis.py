"""The short env of the end-to-end runs and running the plugin's CLIs."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path
from unittest import mock

# Short episodes keep the end-to-end runs to seconds; S = 8 Monte Carlo samples.
EPISODE_LENGTH = 30
ENV_FLAGS = [
    "--env.type=ivmc",
    "--env.task=pick_place",
    f"--env.episode_length={EPISODE_LENGTH}",
    "--env.render_size=64",
]


def console_script(name: str) -> str:
    script = Path(sys.executable).with_name(name)
    return str(script) if script.exists() else shutil.which(name)


def tiny_training_flags(policy_type: str, dataset: Path, out: Path, steps: int) -> list[str]:
    """`lerobot-train`'s flags for a `policy_type` run of `steps` steps on the tiny dataset at `dataset`,
    local and offline, saving at the last step."""
    from helpers.policies import TINY_REPO_ID

    return [
        f"--policy.type={policy_type}",
        f"--dataset.repo_id={TINY_REPO_ID}",
        f"--dataset.root={dataset}",
        "--policy.device=cpu",
        "--policy.push_to_hub=false",
        "--wandb.enable=false",
        "--eval_freq=0",
        f"--steps={steps}",
        f"--save_freq={steps}",
        "--num_workers=0",
        f"--output_dir={out}",
    ]


def run_cli(name: str, *args: str) -> subprocess.CompletedProcess:
    """Run a console script in a subprocess and check it succeeds."""
    result = subprocess.run([console_script(name), *args], capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return result


def run_main(name: str, *args: str):
    """Run one of the plugin's draccus CLIs in this process (as its console script would, minus the
    interpreter start-up), with `args` as its command line; exceptions propagate."""
    from lerobot_ivmc.scripts.lerobot_ivmc_eval import eval_main
    from lerobot_ivmc.scripts.lerobot_ivmc_foresight import foresight_main
    from lerobot_ivmc.scripts.lerobot_ivmc_threshold import threshold_main

    mains = {
        "lerobot-ivmc-eval": eval_main,
        "lerobot-ivmc-foresight": foresight_main,
        "lerobot-ivmc-threshold": threshold_main,
    }
    with mock.patch.object(sys, "argv", [name, *args]):
        return mains[name]()
