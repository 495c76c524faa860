"""Training the uncertainty foresight head by distillation, and how well it foresees.

The head regresses log(u_{t+1}) from (e_t, a_t) with a mean squared error (`foresight.LOG_FLOOR`).
Quality is measured on held-out trajectories: Spearman's rank correlation and R^2 between foreseen and
measured next-step uncertainty (R^2 in the log space it is trained in, and in u itself), next to the
baseline that foresees u_{t+1} = u_t (which needs no head but cannot rank actions).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from scipy import stats
from sklearn.metrics import r2_score
from tqdm import trange

from lerobot_ivmc.policies.bvmc.foresight import UncertaintyForesight, from_log_uncertainty, log_uncertainty


@dataclass
class ForesightConfig:
    """Distillation settings (`--foresight.<field>=` on `lerobot-ivmc-foresight`).

    Args:
        num_trajectories: Bayesian VMC episodes to record (the paper: 2,000), rounded up to whole batches
            of `--eval.batch_size` episodes.
        split: scene split of the distillation episodes (the paper: training scenes).
        epochs: passes over the training records.
        batch_size: records per update.
        lr: Adam learning rate.
        weight_decay: Adam weight decay.
        heldout_fraction: share of the trajectories (the last ones) kept out of training for the report.
        ranking_states: states at which the head's ranking of the S candidate actions is checked against
            trying each in a copy of the env (0 skips the check).
        ranking_every: those states are every this many steps along Bayesian VMC episodes.
        action_noise: standard deviation (action units) of Gaussian noise added to the end-effector move
            of each executed sample during distillation, and to the candidates of the ranking check; stored
            in the checkpoint as the noise min_unc widens its candidates with. 0 = the paper's samples.
    """

    num_trajectories: int = 200
    split: str = "train"
    epochs: int = 30
    batch_size: int = 256
    lr: float = 1e-3
    weight_decay: float = 1e-5
    heldout_fraction: float = 0.1
    ranking_states: int = 100
    ranking_every: int = 15
    action_noise: float = 0.0

    def __post_init__(self) -> None:
        if self.num_trajectories < 2:
            raise ValueError(f"--foresight.num_trajectories must be >= 2, got {self.num_trajectories}.")
        if self.epochs < 1 or self.batch_size < 1 or self.lr <= 0:
            raise ValueError(
                "--foresight.epochs, --foresight.batch_size and --foresight.lr must be positive."
            )
        if not 0.0 < self.heldout_fraction < 1.0:
            raise ValueError(f"--foresight.heldout_fraction must lie in (0, 1), got {self.heldout_fraction}.")
        if self.ranking_states < 0 or self.ranking_every < 1:
            raise ValueError("--foresight.ranking_states must be >= 0 and --foresight.ranking_every >= 1.")
        if not 0.0 <= self.action_noise <= 1.0:
            raise ValueError(
                f"--foresight.action_noise is a standard deviation in action units, in [0, 1]; got "
                f"{self.action_noise}."
            )


def split_by_trajectory(
    records: dict[str, np.ndarray], heldout_fraction: float
) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks (train, held out): the last `heldout_fraction` of the trajectories are held out."""
    trajectories = np.unique(records["trajectory"])
    if len(trajectories) < 2:
        raise ValueError("Distillation needs at least 2 trajectories (one to train on, one to hold out).")
    num_heldout = max(1, int(round(len(trajectories) * heldout_fraction)))
    heldout = np.isin(records["trajectory"], trajectories[-num_heldout:])
    return ~heldout, heldout


def train_foresight(
    head: UncertaintyForesight, records: dict[str, np.ndarray], cfg: ForesightConfig, seed: int
) -> list[float]:
    """Fit the head on `records` (embedding, action, next_uncertainty); return the loss of each epoch."""
    generator = torch.Generator().manual_seed(seed)
    inputs_e = torch.as_tensor(records["embedding"], dtype=torch.float32)
    inputs_a = torch.as_tensor(records["action"], dtype=torch.float32)
    target = log_uncertainty(torch.as_tensor(records["next_uncertainty"], dtype=torch.float32))
    optimizer = torch.optim.Adam(head.parameters(), lr=cfg.lr, weight_decay=cfg.weight_decay)
    losses = []
    head.train()
    progress = trange(cfg.epochs, desc="Foresight training (epochs)")
    for _ in progress:
        order = torch.randperm(len(target), generator=generator)
        total = 0.0
        for start in range(0, len(order), cfg.batch_size):
            index = order[start : start + cfg.batch_size]
            loss = torch.nn.functional.mse_loss(head(inputs_e[index], inputs_a[index]), target[index])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += loss.item() * len(index)
        losses.append(total / len(order))
        progress.set_postfix(mse_log_u=f"{losses[-1]:.4f}")
    head.eval()
    return losses


@torch.no_grad()
def foresight_quality(head: UncertaintyForesight, records: dict[str, np.ndarray]) -> dict[str, float]:
    """Spearman rho and R^2 of foreseen vs measured next-step uncertainty, and the persistence baseline."""
    log_pred = head(
        torch.as_tensor(records["embedding"], dtype=torch.float32),
        torch.as_tensor(records["action"], dtype=torch.float32),
    )
    predicted = from_log_uncertainty(log_pred).numpy()
    measured = records["next_uncertainty"].astype(np.float64)
    current = records["uncertainty"].astype(np.float64)
    log_measured = log_uncertainty(torch.as_tensor(measured)).numpy()
    return {
        "num_records": int(len(measured)),
        "spearman_rho": float(stats.spearmanr(predicted, measured).statistic),
        "r2_log": float(r2_score(log_measured, log_pred.numpy())),
        "r2": float(r2_score(measured, predicted)),
        "baseline_persistence_spearman_rho": float(stats.spearmanr(current, measured).statistic),
        "baseline_persistence_r2": float(r2_score(measured, current)),
    }
