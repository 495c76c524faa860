"""Bayesian VMC: VMC whose layers after the LSTM are concrete dropout + fully connected pairs.

At inference the CNN and LSTM run once per step and only the dropout + fully connected head runs S times,
as one batched pass; the executed action is the mean of the samples and the uncertainty is the trace of
the covariance of the transformed delta-EE samples (the paper's Eqs. (weighted-concat), (unc-tr-cov)).
"""

import logging
from dataclasses import dataclass
from pathlib import Path

import torch
from torch import Tensor, nn

from lerobot_ivmc.policies.bvmc.concrete_dropout import ConcreteDropoutHead
from lerobot_ivmc.policies.bvmc.configuration_bvmc import DEFAULT_DATASET_SIZE, BVMCConfig
from lerobot_ivmc.policies.bvmc.foresight import UncertaintyForesight, from_log_uncertainty
from lerobot_ivmc.policies.bvmc.threshold_record import ThresholdRecord
from lerobot_ivmc.policies.bvmc.uncertainty import trace_cov_uncertainty
from lerobot_ivmc.policies.vmc.gripper import DEFAULT_GRIPPER, GripperReadout
from lerobot_ivmc.policies.vmc.modeling_vmc import HUB_KWARGS, VMCPolicy

logger = logging.getLogger(__name__)


@dataclass
class MCPrediction:
    """Result of one Monte Carlo control step (`BVMCPolicy.sample`).

    Attributes:
        mean_action: (B, 4) action to execute: mean delta EE, and the gripper command of the class with
            the highest mean probability (a continuous gripper: the mean command).
        uncertainty: (B,) trace of the covariance of the transformed delta-EE samples, Eq. (unc-tr-cov).
        embedding: (B, lstm_dim) LSTM embedding e_t.
        delta_ee_samples: (B, S, 3) sampled delta end-effector commands.
        gripper_values: per sample, (B, S, G) gripper class probabilities (G = len(gripper_commands), by
            default 3: close, no-op, open), or (B, S, 1) commands of a continuous gripper.
        gripper: what `gripper_values` mean (`VMCConfig.gripper`).
    """

    mean_action: Tensor
    uncertainty: Tensor
    embedding: Tensor
    delta_ee_samples: Tensor
    gripper_values: Tensor
    gripper: GripperReadout = DEFAULT_GRIPPER

    @property
    def samples(self) -> Tensor:
        """(B, S, 4) sampled actions: delta EE and each sample's gripper command."""
        gripper = self.gripper.sample_commands(self.gripper_values)[..., None]
        return torch.cat([self.delta_ee_samples, gripper], dim=-1)


class BVMCPolicy(VMCPolicy):
    """Bayesian VMC with Monte Carlo inference.

    Attributes:
        mc_sampling: draw dropout masks at inference; initialised from `config.mc_sampling`. Training
            (`forward`) always draws them, whatever this flag and `self.training` say.

    Args:
        config: the policy config.
        dataset_meta: LeRobot dataset metadata; its `total_frames` gives N when `config.dataset_size` is None.
    """

    config_class = BVMCConfig
    name = "bvmc"
    # The recovery threshold picked for this policy (`lerobot-ivmc-threshold`), read with the checkpoint
    # (local or hub) and written back by `save_pretrained`, so `push_to_hub` keeps it.
    threshold_record: ThresholdRecord | None = None

    def __init__(self, config: BVMCConfig, dataset_meta=None, **kwargs):
        super().__init__(config, dataset_meta=dataset_meta, **kwargs)
        self.mc_sampling = config.mc_sampling
        self.foresight: UncertaintyForesight | None = None
        if config.foresight_enabled:
            self.attach_foresight()

    @classmethod
    def from_pretrained(cls, pretrained_name_or_path: str | Path, **kwargs):
        """LeRobot's loading (with VMC's legacy configs), and the checkpoint's threshold record if any."""
        policy = super().from_pretrained(pretrained_name_or_path, **kwargs)
        hub_kwargs = {k: kwargs[k] for k in HUB_KWARGS if k in kwargs and k != "resume_download"}
        policy.threshold_record = ThresholdRecord.load(pretrained_name_or_path, **hub_kwargs)
        return policy

    def forward(self, batch: dict[str, Tensor]) -> tuple[Tensor, dict[str, float]]:
        """VMC's training losses; a policy that trains drops its threshold (picked for other weights)."""
        self.threshold_record = None
        return super().forward(batch)

    def _save_pretrained(self, save_directory: Path) -> None:
        """LeRobot's config and weights, and the threshold record this policy was loaded with."""
        super()._save_pretrained(save_directory)
        if self.threshold_record is not None:
            self.threshold_record.save(save_directory)

    def attach_foresight(self) -> UncertaintyForesight:
        """Add an (untrained) uncertainty foresight head and mark it in the config, so checkpoints keep it."""
        self.config.foresight_enabled = True
        self.foresight = UncertaintyForesight(
            self.config.lstm_dim, self.config.action_dim, self.config.foresight_hidden_dim
        ).to(self.net.decoder.weight.device)
        return self.foresight

    @torch.no_grad()
    def foresee(self, embedding: Tensor, actions: Tensor) -> Tensor:
        """Foreseen uncertainty of the next step after each candidate action.

        Args:
            embedding: (B, lstm_dim) LSTM embedding e_t.
            actions: (B, S, 4) candidate actions (delta EE and gripper command).

        Returns:
            (B, S) predicted uncertainty at t + 1.
        """
        foresight = self.require_foresight()
        expanded = embedding[:, None].expand(-1, actions.shape[1], -1)
        return from_log_uncertainty(foresight(expanded, actions))

    def require_foresight(self) -> UncertaintyForesight:
        """The foresight head; a ValueError naming the command that trains one if the checkpoint has none."""
        if self.foresight is None:
            raise ValueError(
                "This bvmc checkpoint has no uncertainty foresight head: train one with "
                "`lerobot-ivmc-foresight --policy.path=<this checkpoint> ...` and use the checkpoint it "
                "writes."
            )
        return self.foresight

    def _make_head(self, config: BVMCConfig, dataset_meta=None) -> nn.Module:
        if config.dataset_size is None:
            total = getattr(dataset_meta, "total_frames", None)
            if total:
                config.dataset_size = int(total)
                # Right for the whole dataset (stock `lerobot-train`'s usual case), so not a warning.
                logger.info(
                    "Concrete dropout's N = %d, the whole dataset's frames. Training on a subset "
                    "(--dataset.episodes)? Pass --policy.dataset_size=<its frames>, or train with "
                    "lerobot-ivmc-train, which sets it.",
                    config.dataset_size,
                )
            else:
                logger.warning("dataset_size not set and no dataset given: using N=%d.", DEFAULT_DATASET_SIZE)
                config.dataset_size = DEFAULT_DATASET_SIZE
        n = config.dataset_size
        return ConcreteDropoutHead(
            in_dim=config.lstm_dim,
            hidden_dim=config.fc_dim,
            num_layers=config.num_fc_layers,
            init_p=config.dropout_init,
            temperature=config.dropout_temperature,
            weight_reg=config.length_scale**2 / n,
            dropout_reg=2.0 / n,
        )

    def dropout_probabilities(self) -> list[float]:
        """The learned dropout probability of each concrete dropout layer."""
        return self.net.head.dropout_probabilities()

    def draw_noise(
        self, batch_size: int, num_samples: int, generators: list[torch.Generator] | None = None
    ) -> list[Tensor]:
        """Uniform noise fixing the masks of every dropout layer: a list of (B, S, K_l) tensors, from torch's
        global generator, or row b from `generators[b]` (CPU generators, one per row)."""
        device = self.net.decoder.weight.device
        if generators is None:
            return [
                torch.rand(shape, device=device)
                for shape in self.net.head.noise_shapes(batch_size, num_samples)
            ]
        if len(generators) != batch_size:
            raise ValueError(f"draw_noise needs one generator per row: {len(generators)} for {batch_size}.")
        shapes = self.net.head.noise_shapes(1, num_samples)
        rows = generators
        return [torch.cat([torch.rand(shape, generator=g) for g in rows]).to(device) for shape in shapes]

    def sample_head(
        self, embedding: Tensor, num_samples: int, noise: list[Tensor] | None = None
    ) -> tuple[Tensor, Tensor]:
        """Run the dropout + fully connected head S times on e_t, as one batched pass.

        Args:
            embedding: (B, lstm_dim) LSTM embedding.
            num_samples: S.
            noise: optional uniform noise per dropout layer, each (B, S, K_l), to fix the masks.

        Returns:
            (B, S, 3) delta-EE samples and the (B, S, G) gripper values (`MCPrediction.gripper_values`).
            Without `mc_sampling` the head runs once, deterministically, and its output is repeated S times.
        """
        if self.mc_sampling:
            expanded = embedding[:, None].expand(-1, num_samples, -1)
            delta_ee, gripper_output, _, _ = self.net.decode(expanded, stochastic=True, noise=noise)
        else:
            delta_ee, gripper_output, _, _ = self.net.decode(embedding[:, None], stochastic=False)
            delta_ee = delta_ee.expand(-1, num_samples, -1)
            gripper_output = gripper_output.expand(-1, num_samples, -1)
        return delta_ee, self.config.gripper.sample_values(gripper_output)

    @torch.no_grad()
    def sample(
        self, batch: dict[str, Tensor], num_samples: int | None = None, noise: list[Tensor] | None = None
    ) -> MCPrediction:
        """One control step: mean action, uncertainty, embedding e_t and the S sampled actions.

        The CNN and LSTM run once and advance the LSTM memory by one step (save it first with
        `get_memory` to back-track); the head runs S times as one batched pass.

        Args:
            batch: preprocessed observation: image (B, 3, H, W), `observation.state` (B, D).
            num_samples: S >= 2; defaults to `config.num_samples`.
            noise: optional uniform noise per dropout layer, each (B, S, K_l) (see `draw_noise`).

        Returns:
            The `MCPrediction`.
        """
        embedding, delta_ee, gripper_values = self._mc_step(batch, num_samples, noise)
        return make_prediction(
            embedding, delta_ee, gripper_values, self.config.uncertainty_lambda, self.config.gripper
        )

    def _mc_step(
        self, batch: dict[str, Tensor], num_samples: int | None, noise: list[Tensor] | None
    ) -> tuple[Tensor, Tensor, Tensor]:
        """CNN + LSTM once, head S times: e_t (B, H), delta-EE samples (B, S, 3), gripper values (B, S, G)."""
        num_samples = self.config.num_samples if num_samples is None else num_samples
        if num_samples < 2:
            raise ValueError(f"The uncertainty needs at least 2 samples, got num_samples={num_samples}.")
        embedding = self.step_embedding(batch)
        return (embedding, *self.sample_head(embedding, num_samples, noise))

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """The action to execute, (B, 4): the Monte Carlo mean when `mc_sampling` is set (one LSTM step).

        Skips the uncertainty; call `sample` to get it.
        """
        if not self.mc_sampling:
            return super().select_action(batch)
        self.eval()
        _, delta_ee, gripper_values = self._mc_step(batch, None, None)
        return mean_action(delta_ee, gripper_values, self.config.gripper)


def mean_action(
    delta_ee: Tensor, gripper_values: Tensor, gripper: GripperReadout = DEFAULT_GRIPPER
) -> Tensor:
    """(B, 4) mean delta EE of the (B, S, 3) samples and the gripper's mean command of its (B, S, G) values
    (classes: the command of the class of highest mean probability)."""
    return torch.cat([delta_ee.mean(dim=1), gripper.mean_command(gripper_values)[:, None]], dim=-1)


def make_prediction(
    embedding: Tensor,
    delta_ee: Tensor,
    gripper_values: Tensor,
    lam: float,
    gripper: GripperReadout = DEFAULT_GRIPPER,
) -> MCPrediction:
    """Assemble an `MCPrediction` from (B, S, 3) delta-EE samples and the (B, S, G) gripper values that
    `gripper` reads."""
    return MCPrediction(
        mean_action=mean_action(delta_ee, gripper_values, gripper),
        uncertainty=trace_cov_uncertainty(delta_ee, lam),
        embedding=embedding,
        delta_ee_samples=delta_ee,
        gripper_values=gripper_values,
        gripper=gripper,
    )
