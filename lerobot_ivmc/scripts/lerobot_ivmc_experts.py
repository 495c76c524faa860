"""`lerobot-ivmc-experts`: run the scripted expert on each task, report success, save episode videos.

Examples:
    lerobot-ivmc-experts                                   # 3 episodes per task, a video of each
    lerobot-ivmc-experts --n_episodes=500 --n_videos=0     # expert success rate on 500 train scenes
    lerobot-ivmc-experts --config_path=configs/experts.yaml
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.
import json
import logging
from dataclasses import asdict

from lerobot.configs import parser

from lerobot_ivmc.experts.expert_runs import ExpertRunConfig, run_task


@parser.wrap()
def run_experts(cfg: ExpertRunConfig) -> dict[str, dict[str, float]]:
    results = {task: run_task(cfg, task) for task in cfg.tasks}
    cfg.output_dir.mkdir(parents=True, exist_ok=True)
    summary = {"config": {**asdict(cfg), "output_dir": str(cfg.output_dir)}, "success": results}
    (cfg.output_dir / "expert_success.json").write_text(json.dumps(summary, indent=2))
    print(f"Expert success over {cfg.n_episodes} {cfg.split} scenes per task (seeds {cfg.seed}..):")
    for task, rates in results.items():
        print(f"  {task:<11}" + "  ".join(f"{name} {rate:6.1%}" for name, rate in rates.items()))
    if cfg.n_videos:
        print(f"Videos: {cfg.output_dir / 'videos'}")
    return results


def main() -> None:
    logging.basicConfig(level=logging.INFO)
    run_experts()


if __name__ == "__main__":
    main()
