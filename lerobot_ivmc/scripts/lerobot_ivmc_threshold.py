"""`lerobot-ivmc-threshold`: pick the recovery threshold of a bvmc checkpoint on validation scenes.

Runs the Bayesian VMC (mean of S samples, no recovery) through `lerobot-ivmc-eval` on validation
scenes, records per episode its success and u (the maximum sliding-window sum of step uncertainties),
picks the threshold with the paper's argmax, and writes a NEW checkpoint folder
`<output_dir>/pretrained_model`: a copy of the input with `recovery_threshold.json` (the threshold, the
window and the (u, success) pairs it came from), which `lerobot-ivmc-eval --recovery.mode=...` finds from
`--policy.path` alone. The evaluation's own outputs (eval_info.json, traces, Fig. 3) stay in `<output_dir>`.

    lerobot-ivmc-threshold --policy.path=<bvmc checkpoint> --env.type=ivmc --env.task=pick_place \\
        --env.split=val --eval.n_episodes=100 --eval.batch_size=10 --seed=0 --output_dir=outputs/threshold
"""

# No `from __future__ import annotations`: LeRobot's parser.wrap reads the config class from the annotation.
from pathlib import Path

from lerobot.configs import parser

from lerobot_ivmc.cli import cli_main
from lerobot_ivmc.evaluation.threshold_picking import CHECKPOINT_DIR, ThresholdPipelineConfig, pick
from lerobot_ivmc.evaluation.traces import TRACES_FILE, load_traces
from lerobot_ivmc.recovery.threshold import ThresholdRecord


@parser.wrap()
def threshold_main(cfg: ThresholdPipelineConfig) -> ThresholdRecord:
    record = pick(cfg)
    above = sum(e["u"] > record.threshold for e in record.episodes)
    score = (
        "window sum" if record.baseline is None else f"time-conditioned, quantile {record.baseline_quantile}"
    )
    print(
        f"{record.task}: threshold C = {record.threshold:.4f} ({record.method}, window {record.window}, "
        f"{score}) from {len(record.episodes)} {record.split} episodes; {above} of them exceed it."
    )
    if record.score_auroc is not None:
        print(f"Validation AUROC of each score: {record.score_auroc}")
    traces = load_traces(Path(cfg.output_dir) / TRACES_FILE)
    pairs = zip(traces, record.episodes, strict=True)
    success_steps = [len(trace["uncertainty"]) for trace, episode in pairs if episode["success"]]
    if success_steps:
        print(
            f"Successful {record.split} episodes ran {min(success_steps)} to {max(success_steps)} steps: "
            f"--recovery.deadline=auto also recovers rollouts that run {record.deadline} steps."
        )
    if all(e["success"] for e in record.episodes):
        print(
            f"No {record.split} episode failed: the threshold has nothing to learn from. Recovery will "
            "trigger only above every validation episode's uncertainty; to bound false alarms instead, use "
            "--method=conformal --alpha=<rate>."
        )
    print(f"Checkpoint with the threshold: {Path(cfg.output_dir) / CHECKPOINT_DIR}")
    return record


def main() -> None:
    cli_main(threshold_main)


if __name__ == "__main__":
    main()
