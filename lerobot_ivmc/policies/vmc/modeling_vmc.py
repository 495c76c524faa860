"""VMC: the deterministic visuomotor controller, a LeRobot policy.

Its network (`network.py`): CNN over the RGB frame -> spatial feature map concatenated with the tiled
proprioception -> LSTM -> #fc fully connected layers -> four heads: delta end-effector command (MSE),
gripper close / no-op / open (cross-entropy; or a continuous command, MSE: `gripper.py`), auxiliary
end-effector and object positions (MSE); the four losses equally weighted (the paper's Eq. (loss-vmc),
`losses.py`). Optionally (beyond the paper) a head for the object's position at the end of the demo
(`goal_head`) and one reading the positions from each frame's CNN map (`frame_position_head`).
`BVMCPolicy` swaps the fully connected layers for concrete dropout ones.
"""

from pathlib import Path

import torch
from lerobot.policies.pretrained import PreTrainedPolicy
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE
from torch import Tensor, nn

from lerobot_ivmc.policies.vmc.configuration_vmc import VMCConfig
from lerobot_ivmc.policies.vmc.gripper import deterministic_action
from lerobot_ivmc.policies.vmc.losses import (
    demo_end_object_position,
    frame_position_losses,
    supervised_losses,
)
from lerobot_ivmc.policies.vmc.network import (
    FramePositions,
    Memory,
    MLPHead,
    VisuomotorNet,
    random_shift,
)
from lerobot_ivmc.policies.vmc.sequence_chunks import check_chunk_length, chunk_frames_mask, episode_lengths
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
        if config.image_size is not None:  # the pre-processor resizes the frames to it
            image_shape = (image_shape[0], config.image_size, config.image_size)
        state_dim = config.input_features[OBS_STATE].shape[0]
        self.net = VisuomotorNet(config, image_shape, state_dim, self._make_head(config, dataset_meta))
        self._memory: Memory | None = None
        # (B, 6) or, with the goal head, (B, 9): the frame position head's EE and object positions (and
        # the object's at the demo's end) read from the last rollout frame's CNN map alone, normalised like
        # `observation.environment_state`; None for a net without that head or before the first step.
        self.frame_positions: Tensor | None = None
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
        self.frame_positions = None

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
        losses = supervised_losses(outputs, action, aux, self.config.gripper)
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
        images, state, aux, action = batch[self.image_key], batch[OBS_STATE], self._aux(batch), batch[ACTION]
        if images.dim() == 4:
            images, state = images[:, None], state[:, None]
            aux = None if aux is None else aux[:, None]
        if action.dim() == 3:
            action = action[:, -1]
        b, k = images.shape[:2]
        images = random_shift(images, self.config.image_shift_pad)
        s, positions = self.net.encode_with_positions(images.flatten(0, 1), state.flatten(0, 1))
        e = self.net.unroll(s.unflatten(0, (b, k)), batch.get(f"{OBS_STATE}_is_pad"))
        frame_positions = None if positions is None else (positions, aux.flatten(0, 1))
        # Masks are always drawn in training (concrete dropout must not depend on `self.training`).
        return (
            self.net.decode(e, stochastic=True),
            action,
            None if aux is None else aux[:, -1],
            frame_positions,
        )

    def _sequence_outputs(
        self, batch: dict[str, Tensor]
    ) -> tuple[tuple[Tensor, ...], Tensor, Tensor, FramePositions]:
        """Decoded outputs (each (N, ...)) on the N real frames of the chunks, with their actions and targets,
        and the frame position head's predictions and targets on those frames (or None).

        Only the real frames go through the CNN (once each); the LSTM runs over the whole chunk, from the
        memory `chunk_memory` says (stored: the state the frame before the chunk was last left in).
        """
        images, state, aux, action = batch[self.image_key], batch[OBS_STATE], self._aux(batch), batch[ACTION]
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
        return outputs, action[real], None if targets is None else targets[real], frame_positions

    def _aux(self, batch: dict[str, Tensor]) -> Tensor | None:
        """The auxiliary targets (..., 6) of the batch's environment state; None for a net without them."""
        indices = self.config.aux_indices
        return None if indices is None else batch[OBS_ENV_STATE][..., list(indices)]

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
        """Feed one frame to the CNN and LSTM, update the memory and return e_t, (B, lstm_dim). A net with the
        frame position head also leaves that head's reading of the frame in `frame_positions`."""
        images, state = self._current_obs(batch)
        memory = self._memory
        if memory is not None and memory[0].shape[0] != images.shape[0]:
            raise ValueError(f"Memory holds {memory[0].shape[0]} rollouts but the batch {images.shape[0]}.")
        s, self.frame_positions = self.net.encode_with_positions(images, state)
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
        """The action to execute, (B, 4), the gripper's command as `config.gripper` reads it; advances the
        LSTM memory by one step."""
        self.eval()
        embedding = self.step_embedding(batch)
        delta_ee, gripper_output, _, _ = self.net.decode(embedding, stochastic=False)
        return deterministic_action(delta_ee, gripper_output, self.config.gripper)

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
