"""Whole-demo (sequence) training: which frames of a sampled chunk are real, and the chunk lengths the
demos allow."""

from __future__ import annotations

import torch
from lerobot.utils.constants import ACTION, OBS_STATE
from torch import Tensor

from lerobot_ivmc.policies.vmc.configuration_vmc import VMCConfig


def chunk_frames_mask(batch: dict[str, Tensor], shape: torch.Size) -> Tensor:
    """(B, L) bool, True for a chunk's real frames (False past its episode's end, where LeRobot pads).

    A chunk must start on a real frame and its padding must come after its real frames: anything else
    would put frames of before an episode's start into the carried memory.
    """
    is_pad = batch.get(f"{ACTION}_is_pad", batch.get(f"{OBS_STATE}_is_pad"))
    if is_pad is None:
        return torch.ones(shape, dtype=torch.bool, device=batch[ACTION].device)
    real = ~is_pad.bool()
    if not real[:, 0].all() or (real[:, 1:] & ~real[:, :-1]).any():
        raise ValueError(
            "Sequence chunks must start on a real frame and be padded only after their episode's end; "
            "got padding before or between real frames. Use the policy's own (forward) delta indices."
        )
    return real


def episode_lengths(dataset_meta=None) -> list[int]:
    """The frames of each episode of a LeRobot dataset's metadata; empty when unknown."""
    episodes = getattr(dataset_meta, "episodes", None)  # a Hugging Face dataset, one row per episode
    if episodes is None or "length" not in episodes.column_names:
        return []
    return [int(length) for length in episodes["length"]]


def check_chunk_length(config: VMCConfig, dataset_meta=None) -> None:
    """Refuse a sequence chunk longer than the shortest training episode (that episode would never be
    sampled: chunks start only where they fit)."""
    lengths = episode_lengths(dataset_meta)
    if config.training_mode != "sequence" or not lengths:
        return
    shortest, longest = min(lengths), max(lengths)
    if config.goal_head and config.chunk_length != longest:
        raise ValueError(
            "goal_head learns the object's position at each demo's end, so every chunk must be a whole "
            f"demo: chunk_length={config.chunk_length} but the demos last {shortest} to {longest} frames. "
            f"Set --policy.chunk_length={shortest} on a dataset whose demos all last that long, or drop "
            "--policy.goal_head."
        )
    if config.chunk_length > shortest:
        raise ValueError(
            f"chunk_length={config.chunk_length} exceeds the shortest episode of the dataset "
            f"({shortest} frames), which would never be trained on: set --policy.chunk_length to at most "
            f"{shortest}."
        )
