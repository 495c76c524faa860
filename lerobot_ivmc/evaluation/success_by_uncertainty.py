"""The paper's Fig. 3: task success against maximum uncertainty, episodes sorted by u in 10 bins."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from scipy import stats


def success_by_uncertainty_bins(
    scores: Sequence[float], successes: Sequence[bool], num_bins: int = 10
) -> dict:
    """Sort episodes by u, split them into `num_bins` bins of (nearly) equal size, and per bin give the
    mean u and the task success rate; Spearman's rho between the two over the bins.

    Returns:
        {"mean_u", "success_rate", "count"} lists per bin, "spearman_rho" and "spearman_p" (NaN when
        either is constant), "spearman_rho_best" (`most_negative_rho`), "num_episodes".
    """
    u = np.asarray(scores, dtype=np.float64)
    ok = np.asarray(successes, dtype=np.float64)
    if u.shape != ok.shape or len(u) == 0:
        raise ValueError(f"Need one success flag per score, got {u.shape} and {ok.shape}.")
    bins = [b for b in np.array_split(np.argsort(u, kind="stable"), min(num_bins, len(u))) if len(b)]
    mean_u = [float(u[b].mean()) for b in bins]
    rate = [float(ok[b].mean()) for b in bins]
    rho, p = (np.nan, np.nan)
    if _rho_defined(mean_u, rate):
        result = stats.spearmanr(mean_u, rate)
        rho, p = float(result.statistic), float(result.pvalue)
    return {
        "mean_u": mean_u,
        "success_rate": rate,
        "count": [len(b) for b in bins],
        "spearman_rho": rho,
        "spearman_p": p,
        "spearman_rho_best": most_negative_rho(mean_u, rate),
        "num_episodes": len(u),
    }


def most_negative_rho(mean_u: Sequence[float], success_rate: Sequence[float]) -> float:
    """The most negative Spearman rho these bins' success rates allow: the rates sorted from highest to lowest
    uncertainty-wise. Ties bound it: a perfect split into bins of 100% and 0% reaches only about -0.8 (-0.80
    for 7 and 3 bins of 10), so a rho at this bound means the uncertainty orders the bins perfectly. NaN
    when either is constant."""
    rate = np.asarray(success_rate, dtype=np.float64)
    if not _rho_defined(mean_u, rate):
        return float("nan")
    return float(
        stats.spearmanr(np.sort(np.asarray(mean_u, dtype=np.float64)), np.sort(rate)[::-1]).statistic
    )


def _rho_defined(mean_u: Sequence[float], success_rate: Sequence[float]) -> bool:
    """Whether Spearman's rho over the bins is defined: more than two bins, neither u nor success constant."""
    return len(success_rate) > 2 and np.ptp(mean_u) > 0 and np.ptp(success_rate) > 0


def plot_success_by_uncertainty(binned: dict, path: Path, title: str) -> Path:
    """Write the Fig. 3 plot (PNG) of `success_by_uncertainty_bins`'s output."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(4.5, 3.4), dpi=120)
    ax.plot(binned["mean_u"], np.asarray(binned["success_rate"]) * 100, "o-", color="tab:red")
    ax.set_xlabel("maximum uncertainty u (bin mean)")
    ax.set_ylabel("task success [%]")
    ax.set_ylim(-5, 105)
    ax.set_title(title, fontsize=9)
    rho, best = binned["spearman_rho"], binned.get("spearman_rho_best", float("nan"))
    bound = "" if np.isnan(best) else f" (best attainable {best:.2f})"
    rho_text = "undefined (success the same in every bin)" if np.isnan(rho) else f"{rho:.2f}{bound}"
    ax.text(  # bottom left: empty when success falls with u, as when it stays flat at the top
        0.03,
        0.05,
        f"Spearman rho = {rho_text}\n{binned['num_episodes']} episodes, {len(binned['count'])} bins",
        transform=ax.transAxes,
        ha="left",
        va="bottom",
        fontsize=8,
    )
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
