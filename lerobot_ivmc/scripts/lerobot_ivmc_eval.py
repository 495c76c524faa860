"""`lerobot-ivmc-eval`: `lerobot-eval` for the ivmc tasks, with subtask milestones and failure recovery.

It parses the same arguments as `lerobot-eval` plus `--recovery.*` and runs LeRobot's own `eval_policy`
(rollout, seeding, videos). A wrapper on each sub-env keeps the episode's milestones, added to
`eval_info.json` as `subtasks` (per episode) and `aggregated_subtasks` (rates with standard errors). A
`bvmc` policy runs inside `IntrospectiveController` (Algorithm 1), which also records per-step
uncertainty traces (`uncertainty_traces.npz`), the recovery events and u of every episode, the paper's
Fig. 3 (`uncertainty_vs_success.png`) and videos of recoveries (`recovery_videos/`, made from the camera
images the policy acted on, so no frame is rendered for them). `--eval.use_async_envs=true` steps each
sub-env in its own process (per-episode results are the same as in one process); `--max_episodes_rendered`
sets how many episodes LeRobot renders into `videos/` (10, as `lerobot-eval`; 0 saves their rendering).

    lerobot-ivmc-eval --policy.path=<bvmc checkpoint with foresight and threshold> --env.type=ivmc \\
        --env.task=pick_place --eval.n_episodes=100 --eval.batch_size=10 --seed=0 --recovery.mode=min_unc
"""

from pathlib import Path

from lerobot.configs import parser

from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.evaluation.eval_subtasks import EVAL_INFO_FILE, IvmcEvalConfig, evaluate


@parser.wrap()
def eval_main(cfg: IvmcEvalConfig) -> dict:
    info = evaluate(cfg)
    print(f"{cfg.env.task}: {cfg.eval.n_episodes} episodes on {cfg.env.split} scenes (seeds {cfg.seed}..)")
    for name, rate in info["aggregated_subtasks"].items():
        print(f"  {name:<6} {rate['pc']:6.2f} +- {rate['stderr']:.2f} %")
    if "recovery" in info:
        rec = info["recovery"]
        print(
            f"  recovery={rec['mode']} threshold={rec['threshold']} ({rec['threshold_source']}), "
            f"{rec['num_recoveries']} recoveries in {rec['episodes_with_recovery']} episodes; "
            f"Spearman rho (Fig. 3) {info['uncertainty_vs_success']['spearman_rho']:.2f}"
        )
    print(f"Eval info: {Path(cfg.output_dir) / EVAL_INFO_FILE}")
    return info


def main() -> None:
    cli_main(eval_main)


if __name__ == "__main__":
    main()
