"""`lerobot-ivmc-foresight`: distil the uncertainty foresight head into a bvmc checkpoint.

Deploys the Bayesian VMC on training scenes, executing one Monte Carlo sample per step, records
(e_t, a_t, u_{t+1}) (resumable shards), trains the head, reports its quality on held-out trajectories and
on trying every candidate action of sampled states in a copy of the env, and writes a NEW checkpoint
folder `<output_dir>/pretrained_model` (the input checkpoint is never modified) that `from_pretrained`
loads as a policy that both acts and foresees.

    lerobot-ivmc-foresight --policy.path=<bvmc checkpoint> --env.type=ivmc --env.task=pick_place \\
        --foresight.num_trajectories=2000 --eval.batch_size=10 --seed=0 --output_dir=outputs/foresight
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.
from pathlib import Path

from lerobot.configs import parser

from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.evaluation.foresight_distillation import (
    CHECKPOINT_DIR,
    ForesightPipelineConfig,
    distill_foresight,
)


@parser.wrap()
def foresight_main(cfg: ForesightPipelineConfig) -> dict:
    report = distill_foresight(cfg)
    quality = report["heldout"]
    print(
        f"Foresight head on {report['num_heldout_records']} held-out records: Spearman rho "
        f"{quality['spearman_rho']:.3f}, R^2 (log u) {quality['r2_log']:.3f}, R^2 (u) {quality['r2']:.3f} "
        f"(persistence baseline rho {quality['baseline_persistence_spearman_rho']:.3f})"
    )
    if "action_ranking" in report:
        ranking = report["action_ranking"]
        print(
            f"Action ranking on {ranking['num_states']} states: argmin match "
            f"{ranking['argmin_match_rate']:.3f} "
            f"(chance {ranking['chance_match_rate']:.3f}, measurement self-agreement "
            f"{ranking['measurement_self_match_rate']:.3f}), percentile of choice "
            f"{ranking['mean_percentile_of_choice']:.3f} (chance 0.5); measured next uncertainty of its "
            f"choice {ranking['measured_u_of_choice']:.4f}, of a random candidate "
            f"{ranking['measured_u_mean_candidate']:.4f}, of the best "
            f"{ranking['measured_u_best_candidate']:.4f}"
        )
    print(f"Checkpoint with the foresight head: {Path(cfg.output_dir) / CHECKPOINT_DIR}")
    return report


def main() -> None:
    cli_main(foresight_main)


if __name__ == "__main__":
    main()
