"""What a vmc or bvmc model card says beyond LeRobot's template: the paper, the training data's task and
camera, and for a bvmc its recovery threshold (`lerobot-ivmc-threshold`)."""

from __future__ import annotations

from lerobot_ivmc.policies.bvmc.threshold_record import ThresholdRecord

PAPER = (
    'C.-M. Hung, L. Sun, Y. Wu, I. Havoutis and I. Posner, "Introspective Visuomotor Control: Exploiting '
    'Uncertainty in Deep Visuomotor Control for Failure Recovery", ICRA 2021 (arXiv:2103.11881)'
)


def model_card_section(config, threshold_record: ThresholdRecord | None) -> str:
    """Markdown appended to LeRobot's model card of a vmc or bvmc policy."""
    kind = (
        "Bayesian visuomotor control: concrete dropout after the LSTM, the action the mean of "
        f"{getattr(config, 'num_samples', '?')} Monte Carlo samples, their uncertainty a failure warning"
        if config.type == "bvmc"
        else "visuomotor control: a CNN and an LSTM from camera and proprioception to end-effector moves"
    )
    lines = [
        "",
        "## Introspective Visuomotor Control (lerobot-ivmc)",
        "",
        f"A `{config.type}` policy of the lerobot-ivmc plugin ({kind}; #fc = {config.num_fc_layers}), after "
        f"{PAPER}.",
        "",
        f"- Trained on: {config.trained_task or 'a dataset not made by lerobot-ivmc-collect'} demos, "
        f"{config.render_style} render style.",
    ]
    if threshold_record is not None:
        r = threshold_record
        score = "" if r.baseline is None else f", time-conditioned at quantile {r.baseline_quantile}"
        lines.append(
            f"- Recovery threshold C = {r.threshold:.4g} ({r.method}, window {r.window}{score}) picked on "
            f"{len(r.episodes)} {r.split} episodes of {r.task}; `lerobot-ivmc-eval --policy.path=<this repo> "
            "--recovery.mode=<mode>` reads it."
        )
    elif config.type == "bvmc":
        lines.append("- No recovery threshold yet: pick one with `lerobot-ivmc-threshold`.")
    return "\n".join(lines) + "\n"
