"""`lerobot-ivmc-demo`: a policy that detects its failures and recovers, in a few minutes on a CPU.

    lerobot-ivmc-demo [--output_dir=outputs/demo] [--n_episodes=20] [--mode=anchor] [--policy_path=...]

Evaluates the pick_place `bvmc` shipped with the package (`lerobot_ivmc/checkpoints/pick_place_bvmc`, its
foresight head and threshold inside; model card in its README.md) on the same held-out test scenes without
and with recovery (`lerobot-ivmc-eval`, once each), prints the table (success, failures, flagged, rescued,
lost) and writes `demo.md` next to Fig. 3 and a recovery video in `output_dir`.
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.
from lerobot.configs import parser

from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.evaluation.demo import DemoConfig, run_demo


@parser.wrap()
def demo_main(cfg: DemoConfig) -> None:
    page = run_demo(cfg)
    print(f"The page: {page}")


def main() -> None:
    cli_main(demo_main)


if __name__ == "__main__":
    main()
