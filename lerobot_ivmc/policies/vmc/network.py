"""The visuomotor network VMC and Bayesian VMC share (`gripper.py` turns its gripper outputs into commands).

CNN over the RGB frame -> spatial feature map concatenated with the tiled proprioception -> LSTM ->
#fc fully connected layers -> four heads: delta end-effector command, gripper (classes or a command),
auxiliary end-effector and object positions; optionally (beyond the paper) the object's position at the
end of the demo (`goal_head`) and the positions read from each frame's CNN map (`frame_position_head`).
"""

from __future__ import annotations

import contextlib

import torch
import torch.nn.functional as F  # noqa: N812
from torch import Tensor, nn

from lerobot_ivmc.hardware import cpu_has_native_bf16
from lerobot_ivmc.policies.vmc.configuration_vmc import AUX_DIM, VMCConfig

# One position (x, y, z) of `observation.environment_state`: the end effector's, then the object's.
POSITION_DIM = AUX_DIM // 2
# Rollout memory: the LSTM state (h, c), or the last K state representations (`rollout_memory`).
Memory = tuple[Tensor, ...]
# The frame position head's (N, 6) or, with the goal head, (N, 9) predictions and their targets; None
# without that head.
FramePositions = tuple[Tensor, Tensor] | None


class MLPHead(nn.Module):
    """[linear -> ReLU] x num_layers: VMC's deterministic fully connected layers after the LSTM."""

    def __init__(self, in_dim: int, hidden_dim: int, num_layers: int):
        super().__init__()
        dims = [in_dim] + [hidden_dim] * num_layers
        self.linears = nn.ModuleList(nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:], strict=True))
        self.out_dim = hidden_dim

    def forward(self, x: Tensor, stochastic: bool = False, noise: list[Tensor] | None = None) -> Tensor:
        """(..., in_dim) -> (..., hidden_dim). `stochastic` and `noise` are ignored: nothing is random."""
        for linear in self.linears:
            x = torch.relu(linear(x))
        return x

    def regularization(self) -> Tensor:
        return self.linears[0].weight.new_zeros(())

    def dropout_probabilities(self) -> list[float]:
        return []


class VisuomotorNet(nn.Module):
    """CNN + tiled state -> LSTM cell -> head -> decoder.

    Args:
        config: the policy config (architecture fields).
        image_shape: (3, H, W) of the camera.
        state_dim: size of `observation.state`.
        head: the layers between the LSTM embedding and the decoder, `MLPHead` or a concrete dropout head.
    """

    def __init__(self, config: VMCConfig, image_shape: tuple[int, ...], state_dim: int, head: nn.Module):
        super().__init__()
        layers: list[nn.Module] = []
        in_ch = image_shape[0]
        for out_ch in config.conv_channels:
            layers += [nn.Conv2d(in_ch, out_ch, kernel_size=3, stride=2, padding=1), nn.ReLU()]
            in_ch = out_ch
        self.cnn = nn.Sequential(*layers)
        with torch.no_grad():
            _, channels, height, width = self.cnn(torch.zeros(1, *image_shape)).shape
        self.map_size = (height, width)
        self.lstm = nn.LSTMCell((channels + state_dim) * height * width, config.lstm_dim)
        self.head = head
        # delta EE (3) | gripper (G logits, one per `VMCConfig.gripper_commands`, or 1 continuous command:
        # `VMCConfig.gripper`) | EE position (3) | object
        # position (3); the positions only for a dataset with auxiliary targets (`VMCConfig.aux_indices`).
        self.has_aux = config.aux_indices is not None
        self.command_dim = config.action_dim - 1  # the continuous part of the action (the delta EE)
        self.gripper_dim = config.gripper.out_dim
        self.decoder = nn.Linear(
            head.out_dim, self.command_dim + self.gripper_dim + (AUX_DIM if self.has_aux else 0)
        )
        # Object position at the demo's end (`goal_head`): a training target only, never used to act.
        self.goal_decoder = nn.Linear(head.out_dim, POSITION_DIM) if config.goal_head else None
        # EE and object positions (and with the goal head, the object's at the demo's end) from one frame's
        # CNN map (`frame_position_head`): a training target only.
        frame_targets = AUX_DIM + (POSITION_DIM if config.goal_head else 0)
        self.frame_position_decoder = (
            nn.Linear(channels * height * width, frame_targets) if config.frame_position_head else None
        )

    def encode(self, images: Tensor, state: Tensor) -> Tensor:
        """State representation s_t: (N, 3, H, W) images, (N, D_state) -> (N, D_s)."""
        return self._state_representation(self.cnn(images), state)

    def encode_with_positions(self, images: Tensor, state: Tensor) -> tuple[Tensor, Tensor | None]:
        """s_t as `encode`, and (training only) the frame position head's (N, 6) EE and object positions
        read from the CNN map alone (normalised like `observation.environment_state`; (N, 9) with the goal
        head: then the object's position at the demo's end); None for a net without that head."""
        fmap = self.cnn(images)
        s = self._state_representation(fmap, state)
        if self.frame_position_decoder is None:
            return s, None
        return s, self.frame_position_decoder(fmap.flatten(1))

    def _state_representation(self, fmap: Tensor, state: Tensor) -> Tensor:
        """The CNN map (N, C, h, w) and the state tiled over it, flattened: (N, D_s)."""
        tiled = state[:, :, None, None].expand(-1, -1, *self.map_size)
        return torch.cat([fmap, tiled], dim=1).flatten(1)

    def step(self, s: Tensor, memory: Memory | None) -> Memory:
        """One LSTM step: (B, D_s) and memory (or None for zeros) -> new memory (h, c); h is e_t."""
        return self.lstm(s, memory)

    def unroll(self, s: Tensor, is_pad: Tensor | None = None) -> Tensor:
        """Run the LSTM over a window from zero memory; padded steps leave the memory untouched.

        LeRobot pads only before an episode's start, so a padded window equals a rollout from `reset()`.

        Args:
            s: (B, K, D_s) state representations.
            is_pad: optional (B, K) bool, True for padded steps.

        Returns:
            (B, lstm_dim) embedding e_t of the last step.
        """
        h = c = s.new_zeros(s.shape[0], self.lstm.hidden_size)
        for k in range(s.shape[1]):
            h_new, c_new = self.lstm(s[:, k], (h, c))
            if is_pad is None:
                h, c = h_new, c_new
            else:
                keep = is_pad[:, k, None]
                h, c = torch.where(keep, h, h_new), torch.where(keep, c, c_new)
        return h

    def unroll_sequence(self, s: Tensor, memory: Memory | None = None) -> Tensor:
        """Run the LSTM over a chunk, carrying (h, c) from step to step.

        The same cell as `step`, as one fused pass (its weights shared): the input projection of all steps
        is one matrix product.

        Args:
            s: (B, L, D_s) state representations.
            memory: the (h, c) the chunk starts from, each (B, lstm_dim); None for zeros.

        Returns:
            (B, L, lstm_dim) embeddings e_t of every step.
        """
        cell = self.lstm
        weights = [cell.weight_ih, cell.weight_hh, cell.bias_ih, cell.bias_hh]
        lowp = torch.is_autocast_enabled("cpu") and torch.get_autocast_dtype("cpu") == torch.bfloat16
        # oneDNN has no bf16 LSTM on CPUs without AVX512-BF16 / AMX (it fails to build the primitive): the
        # LSTM runs in fp32 there, the rest of the network stays under autocast.
        fp32_lstm = s.device.type == "cpu" and lowp and not cpu_has_native_bf16()
        with torch.autocast("cpu", enabled=False) if fp32_lstm else contextlib.nullcontext():
            if fp32_lstm:
                s, weights = s.float(), [w.float() for w in weights]
            if memory is None:
                h0 = c0 = s.new_zeros(1, s.shape[0], cell.hidden_size)
            else:
                h0, c0 = (m.to(s.dtype)[None] for m in memory)
            # torch.lstm(input, hx, params, biases, num_layers, dropout, train, bidirectional, batch_first)
            return torch.lstm(s, (h0, c0), weights, True, 1, 0.0, self.training, False, True)[0]

    def decode(
        self, e: Tensor, stochastic: bool, noise: list[Tensor] | None = None, with_goal: bool = False
    ) -> tuple[Tensor, ...]:
        """Head and decoder: (..., lstm_dim) -> delta EE (D - 1 of a D-dimensional action), gripper outputs,
        EE position, object position.

        Args:
            with_goal: also return the goal head's output (a net built with `goal_head`).

        Returns:
            (..., 3) delta EE, (..., G) gripper outputs (`VMCConfig.gripper`), (..., 3) EE and (..., 3)
            object positions (the positions in the normalised space of `observation.environment_state`;
            None for a net without auxiliary heads), then with `with_goal` (..., 3) the object's predicted
            position at the demo's end.
        """
        features = self.head(e, stochastic, noise)
        if not self.has_aux:
            return (*self.decoder(features).split([self.command_dim, self.gripper_dim], -1), None, None)
        outputs = self.decoder(features).split(
            [self.command_dim, self.gripper_dim, POSITION_DIM, POSITION_DIM], dim=-1
        )
        if not with_goal:
            return outputs
        return (*outputs, self.goal_decoder(features))


def random_shift(images: Tensor, pad: int, group: Tensor | None = None) -> Tensor:
    """Shift frames by random offsets in [-pad, pad] pixels per axis, edges replicated (DrQ / RAD).

    Args:
        images: (B, K, C, H, W) windows, each window's K frames moved together; or (N, C, H, W) frames
            with `group`.
        pad: the largest shift; 0 returns `images` unchanged.
        group: (N,) index of the sample (0..G-1) each frame belongs to; frames of one sample move together.

    Returns:
        The shifted frames, shape of `images`.
    """
    if pad == 0:
        return images
    if group is None:
        b, k = images.shape[:2]
        group = torch.arange(b, device=images.device).repeat_interleave(k)
        return random_shift(images.flatten(0, 1), pad, group).unflatten(0, (b, k))
    n, _, h, w = images.shape
    num_groups = int(group.max()) + 1 if n else 0
    offsets = torch.randint(0, 2 * pad + 1, (2, num_groups), device=images.device)[:, group]  # (2, N)
    padded = F.pad(images, (pad, pad, pad, pad), mode="replicate")
    rows = offsets[0, :, None] + torch.arange(h, device=images.device)  # (N, H)
    cols = offsets[1, :, None] + torch.arange(w, device=images.device)  # (N, W)
    frame = torch.arange(n, device=images.device)[:, None, None]
    shifted = padded[frame, :, rows[:, :, None], cols[:, None, :]]  # (N, H, W, C)
    return shifted.permute(0, 3, 1, 2)
