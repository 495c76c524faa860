"""Per-step uncertainty traces of evaluated episodes: assembled from the controller, saved as one npz."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lerobot_ivmc.recovery.controller import BatchTrace
from lerobot_ivmc.recovery.manoeuvres import PHASE_NAMES
from lerobot_ivmc.recovery.time_baseline import episode_score

TRACES_FILE = "uncertainty_traces.npz"


def episode_traces(
    batches: list[BatchTrace],
    lengths_per_env: list[list[int]],
    n_episodes: int,
    window: int,
    baseline: np.ndarray | None = None,
) -> list[dict]:
    """The traces of the evaluated episodes in `eval_policy`'s order (batch-major, then sub-env).

    Args:
        batches: the controller's traces, one per `rollout`.
        lengths_per_env: per sub-env, the lengths of its seeded episodes (`MilestoneRecorder`).
        n_episodes: episodes evaluated (the last batch may hold extra ones, which are dropped).
        window: the sliding window for u.
        baseline: (T,) the time-conditioned score's baseline of the threshold, None for the paper's score.

    Returns:
        Per episode: "uncertainty", "window_sum", "phase" arrays, "events" and "max_uncertainty" (u, the
        maximum sliding-window sum of the step uncertainties, or of its time-conditioned score, whatever the
        trigger cleared).
    """
    episodes = []
    for b, trace in enumerate(batches):
        for j in range(len(lengths_per_env)):
            if len(episodes) == n_episodes:
                return episodes
            episode = trace.episode(j, lengths_per_env[j][b])
            episode["max_uncertainty"] = episode_score(episode["uncertainty"], window, baseline)
            episodes.append(episode)
    return episodes


def save_traces(path: Path, episodes: list[dict], seeds: list[int | None]) -> Path:
    """One npz: per-step arrays of all episodes concatenated, with `episode_start` offsets.

    Keys: uncertainty, window_sum, phase (int8; names in `phase_names`), step, episode (index per step),
    episode_start (E + 1 offsets), seed (E), max_uncertainty (E). `load_traces` splits them again.
    """
    lengths = [len(e["uncertainty"]) for e in episodes]
    np.savez_compressed(
        path,
        uncertainty=np.concatenate([e["uncertainty"] for e in episodes]),
        window_sum=np.concatenate([e["window_sum"] for e in episodes]),
        phase=np.concatenate([e["phase"] for e in episodes]),
        step=np.concatenate([np.arange(n) for n in lengths]),
        episode=np.repeat(np.arange(len(episodes)), lengths),
        episode_start=np.concatenate([[0], np.cumsum(lengths)]),
        seed=np.array([-1 if s is None else s for s in seeds], dtype=np.int64),
        max_uncertainty=np.array([e["max_uncertainty"] for e in episodes]),
        phase_names=np.array(PHASE_NAMES),
    )
    return path


def load_traces(path: Path | str) -> list[dict[str, np.ndarray]]:
    """Per episode: its uncertainty, window_sum and phase arrays, seed and max_uncertainty."""
    with np.load(path) as data:
        start = data["episode_start"]
        return [
            {
                "uncertainty": data["uncertainty"][a:b],
                "window_sum": data["window_sum"][a:b],
                "phase": data["phase"][a:b],
                "seed": int(data["seed"][i]),
                "max_uncertainty": float(data["max_uncertainty"][i]),
            }
            for i, (a, b) in enumerate(zip(start[:-1], start[1:], strict=True))
        ]
