"""`lerobot-ivmc-inspect`: one episode step by step, the world next to what the policy believes.

Why did an episode fail? Runs a vmc or bvmc checkpoint on one scene (the scene of `lerobot-ivmc-eval`'s
episode with that seed) and records per step the true grip, object and target positions, the grasp, the
executed action, the Bayesian VMC's uncertainty, and the network's own position estimates: its auxiliary
end-effector and object predictions and, for a net trained with `goal_head`, where it believes the object
must end up. Writes `inspect_seed<seed>.json` and a plot of true against believed positions.

    lerobot-ivmc-inspect --policy.path=<checkpoint> --env.type=ivmc --env.task=pick_place \\
        --env.split=test --episode_seed=0 --output_dir=outputs/inspect
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.
import json

from lerobot.configs import parser

from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.evaluation.inspect_episode import InspectConfig, inspect_episode, output_paths, plot_episode


@parser.wrap()
def inspect_main(cfg: InspectConfig) -> dict:
    result = inspect_episode(cfg)
    record_path, plot_path = output_paths(cfg)
    record_path.parent.mkdir(parents=True, exist_ok=True)
    record_path.write_text(json.dumps(result, indent=1))
    plot_episode(result, plot_path)
    print(f"{result['steps']} steps, milestones {result['milestones']}; wrote {record_path} and {plot_path}")
    return result


def main() -> None:
    cli_main(inspect_main)


if __name__ == "__main__":
    main()
