"""The demo behind `lerobot-ivmc-demo` (`scripts/lerobot_ivmc_demo.py`): the shipped pick_place `bvmc`
evaluated on the same held-out test scenes without and with recovery, and the page that puts the table,
Fig. 3 and a recovery video together."""

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from lerobot_ivmc.evaluation.compare import load_run
from lerobot_ivmc.evaluation.demo_page import demo_table, write_demo_page
from lerobot_ivmc.recovery.config import RECOVERY_MODES

SHIPPED_CHECKPOINT = Path(__file__).resolve().parents[1] / "checkpoints" / "pick_place_bvmc"


@dataclass
class DemoConfig:
    """Args:
    output_dir: where the two evaluations, the page, the figure and the video go (must not exist yet).
    n_episodes: held-out test scenes (seeds `seed`, `seed + 1`, ...), evaluated up to 10 at a time.
    mode: the recovery mode shown against no recovery.
    policy_path: a pick_place `bvmc` checkpoint with foresight head and threshold; default: the shipped one.
    seed: the first test scene and the Monte Carlo masks' seed.
    """

    output_dir: Path = Path("outputs/demo")
    n_episodes: int = 20
    mode: str = "anchor"
    policy_path: Path = SHIPPED_CHECKPOINT
    seed: int = 0

    def __post_init__(self) -> None:
        if self.mode not in RECOVERY_MODES or self.mode == "none":
            raise ValueError(f"--mode must be one of {RECOVERY_MODES[1:]}, got {self.mode!r}.")
        if self.n_episodes < 1:
            raise ValueError(f"--n_episodes must be >= 1, got {self.n_episodes}.")


def eval_command(cfg: DemoConfig, mode: str, output_dir: Path) -> list[str]:
    """The `lerobot-ivmc-eval` call for one of the demo's two runs."""
    batch = max(
        size for size in range(1, 11) if cfg.n_episodes % size == 0
    )  # every scene, 10 at most at once
    return [
        str(Path(sys.executable).with_name("lerobot-ivmc-eval")),
        f"--policy.path={cfg.policy_path}",
        "--env.type=ivmc",
        "--env.task=pick_place",
        "--env.episode_length=200",
        "--env.render_style=fast",
        "--env.split=test",
        "--max_episodes_rendered=0",
        f"--eval.n_episodes={cfg.n_episodes}",
        f"--eval.batch_size={batch}",
        f"--seed={cfg.seed}",
        f"--recovery.mode={mode}",
        "--recovery.max_videos=1",
        f"--output_dir={output_dir}",
    ]


def run_demo(cfg: DemoConfig) -> Path:
    """Run both evaluations and write the page; return its path."""
    if cfg.output_dir.exists():
        raise FileExistsError(
            f"--output_dir={cfg.output_dir} exists: pass a new folder (nothing is overwritten)."
        )
    if not (cfg.policy_path / "recovery_threshold.json").is_file():
        raise FileNotFoundError(
            f"{cfg.policy_path} has no recovery_threshold.json: pass the output of lerobot-ivmc-threshold."
        )
    cfg.output_dir.mkdir(parents=True)
    runs = {}
    for mode in ("none", cfg.mode):
        runs[mode] = cfg.output_dir / f"bvmc_{mode}"
        print(f"Evaluating BVMC with --recovery.mode={mode} on {cfg.n_episodes} test scenes ...", flush=True)
        log = cfg.output_dir / f"bvmc_{mode}.log"
        with log.open("w") as out:
            result = subprocess.run(eval_command(cfg, mode, runs[mode]), stdout=out, stderr=subprocess.STDOUT)
        if result.returncode != 0:
            raise RuntimeError(f"lerobot-ivmc-eval --recovery.mode={mode} failed; its log is {log}.")
    table, _ = demo_table(load_run(runs["none"]), load_run(runs[cfg.mode]))
    print(table)
    command = " ".join(["lerobot-ivmc-demo", *sys.argv[1:]])
    return write_demo_page(runs["none"], runs[cfg.mode], cfg.output_dir, command)
