"""Stored LSTM states for sequence chunks that start mid-episode (truncated back-propagation through time).

A chunk shorter than its demo starts at some frame t > 0 of an episode. At rollout the LSTM memory there
holds everything since the episode's start; from zero memory the chunk would teach the policy a state it
never meets. `StoredLSTMStates` keeps, for every demo frame, the LSTM state (h, c) the last training pass
over that frame ended with, and hands the one of frame t - 1 to a chunk that starts at t (R2D2's "stored
state", Kapturowski et al. 2019): the memory reaches back to the episode's start, gradients stop at the
chunk's first frame, and a state is as fresh as the last pass over its frame. Frames never trained on yet,
and every episode's first frame, start from zero memory.
"""

from __future__ import annotations

import torch
from torch import Tensor


class StoredLSTMStates:
    """Per-frame LSTM states (h, c), addressed by the dataset's absolute frame index.

    Kept on the policy as a plain attribute (not a buffer): it is training state, never saved in a checkpoint.
    h and c of a frame are one row, written together, so a frame that two overlapping chunks of a batch both
    hold gets both halves from the same chunk.

    Args:
        hidden_size: the LSTM's width.
        num_frames: frames of the dataset (rows to allocate up front); 0 grows with the indices seen.
    """

    def __init__(self, hidden_size: int, num_frames: int = 0):
        self.hidden_size = hidden_size
        self.num_frames = num_frames
        self.states: Tensor | None = None  # (F, 2 * hidden_size): h then c
        self.episode: Tensor | None = None  # (F,) episode of each stored frame, -1 where none is stored

    def __len__(self) -> int:
        return 0 if self.episode is None else int((self.episode >= 0).sum())

    def initial(self, first_index: Tensor, episode_index: Tensor, like: Tensor) -> tuple[Tensor, Tensor]:
        """The memory each chunk starts from: the stored state of the frame before its first one, if that
        frame is of the same episode and was trained on; zeros otherwise.

        Args:
            first_index: (B,) absolute dataset index of each chunk's first frame.
            episode_index: (B,) episode of each chunk.
            like: a tensor whose dtype and device the memory takes.

        Returns:
            h0, c0, each (B, hidden_size), detached.
        """
        if self.episode is None:
            zeros = like.new_zeros(first_index.shape[0], self.hidden_size)
            return zeros, zeros.clone()
        before = first_index.to(self.episode.device) - 1
        inside = (before >= 0) & (before < self.episode.shape[0])
        rows = before.clamp(0, self.episode.shape[0] - 1)
        known = inside & (self.episode[rows] == episode_index.to(self.episode.device))
        states = torch.where(known[:, None], self.states[rows], 0.0).to(like)
        return states[:, : self.hidden_size], states[:, self.hidden_size :]

    @torch.no_grad()
    def store(self, frame_index: Tensor, episode_index: Tensor, h: Tensor, c: Tensor) -> None:
        """Keep the state (h, c) each of N frames ended with (each (N, hidden_size)), replacing older ones."""
        if frame_index.numel() == 0:
            return
        needed = int(frame_index.max()) + 1
        if self.episode is None or needed > self.episode.shape[0]:
            self._grow(max(needed, self.num_frames), h.device)
        rows = frame_index.to(self.episode.device)
        self.states[rows] = torch.cat([h, c], dim=-1).detach().float()
        self.episode[rows] = episode_index.to(self.episode.device)

    def _grow(self, size: int, device: torch.device) -> None:
        states = torch.zeros(size, 2 * self.hidden_size, device=device)
        episode = torch.full((size,), -1, dtype=torch.long, device=device)
        if self.episode is not None:
            old = self.episode.shape[0]
            states[:old], episode[:old] = self.states, self.episode
        self.states, self.episode = states, episode


@torch.no_grad()
def lstm_cell_states(cell: torch.nn.LSTMCell, s: Tensor, h: Tensor, h0: Tensor, c0: Tensor) -> Tensor:
    """The cell states c_t of an LSTM pass whose outputs h_t are known (the fused pass returns only the last).

    With every h_{t-1} known, all gates are one matrix product; c_t = f_t * c_{t-1} + i_t * g_t is then an
    element-wise scan.

    Args:
        cell: the LSTM cell the pass ran (PyTorch's gate order i, f, g, o).
        s: (B, L, D_s) the pass's inputs.
        h: (B, L, H) its outputs.
        h0, c0: (B, H) the memory it started from.

    Returns:
        (B, L, H) float32 cell states.
    """
    with torch.autocast(s.device.type, enabled=False):
        s, h, h0, c = s.float(), h.float(), h0.float(), c0.float()
        h_before = torch.cat([h0[:, None], h[:, :-1]], dim=1)
        gates = (
            s @ cell.weight_ih.float().T
            + h_before @ cell.weight_hh.float().T
            + cell.bias_ih.float()
            + cell.bias_hh.float()
        )
        i, f, g, _ = gates.chunk(4, dim=-1)
        keep, write = torch.sigmoid(f), torch.sigmoid(i) * torch.tanh(g)
        cells = []
        for t in range(s.shape[1]):
            c = keep[:, t] * c + write[:, t]
            cells.append(c)
        return torch.stack(cells, dim=1)
