"""VMC: the deterministic visuomotor controller, and the network it shares with Bayesian VMC.

CNN over the RGB frame -> spatial feature map concatenated with the tiled proprioception -> LSTM ->
#fc fully connected layers -> four heads: delta end-effector command (MSE), gripper close / no-op / open
(cross-entropy), auxiliary end-effector and object positions (MSE); the four losses equally weighted
(the paper's Eq. (loss-vmc)). Optionally (beyond the paper) a head for the object's position at the end
of the demo (`goal_head`) and one reading the positions from each frame's CNN map (`frame_position_head`).
`BVMCPolicy` swaps the fully connected layers for concrete dropout ones.
"""

import contextlib
import functools
from pathlib import Path

import torch
import torch.nn.functional as F  # noqa: N812
from lerobot.policies.pretrained import PreTrainedPolicy
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE
from torch import Tensor, nn

from lerobot_ivmc.policies.vmc.configuration_vmc import AUX_DIM, DELTA_EE_DIM, GRIPPER_COMMANDS, VMCConfig
from lerobot_ivmc.policies.vmc.stored_memory import StoredLSTMStates, lstm_cell_states

# `from_pretrained` arguments that say where and how to fetch a checkpoint's files.
HUB_KWARGS = (
    "force_download",
    "resume_download",
    "proxies",
    "token",
    "cache_dir",
    "local_files_only",
    "revision",
)

NUM_GRIPPER_CLASSES = len(GRIPPER_COMMANDS)
# One position (x, y, z) of `observation.environment_state`: the end effector's, then the object's.
POSITION_DIM = AUX_DIM // 2
# Rollout memory: the LSTM state (h, c), or the last K state representations (`rollout_memory`).
Memory = tuple[Tensor, ...]
# The frame position head's (N, 6) or, with the goal head, (N, 9) predictions and their targets; None
# without that head.
FramePositions = tuple[Tensor, Tensor] | None


@functools.cache
def cpu_has_native_bf16() -> bool:
    """Whether this CPU runs bf16 natively in oneDNN (AVX512-BF16 or AMX): bf16 autocast pays off and the
    fused LSTM has a bf16 kernel. Elsewhere bf16 is emulated (slower than fp32)."""
    try:
        return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):  # a torch without the query: assume not
        return False


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
        # delta EE (3) | gripper logits (3) | EE position (3) | object position (3)
        self.decoder = nn.Linear(head.out_dim, DELTA_EE_DIM + NUM_GRIPPER_CLASSES + AUX_DIM)
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
        """Head and decoder: (..., lstm_dim) -> delta EE, gripper logits, EE position, object position.

        Args:
            with_goal: also return the goal head's output (a net built with `goal_head`).

        Returns:
            (..., 3) delta EE, (..., 3) gripper logits, (..., 3) EE and (..., 3) object positions
            (the positions in the normalised space of `observation.environment_state`), then with
            `with_goal` (..., 3) the object's predicted position at the demo's end.
        """
        features = self.head(e, stochastic, noise)
        outputs = self.decoder(features).split(
            [DELTA_EE_DIM, NUM_GRIPPER_CLASSES, POSITION_DIM, POSITION_DIM], dim=-1
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


def gripper_commands(class_index: Tensor) -> Tensor:
    """Map gripper class indices (0, 1, 2) to commands (-1, 0, +1), as float."""
    return class_index.to(torch.get_default_dtype()) - 1.0


def deterministic_action(delta_ee: Tensor, gripper_logits: Tensor) -> Tensor:
    """The executed action (B, 4) from one decoded pass: delta EE and the most likely gripper command."""
    return torch.cat([delta_ee, gripper_commands(gripper_logits.argmax(dim=-1))[:, None]], dim=-1)


def gripper_labels(command: Tensor) -> Tensor:
    """Map gripper commands in [-1, 1] to class indices: round to the nearest of -1, 0, +1, then shift."""
    return (torch.round(command).clamp(-1, 1) + 1).long()


class VMCPolicy(PreTrainedPolicy):
    """Deterministic visuomotor controller; `rollout_memory` sets how its memory runs at rollout.

    Args:
        config: the policy config.
        dataset_meta: LeRobot dataset metadata (`make_policy` passes it); Bayesian VMC reads N from it.
    """

    config_class = VMCConfig
    name = "vmc"

    def __init__(self, config: VMCConfig, dataset_meta=None, **kwargs):
        super().__init__(config)
        config.validate_features()
        check_chunk_length(config, dataset_meta)
        self.image_key = config.image_feature_key
        image_shape = tuple(config.image_features[self.image_key].shape)
        state_dim = config.input_features[OBS_STATE].shape[0]
        self.net = VisuomotorNet(config, image_shape, state_dim, self._make_head(config, dataset_meta))
        self._memory: Memory | None = None
        # Sequence training, `chunk_memory="stored"`: the state each demo frame was last left in. Chunks of
        # whole demos all start at an episode's start, where the memory is zero: nothing to store then.
        lengths = episode_lengths(dataset_meta)
        whole_demos = bool(lengths) and set(lengths) == {config.chunk_length}
        self._stores_chunk_memory = (
            config.training_mode == "sequence" and config.chunk_memory == "stored" and not whole_demos
        )
        self.stored_states = StoredLSTMStates(config.lstm_dim, sum(lengths) if lengths else 0)

    def _make_head(self, config: VMCConfig, dataset_meta=None) -> nn.Module:
        """The layers after the LSTM; Bayesian VMC overrides this."""
        return MLPHead(config.lstm_dim, config.fc_dim, config.num_fc_layers)

    def generate_model_card(self, dataset_repo_id: str, model_type: str, license, tags):  # noqa: A002
        """LeRobot's model card (what `push_model_to_hub` writes), with the paper, the training task and a
        bvmc's threshold (`policies/model_card.py`)."""
        from lerobot_ivmc.policies.model_card import model_card_section

        card = super().generate_model_card(dataset_repo_id, model_type, license, tags)
        card.text += model_card_section(self.config, getattr(self, "threshold_record", None))
        return card

    def get_optim_params(self) -> list[dict]:
        return [{"params": [p for p in self.parameters() if p.requires_grad]}]

    def reset(self) -> None:
        """Clear the LSTM memory (call at every episode start)."""
        self._memory = None

    def get_memory(self) -> Memory | None:
        """A copy of the rollout memory, or None before the first step.

        With `rollout_memory="trajectory"` it is the LSTM state (h, c), each (B, lstm_dim); with "window" the
        state representations of the last K frames (B, K, D_s) and their padding mask (B, K), True for the
        slots before the episode's first frame. Every tensor has the rollouts on its first axis, so a
        recovery can save or restore the memory of one rollout of a batch (`memory_rows`).
        """
        return None if self._memory is None else tuple(t.clone() for t in self._memory)

    def set_memory(self, memory: Memory | None) -> None:
        """Restore a memory from `get_memory` (e.g. to back-track); None clears it."""
        self._memory = None if memory is None else tuple(t.clone() for t in memory)

    def forward(self, batch: dict[str, Tensor]) -> tuple[Tensor, dict[str, float]]:
        """Training loss: on the last step of each K-frame window, or on every frame of each chunk.

        The frames are augmented by `random_shift` (config `image_shift_pad`); `forward` is the training
        loss, so this does not depend on `self.training` (LeRobot 0.4's in-training eval leaves eval mode on).

        Args:
            batch: window training: image (B, K, 3, H, W), `observation.state` (B, K, D),
                `observation.environment_state` (B, K, 6) (the targets), `action` (B, 4), optional
                `observation.state_is_pad` (B, K); tensors without the K axis are taken as K = 1. Sequence
                training: the same keys over a chunk of L frames, `action` (B, L, 4), and
                `observation.state_is_pad` (B, L) marking the frames past an episode's end.

        Returns:
            The total loss and its parts as floats.
        """
        if self.config.training_mode == "sequence":
            outputs, action, aux, frame_positions = self._sequence_outputs(batch)
        else:
            outputs, action, aux, frame_positions = self._window_outputs(batch)
        losses = supervised_losses(outputs, action, aux)
        if frame_positions is not None:
            losses.update(frame_position_losses(*frame_positions))
        regularization = self.net.head.regularization()
        loss = torch.stack(list(losses.values())).sum() + regularization
        info = {name: value.item() for name, value in losses.items()}
        info["regularization"] = regularization.item()
        info["supervised_steps"] = float(action.shape[0])
        for i, p in enumerate(self.net.head.dropout_probabilities()):
            info[f"dropout_p_{i}"] = p
        return loss, info

    def _window_outputs(
        self, batch: dict[str, Tensor]
    ) -> tuple[tuple[Tensor, ...], Tensor, Tensor, FramePositions]:
        """Decoded outputs (each (B, ...)) on the last step of each window, with its action and targets, and
        the frame position head's predictions and targets on every frame of the windows (or None)."""
        images, state, aux, action = (
            batch[self.image_key],
            batch[OBS_STATE],
            batch[OBS_ENV_STATE],
            batch[ACTION],
        )
        if images.dim() == 4:
            images, state, aux = images[:, None], state[:, None], aux[:, None]
        if action.dim() == 3:
            action = action[:, -1]
        b, k = images.shape[:2]
        images = random_shift(images, self.config.image_shift_pad)
        s, positions = self.net.encode_with_positions(images.flatten(0, 1), state.flatten(0, 1))
        e = self.net.unroll(s.unflatten(0, (b, k)), batch.get(f"{OBS_STATE}_is_pad"))
        frame_positions = None if positions is None else (positions, aux.flatten(0, 1))
        # Masks are always drawn in training (concrete dropout must not depend on `self.training`).
        return self.net.decode(e, stochastic=True), action, aux[:, -1], frame_positions

    def _sequence_outputs(
        self, batch: dict[str, Tensor]
    ) -> tuple[tuple[Tensor, ...], Tensor, Tensor, FramePositions]:
        """Decoded outputs (each (N, ...)) on the N real frames of the chunks, with their actions and targets,
        and the frame position head's predictions and targets on those frames (or None).

        Only the real frames go through the CNN (once each); the LSTM runs over the whole chunk, from the
        memory `chunk_memory` says (stored: the state the frame before the chunk was last left in).
        """
        images, state, aux, action = (
            batch[self.image_key],
            batch[OBS_STATE],
            batch[OBS_ENV_STATE],
            batch[ACTION],
        )
        if images.dim() != 5 or action.dim() != 3:
            raise ValueError(
                "Sequence training expects chunks: image (B, L, 3, H, W) and action (B, L, 4); got "
                f"{tuple(images.shape)} and {tuple(action.shape)}. Train with the policy's delta indices "
                "(lerobot-train sets them from the config)."
            )
        real = chunk_frames_mask(batch, images.shape[:2])
        group = torch.arange(images.shape[0], device=images.device)[:, None].expand_as(real)[real]
        frames = random_shift(images[real], self.config.image_shift_pad, group)
        s_real, positions = self.net.encode_with_positions(frames, state[real])
        s = s_real.new_zeros(*real.shape, s_real.shape[-1]).masked_scatter(real[..., None], s_real)
        e = self._unroll_chunks(s, real, batch)[real]
        targets = aux
        if self.config.goal_head:
            targets = torch.cat([aux, demo_end_object_position(aux, real)], dim=-1)
        outputs = self.net.decode(e, stochastic=True, with_goal=self.config.goal_head)
        frame_positions = None if positions is None else (positions, targets[real])
        return outputs, action[real], targets[real], frame_positions

    def _unroll_chunks(self, s: Tensor, real: Tensor, batch: dict[str, Tensor]) -> Tensor:
        """The LSTM over (B, L, D_s) chunks -> (B, L, lstm_dim); with stored chunk memory, each chunk starts
        from the stored state of the frame before it and leaves its frames' states for later chunks."""
        if not self._stores_chunk_memory:
            return self.net.unroll_sequence(s)
        positions = batch.get("index"), batch.get("episode_index")
        if positions[0] is None or positions[1] is None:
            raise ValueError(
                "chunk_memory='stored' needs each chunk's dataset position: the batch's 'index' and "
                "'episode_index' (LeRobot's datasets give them). Pass them, or set "
                "--policy.chunk_memory=zero to start every chunk from zero memory."
            )
        first_index, episode_index = (p.reshape(-1).long() for p in positions)
        if first_index.shape[0] != s.shape[0] or episode_index.shape[0] != s.shape[0]:
            raise ValueError(
                f"'index' and 'episode_index' must hold one value per chunk ({s.shape[0]}), got shapes "
                f"{tuple(positions[0].shape)} and {tuple(positions[1].shape)}."
            )
        memory = self.stored_states.initial(first_index, episode_index, s)
        e = self.net.unroll_sequence(s, memory)
        cells = lstm_cell_states(self.net.lstm, s, e, *memory)
        frame_index = first_index[:, None] + torch.arange(s.shape[1], device=s.device)
        episodes = episode_index[:, None].expand_as(frame_index)
        self.stored_states.store(frame_index[real], episodes[real], e[real], cells[real])
        return e

    def _current_obs(self, batch: dict[str, Tensor]) -> tuple[Tensor, Tensor]:
        images, state = batch[self.image_key], batch[OBS_STATE]
        if images.dim() != 4 or state.dim() != 2:
            raise ValueError(
                f"Rollout expects one frame per step: image (B, 3, H, W) and state (B, D); got "
                f"{tuple(images.shape)} and {tuple(state.shape)}."
            )
        return images, state

    def step_embedding(self, batch: dict[str, Tensor]) -> Tensor:
        """Feed one frame to the CNN and LSTM, update the memory and return e_t, (B, lstm_dim)."""
        images, state = self._current_obs(batch)
        memory = self._memory
        if memory is not None and memory[0].shape[0] != images.shape[0]:
            raise ValueError(f"Memory holds {memory[0].shape[0]} rollouts but the batch {images.shape[0]}.")
        s = self.net.encode(images, state)
        if self.config.rollout_memory == "window":
            frames, is_pad = self.initial_memory(s.shape[0]) if memory is None else memory
            frames = torch.cat([frames[:, 1:], s[:, None]], dim=1)
            is_pad = torch.cat([is_pad[:, 1:], is_pad.new_zeros(is_pad.shape[0], 1)], dim=1)
            self._memory = (frames, is_pad)
            return self.net.unroll(frames, is_pad)
        self._memory = self.net.step(s, memory)
        return self._memory[0]

    def initial_memory(self, batch_size: int) -> Memory:
        """The memory right after `reset()`, as a tensor tuple (what a rollout's memory is reset to)."""
        weight = self.net.decoder.weight
        if self.config.rollout_memory == "window":
            size = self.net.lstm.input_size
            frames = weight.new_zeros(batch_size, self.config.n_obs_steps, size)
            return frames, torch.ones(
                batch_size, self.config.n_obs_steps, dtype=torch.bool, device=weight.device
            )
        h = weight.new_zeros(batch_size, self.net.lstm.hidden_size)
        return h, h.clone()

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """The action to execute, (B, 4), gripper in {-1, 0, +1}; advances the LSTM memory by one step."""
        self.eval()
        embedding = self.step_embedding(batch)
        delta_ee, logits, _, _ = self.net.decode(embedding, stochastic=False)
        return deterministic_action(delta_ee, logits)

    @torch.no_grad()
    def predict_action_chunk(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """A chunk of one action, (B, 1, 4); advances the LSTM memory like `select_action`."""
        return self.select_action(batch)[:, None]

    @classmethod
    def from_pretrained(
        cls, pretrained_name_or_path: str | Path, *, config: VMCConfig | None = None, **kwargs
    ):
        """LeRobot's loading, with a checkpoint saved before sequence training became the default read with
        the network it was trained as (`lerobot_ivmc.policies.legacy_configs`)."""
        from lerobot.configs.policies import PreTrainedConfig

        from lerobot_ivmc.policies.legacy_configs import complete_legacy_config

        if config is None:  # as LeRobot's own, which passes every argument but `strict` to the config
            config_kwargs = {k: v for k, v in kwargs.items() if k != "strict"}
            config = PreTrainedConfig.from_pretrained(pretrained_name_or_path, **config_kwargs)
        complete_legacy_config(
            config, pretrained_name_or_path, **{k: kwargs[k] for k in HUB_KWARGS if k in kwargs}
        )
        return super().from_pretrained(pretrained_name_or_path, config=config, **kwargs)

    @classmethod
    def _load_as_safetensor(
        cls, model: "VMCPolicy", model_file: str, map_location: str, strict: bool
    ) -> "VMCPolicy":
        """Load the weights strictly, whatever `strict` says (LeRobot's default only warns about a missing
        tensor and keeps its random weights): see `lerobot_ivmc.policies.checkpoint_checks`."""
        from lerobot_ivmc.policies.checkpoint_checks import load_checkpoint_strictly

        load_checkpoint_strictly(model, model_file, map_location)
        return model


def supervised_losses(outputs: tuple[Tensor, ...], action: Tensor, aux: Tensor) -> dict[str, Tensor]:
    """The four losses of the paper's Eq. (loss-vmc), equally weighted, each a mean over the N labels;
    a fifth, weighed the same, when the outputs include the goal head's.

    Args:
        outputs: decoded delta EE (N, 3), gripper logits (N, 3), EE (N, 3) and object (N, 3) positions,
            optionally the predicted object position at the demo's end (N, 3).
        action: (N, 4) demonstrated actions.
        aux: (N, 6) auxiliary targets (EE then object position, normalised), (N, 9) with the goal head's
            target (the object's position at the demo's end) appended.
    """
    delta_ee, logits = outputs[:2]
    return {
        "loss_delta_ee": F.mse_loss(delta_ee, action[:, :DELTA_EE_DIM]),
        "loss_gripper": F.cross_entropy(logits, gripper_labels(action[:, DELTA_EE_DIM])),
        **position_losses(outputs[2:], aux, "loss_"),
    }


def frame_position_losses(predicted: Tensor, aux: Tensor) -> dict[str, Tensor]:
    """The frame position head's losses, weighed like the auxiliary ones: its (N, 6) or, with the goal
    head, (N, 9) positions against the targets of the same frames (`position_losses`)."""
    return position_losses(predicted.split(POSITION_DIM, dim=-1), aux, "loss_frame_")


def position_losses(positions: tuple[Tensor, ...], aux: Tensor, prefix: str) -> dict[str, Tensor]:
    """MSE of each predicted (N, 3) position, EE, object, then optionally the object's at the demo's end,
    against its columns of the (N, 6) or (N, 9) targets; named `<prefix>ee_pos`, `obj_pos`, `goal_pos`."""
    names = ("ee_pos", "obj_pos", "goal_pos")[: len(positions)]
    return {
        f"{prefix}{name}": F.mse_loss(position, aux[:, i * POSITION_DIM : (i + 1) * POSITION_DIM])
        for i, (name, position) in enumerate(zip(names, positions, strict=True))
    }


def demo_end_object_position(aux: Tensor, real: Tensor) -> Tensor:
    """The goal head's target: the object's position on each chunk's last real frame, on every frame.

    Args:
        aux: (B, L, 6) auxiliary targets of whole-demo chunks.
        real: (B, L) bool, True for real frames (`chunk_frames_mask`).

    Returns:
        (B, L, 3).
    """
    last = real.sum(dim=1) - 1
    end = aux[torch.arange(aux.shape[0], device=aux.device), last, POSITION_DIM:]
    return end[:, None].expand(-1, aux.shape[1], -1)


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
