"""Introspection and recovery (the paper's Section "Recovery from Failures" and Algorithm 1).

- `threshold`: the paper's u (maximum sliding-window sum of step uncertainties) and its threshold pick.
- `trigger`: when to recover (window sum over the threshold, exponential backoff of the interval).
- `controller`: a LeRobot policy that runs Bayesian VMC with Algorithm 1 inside LeRobot's rollout.
- `strategies/`: what a rollout does once the trigger fires, one module per `--recovery.mode`;
  `strategy_settings`: each strategy's `--recovery.<mode>.*` settings; `config`: `RecoveryConfig`.
- `manoeuvres`, `anchor`: the moves the strategies make, through the robot's embodiment.
- `foresight_data`, `foresight_training`, `foresight_ranking`: distillation of the uncertainty foresight head.
"""

from lerobot_ivmc.recovery.config import RECOVERY_MODES, RecoveryConfig

__all__ = ["RECOVERY_MODES", "RecoveryConfig"]
