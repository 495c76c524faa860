"""Configuration of Bayesian VMC: VMC with concrete dropout layers after the LSTM (the paper's Fig. 2)."""

from __future__ import annotations

from dataclasses import dataclass

from lerobot.configs.policies import PreTrainedConfig

from lerobot_ivmc.policies.vmc.configuration_vmc import VMCConfig

# N for the regularisers when neither the config nor the dataset gives it: 1,000 demos of 100 frames.
DEFAULT_DATASET_SIZE = 100_000


@PreTrainedConfig.register_subclass("bvmc")
@dataclass
class BVMCConfig(VMCConfig):
    """Bayesian VMC: every fully connected layer after the LSTM is preceded by a concrete dropout layer.

    All VMC fields apply; `num_fc_layers` (#fc, 1 or 2) is also the number of dropout layers.

    Args:
        dropout_init: initial dropout probability of every concrete dropout layer (Gal et al.: 0.1).
        dropout_temperature: temperature of the relaxed Bernoulli masks (Gal et al.: 0.1).
        length_scale: prior length-scale l; weight regulariser = l^2 / N.
        dataset_size: N, training frames scaling both regularisers (dropout regulariser = 2 / N). None:
            filled from the dataset by `lerobot-train`, else DEFAULT_DATASET_SIZE.
        mc_sampling: draw dropout masks at inference (`select_action` returns the mean of the samples).
            An explicit switch: LeRobot puts the policy in eval mode before acting.
        num_samples: S, Monte Carlo samples per step (the paper: 50, where the sampled error converges).
        uncertainty_lambda: lambda of Eq. (weighted-concat), weight of the command's norm against its
            direction. The paper tunes it without giving a value; 0.5 weighs both equally.
        foresight_enabled: the checkpoint holds an uncertainty foresight head (the paper's Fig. 2, orange),
            trained by `lerobot-ivmc-foresight` after the policy; False for a freshly trained policy.
        foresight_hidden_dim: width of the hidden layer of the foresight head's two fully connected layers
            (the paper says only "small"; 64 is half the LSTM width).
        foresight_action_noise: standard deviation (action units) of the Gaussian noise on the end-effector
            move of the sampled actions the head was distilled on (`--foresight.action_noise`), and so of
            the candidates min_unc ranks with it by default; 0 = the paper's plain Monte Carlo samples.
    """

    # Concrete dropout (training).
    dropout_init: float = 0.1
    dropout_temperature: float = 0.1
    length_scale: float = 1e-2
    dataset_size: int | None = None

    # Monte Carlo inference.
    mc_sampling: bool = True
    num_samples: int = 50
    uncertainty_lambda: float = 0.5

    # Uncertainty foresight (trained by distillation after the policy: `lerobot-ivmc-foresight`).
    foresight_enabled: bool = False
    foresight_hidden_dim: int = 64
    foresight_action_noise: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0.0 < self.dropout_init < 1.0:
            raise ValueError(f"dropout_init must lie in (0, 1), got {self.dropout_init}.")
        if self.dropout_temperature <= 0:
            raise ValueError(f"dropout_temperature must be positive, got {self.dropout_temperature}.")
        if self.length_scale < 0:
            raise ValueError(f"length_scale must be >= 0, got {self.length_scale}.")
        if self.dataset_size is not None and self.dataset_size <= 0:
            raise ValueError(f"dataset_size must be positive, got {self.dataset_size}.")
        if self.num_samples < 2:
            raise ValueError(
                f"num_samples (S) must be >= 2 to estimate the uncertainty, got {self.num_samples}."
            )
        if not 0.0 <= self.uncertainty_lambda <= 1.0:
            raise ValueError(f"uncertainty_lambda must lie in [0, 1], got {self.uncertainty_lambda}.")
        if self.foresight_hidden_dim <= 0:
            raise ValueError(f"foresight_hidden_dim must be positive, got {self.foresight_hidden_dim}.")
        if not 0.0 <= self.foresight_action_noise <= 1.0:
            raise ValueError(
                f"foresight_action_noise is a standard deviation in action units, in [0, 1]; got "
                f"{self.foresight_action_noise}."
            )
