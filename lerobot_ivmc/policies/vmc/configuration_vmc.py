"""Configuration of VMC, the deterministic visuomotor controller (James et al. 2017, as in the paper)."""

from __future__ import annotations

from dataclasses import dataclass, field

from lerobot.configs.policies import PreTrainedConfig
from lerobot.configs.types import FeatureType, NormalizationMode
from lerobot.optim.optimizers import AdamConfig
from lerobot.optim.schedulers import CosineDecayWithWarmupSchedulerConfig
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from lerobot_ivmc.envs.render_styles import DEFAULT_RENDER_STYLE, LEGACY_RENDER_STYLE, check_render_style
from lerobot_ivmc.policies.vmc.gripper import (
    GRIPPER_COMMANDS,
    GRIPPER_HEADS,
    GripperReadout,
    gripper_readout,
)

# Layout of the action: a continuous command (the delta end effector, 3 for the Fetch and MetaWorld arms)
# followed by the gripper command, a class of {-1, 0, +1} or of `VMCConfig.gripper_levels`, or continuous
# (`VMCConfig.gripper_head`, `VMCConfig.action_dim`).
DELTA_EE_DIM = 3
ACTION_DIM = DELTA_EE_DIM + 1
# The auxiliary targets: end-effector (3) then object (3) position, read from `observation.environment_state`
# at `VMCConfig.aux_state_indices` (all six entries of a 6-D state, the Fetch tasks' layout).
AUX_DIM = 6
ROLLOUT_MEMORY_MODES = ("trajectory", "window")
TRAINING_MODES = ("sequence", "window")
CHUNK_MEMORY_MODES = ("stored", "zero")
# Default Adam learning rates per training mode: 6e-4 made the 10,000-step whole-demo schedule place as
# well as 36,000 window steps at 3e-4 (docs/training_experiments.md, "Sequence training with the carried
# memory").
SEQUENCE_LR = 6e-4
WINDOW_LR = 3e-4
# What a checkpoint saved before sequence training became the default (or before render styles existed)
# ran with, for the fields its config.json may lack: `VMCPolicy.from_pretrained` fills these in.
LEGACY_DEFAULTS = {
    "training_mode": "window",
    "goal_head": False,
    "frame_position_head": False,
    "render_style": LEGACY_RENDER_STYLE,
}


@PreTrainedConfig.register_subclass("vmc")
@dataclass
class VMCConfig(PreTrainedConfig):
    """VMC: CNN over the RGB frame, tiled proprioception, LSTM, fully connected layers, four heads.

    Args:
        n_obs_steps: K, the frames of a window in window training and "window" rollout memory (the paper:
            K = 4). Windows that reach before an episode's start are padded by LeRobot; padded steps leave the
            LSTM state untouched.
        normalization_mapping: normalisation per feature type. ACTION must stay IDENTITY: its last
            dimension is a class label (gripper close / no-op / open), which mean/std would mangle.
        image_key: the camera to use; None picks the only VISUAL input feature.
        trained_task: the ivmc task of the training demos; `lerobot-ivmc-train` takes it from the dataset's
            collection record, and the ivmc commands refuse an env of another task. None: not known (plain
            `lerobot-train`, a dataset of another origin, a checkpoint made before the field).
        render_style: how the training frames were drawn (`lerobot_ivmc.envs.render_styles`);
            `lerobot-ivmc-train` takes it from the dataset's collection record, and the ivmc commands refuse
            an env of another `--env.render_style`. With plain `lerobot-train`, pass the dataset's style.
        image_size: the side the network takes; the pre-processor resizes the camera frames to it
            (`image_resize.ResizeImagesProcessorStep`), e.g. 64 for `lerobot/metaworld_mt50`'s 480-px frames.
            None: the dataset's size.
        conv_channels: filters of the 3x3 stride-2 conv layers (each halves the image side).
        lstm_dim: LSTM width, also the size of the embedding e_t.
        fc_dim: width of the fully connected layers after the LSTM.
        num_fc_layers: #fc, fully connected layers after the LSTM (the paper: 1 or 2).
        training_mode: what one training sample is. "sequence" (the default: measured better,
            docs/training_experiments.md, "Sequence training with the carried memory"): a chunk of
            `chunk_length` consecutive frames of one demo
            that fits inside the episode (with the default, a whole 100-step demo); the LSTM runs over the
            chunk from the memory `chunk_memory` says (with whole episodes: from zero at the episode start,
            as at rollout), each frame goes through the CNN once, and every frame's action is a label.
            "window": the K frames up to a frame, the LSTM from zero memory over them, the last frame's
            action the only label (each frame goes through the CNN about K times per epoch).
        chunk_length: frames per chunk in sequence training, at most the shortest demo. Chunks start only
            where they fit (`drop_n_last_frames`, LeRobot's episode-aware sampler): with chunk_length equal
            to the demo length every frame weighs the same. (Chunks from any frame, padded past the episode's
            end, weigh frame t by t + 1: the first steps of an episode were all but never learned.)
        chunk_memory: the memory a sequence chunk that starts mid-episode (chunks shorter than the demos)
            starts from. "stored": truncated back-propagation through time with stored states (R2D2): the
            LSTM state (h, c) the frame before the chunk was left in by the last training pass over it,
            detached, so the memory reaches back to the episode's start as at rollout while gradients stop
            at the chunk's start; zeros at an episode's first frame and for frames not yet trained on. Needs
            the batch's `index` and `episode_index` (LeRobot's datasets give them). "zero": zero memory at
            every chunk's start. Whole-demo chunks start at their episode's start: both are the same there.
        rollout_memory: how the LSTM memory runs at rollout; None follows `training_mode`. "trajectory" (the
            paper): one LSTM step per control step, (h, c) carried along the whole episode and cleared by
            `reset()`, as in sequence training. "window": the memory is the state representations of the last
            K frames and the LSTM re-runs from zero memory over them at every step, as in window training (a
            window-trained policy drifts with a carried memory it never saw: docs/training_experiments.md,
            "K = 4 `vmc` and `bvmc` on 2,000 demos (the window baseline)").
        goal_head: beyond the paper: a fifth head predicts, from every frame, where the object is at the end
            of its demonstration (on the target in push and pick-and-place), an MSE loss weighed like the
            auxiliary ones, so the target's position is learned directly, not only through the action loss
            (docs/training_experiments.md, "Sequence training with the carried memory"). Needs sequence
            training on whole demos (`chunk_length` equal to every demo's length), so that each chunk's last
            frame is its demo's end. None (the default): on in sequence training, off in
            window training; false is the paper's network.
        frame_position_head: beyond the paper: a linear head reads the end-effector and object positions
            (with `goal_head` also the object's position at the demo's end, i.e. the target) from each
            frame's CNN feature map alone (before the LSTM, without the state), MSE losses weighed like the
            auxiliary ones on every trained frame. The paper's auxiliary heads read the LSTM embedding,
            which can answer from the carried memory (the expert's path so far) instead of the image; this
            head makes the CNN find the cube (and the target) in every frame. A training target only, never
            used to act; on by default (docs/training_experiments.md, "Sequence training with the carried
            memory"); false is the paper's network.
        gripper_levels: the gripper commands the gripper classes stand for, ascending, at least two: each
            demo command is learned as the class of the nearest level (one farther than 0.05 from every level
            is refused) and a class is executed as its level.
            None: (-1, 0, +1), each demo command rounded to the nearest (the Fetch tasks; MetaWorld's grab
            effort of 0.6 is then executed as 1). MetaWorld's push-v3 and assembly-v3 demos: [0, 0.6].
        gripper_head: how the action's last entry is learned (`gripper.py`): "classes" (the paper's: the
            classes of `gripper_levels`) or "continuous" (the command itself, MSE, executed as predicted:
            a dataset whose gripper takes any value).
        aux_state_indices: the entries of `observation.environment_state` the auxiliary heads learn, the
            end effector's x, y, z then the object's (six). None: all six of a 6-D environment state (the
            Fetch datasets); with another state (MetaWorld's 39-D: [0, 1, 2, 4, 5, 6], which
            `lerobot-ivmc-train` passes for the plugin's MetaWorld datasets) or none, the auxiliary, goal and
            frame position heads are off unless this is given. docs/metaworld.md.
        image_shift_pad: training augmentation: each window's frames are shifted together by a random
            offset of up to this many pixels per axis (DrQ / RAD random shift); 0 disables it.
        optimizer_lr: Adam learning rate; None (the default): 6e-4 in sequence training, 3e-4 in window
            training, each the rate measured best for it.
        optimizer_weight_decay: Adam weight decay.
        optimizer_grad_clip_norm: gradient clipping norm applied by lerobot-train.
        scheduler_warmup_steps: linear learning-rate warm-up steps.
        scheduler_decay_steps: steps of the cosine decay from `optimizer_lr` to `scheduler_decay_lr`. LeRobot
            shrinks warm-up and decay to `--steps` when the run is shorter, so by default the decay spans
            the whole run; 0 keeps the learning rate constant (as the paper's Adam).
        scheduler_decay_lr: learning rate at the end of the decay.
    """

    # Input / output structure.
    n_obs_steps: int = 4
    normalization_mapping: dict[str, NormalizationMode] = field(
        default_factory=lambda: {
            "VISUAL": NormalizationMode.IDENTITY,  # images arrive in [0, 1]
            "STATE": NormalizationMode.MEAN_STD,
            "ENV": NormalizationMode.MEAN_STD,  # the auxiliary targets
            "ACTION": NormalizationMode.IDENTITY,  # delta EE already in [-1, 1]; gripper is a label
        }
    )
    image_key: str | None = None
    render_style: str = DEFAULT_RENDER_STYLE
    trained_task: str | None = None

    # Architecture. Smaller than GEECO's 8-layer CNN at 256x256 so that 64x64 frames train on 2 CPU cores:
    # 64 -> 32 -> 16 -> 8 -> 4, a 4x4x64 map, concatenated with the tiled state.
    image_size: int | None = None
    conv_channels: tuple[int, ...] = (32, 32, 64, 64)
    lstm_dim: int = 128
    fc_dim: int = 128
    num_fc_layers: int = 1

    # Training samples and rollout memory (see the docstring).
    training_mode: str = "sequence"
    chunk_length: int = 100
    chunk_memory: str = "stored"
    rollout_memory: str | None = None
    goal_head: bool | None = None
    frame_position_head: bool | None = None
    aux_state_indices: list[int] | None = None
    gripper_levels: list[float] | None = None
    gripper_head: str = "classes"

    # Training augmentation (4 px of 64, as the usual 84 -> 76 random crops of pixel-based imitation).
    image_shift_pad: int = 4

    # Training presets (GEECO: Adam, lr 1e-4, batch 32; a larger lr converges faster on short CPU runs).
    optimizer_lr: float | None = None
    optimizer_weight_decay: float = 0.0
    optimizer_grad_clip_norm: float = 10.0
    scheduler_warmup_steps: int = 1_000
    scheduler_decay_steps: int = 100_000
    scheduler_decay_lr: float = 1e-5

    def __post_init__(self) -> None:
        super().__post_init__()
        check_render_style("render_style", self.render_style)
        if self.n_obs_steps < 1:
            raise ValueError(f"n_obs_steps must be >= 1, got {self.n_obs_steps}.")
        if self.num_fc_layers not in (1, 2):
            raise ValueError(f"num_fc_layers (#fc) must be 1 or 2 as in the paper, got {self.num_fc_layers}.")
        if not self.conv_channels or any(c <= 0 for c in self.conv_channels):
            raise ValueError(f"conv_channels must be non-empty and positive, got {self.conv_channels}.")
        for name in ("lstm_dim", "fc_dim"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}.")
        if self.image_size is not None and self.image_size < 2 ** len(self.conv_channels):
            raise ValueError(
                f"image_size must be at least {2 ** len(self.conv_channels)} pixels (the CNN halves it "
                f"{len(self.conv_channels)} times), got {self.image_size}."
            )
        if self.image_shift_pad < 0:
            raise ValueError(f"image_shift_pad must be >= 0 pixels, got {self.image_shift_pad}.")
        if self.scheduler_warmup_steps < 0 or self.scheduler_decay_steps < 0:
            raise ValueError(
                "scheduler_warmup_steps and scheduler_decay_steps must be >= 0, got "
                f"{self.scheduler_warmup_steps} and {self.scheduler_decay_steps}."
            )
        if self.training_mode not in TRAINING_MODES:
            raise ValueError(f"training_mode must be one of {TRAINING_MODES}, got {self.training_mode!r}.")
        if self.chunk_length < 1:
            raise ValueError(
                f"chunk_length must be >= 1 frame (at most a demo's length, e.g. 100), "
                f"got {self.chunk_length}."
            )
        if self.chunk_memory not in CHUNK_MEMORY_MODES:
            raise ValueError(f"chunk_memory must be one of {CHUNK_MEMORY_MODES}, got {self.chunk_memory!r}.")
        # Heads left to their defaults are switched off for a dataset without auxiliary targets
        # (`validate_features`); asked for by name, they are refused there instead.
        self._default_heads = {
            name for name in ("goal_head", "frame_position_head") if getattr(self, name) is None
        }
        if self.goal_head is None:
            self.goal_head = self.training_mode == "sequence"
        if self.frame_position_head is None:
            self.frame_position_head = True
        if self.aux_state_indices is not None and (
            len(self.aux_state_indices) != AUX_DIM or any(int(i) < 0 for i in self.aux_state_indices)
        ):
            raise ValueError(
                f"aux_state_indices must be {AUX_DIM} entries of observation.environment_state (end effector "
                f"x, y, z, then the object's), got {self.aux_state_indices}."
            )
        if self.gripper_levels is not None:
            levels = [float(v) for v in self.gripper_levels]
            if len(levels) < 2 or levels != sorted(set(levels)) or not all(-1 <= v <= 1 for v in levels):
                raise ValueError(
                    f"--policy.gripper_levels must be at least two distinct gripper commands in [-1, 1], "
                    f"ascending (e.g. [0, 0.6]), got {self.gripper_levels}."
                )
        if self.gripper_head not in GRIPPER_HEADS:
            raise ValueError(
                f"--policy.gripper_head must be one of {GRIPPER_HEADS}, got {self.gripper_head!r}."
            )
        if self.gripper_head == "continuous" and self.gripper_levels is not None:
            raise ValueError(
                "--policy.gripper_levels names the classes of --policy.gripper_head=classes; drop it for a "
                "continuous gripper."
            )
        if self.optimizer_lr is None:
            self.optimizer_lr = SEQUENCE_LR if self.training_mode == "sequence" else WINDOW_LR
        if not self.optimizer_lr > 0:
            raise ValueError(f"optimizer_lr must be positive, got {self.optimizer_lr}.")
        if self.goal_head and self.training_mode != "sequence":
            raise ValueError(
                "goal_head needs whole demos in each sample (the object's position at the demo's end is its "
                "target): set --policy.training_mode=sequence with --policy.chunk_length=<demo length>."
            )
        if self.rollout_memory is None:
            self.rollout_memory = "trajectory" if self.training_mode == "sequence" else "window"
        if self.rollout_memory not in ROLLOUT_MEMORY_MODES:
            raise ValueError(
                f"rollout_memory must be one of {ROLLOUT_MEMORY_MODES}, got {self.rollout_memory!r}."
            )
        action_mode = self.normalization_mapping.get(FeatureType.ACTION.value, NormalizationMode.IDENTITY)
        if NormalizationMode(action_mode) is not NormalizationMode.IDENTITY:
            raise ValueError(
                f"ACTION normalisation must be IDENTITY (the delta EE is in action units and the gripper a "
                f"class label or command), got {action_mode}."
            )
        self._built = True  # from here on, naming the checkpoint completes the config (`__setattr__`)

    def __setattr__(self, name: str, value) -> None:
        """Set the field; naming a built config's checkpoint (`pretrained_path`) also puts back the values a
        checkpoint saved before sequence training became the default acts with (`legacy_configs`).

        LeRobot's commands read `--policy.path` with `PreTrainedConfig.from_pretrained`, which fills the
        fields its `config.json` lacks from today's defaults, then set `pretrained_path`, before they log or
        save the config: completed here, both show the values the policy acts with. (Not while the dataclass
        is built: a train config resumed from file names the checkpoint it was fine-tuned from before its
        own saved fields are set.)"""
        super().__setattr__(name, value)
        if name == "pretrained_path" and value is not None and self.__dict__.get("_built"):
            from lerobot_ivmc.policies.legacy_configs import complete_legacy_config

            complete_legacy_config(self, value)

    def get_optimizer_preset(self) -> AdamConfig:
        return AdamConfig(
            lr=self.optimizer_lr,
            weight_decay=self.optimizer_weight_decay,
            grad_clip_norm=self.optimizer_grad_clip_norm,
        )

    def get_scheduler_preset(self) -> CosineDecayWithWarmupSchedulerConfig | None:
        if self.scheduler_decay_steps == 0:
            return None
        return CosineDecayWithWarmupSchedulerConfig(
            num_warmup_steps=self.scheduler_warmup_steps,
            num_decay_steps=self.scheduler_decay_steps,
            peak_lr=self.optimizer_lr,
            decay_lr=self.scheduler_decay_lr,
        )

    @property
    def image_feature_key(self) -> str:
        """The camera key the policy reads."""
        if self.image_key is not None:
            return self.image_key
        keys = list(self.image_features)
        if len(keys) != 1:
            raise ValueError(f"Set `image_key`: expected exactly one image feature, found {keys}.")
        return keys[0]

    def validate_features(self) -> None:
        """Raise a ValueError naming whatever the dataset lacks: image, state, auxiliary targets, action."""
        inputs = self.input_features or {}
        outputs = self.output_features or {}
        if not self.image_features:
            raise ValueError(
                f"VMC needs an RGB camera ('observation.images.<name>'); input features are {list(inputs)}."
            )
        if self.image_key is not None and self.image_key not in self.image_features:
            raise ValueError(f"image_key {self.image_key!r} is not among {list(self.image_features)}.")
        shape = self.image_features[self.image_feature_key].shape
        if len(shape) != 3 or shape[0] != 3:
            raise ValueError(f"Expected an RGB image of shape (3, H, W), got {shape}.")
        if OBS_STATE not in inputs:
            raise ValueError(f"VMC needs the state input {OBS_STATE!r}; the dataset provides {list(inputs)}.")
        self._check_auxiliary_targets(inputs)
        if ACTION not in outputs or len(outputs[ACTION].shape) != 1 or outputs[ACTION].shape[0] < 2:
            got = tuple(outputs[ACTION].shape) if ACTION in outputs else None
            raise ValueError(
                f"VMC needs an {ACTION!r} of shape (D,), D >= 2: a continuous command, then the gripper "
                f"(-1 close, 0 no-op, +1 open), as [dx, dy, dz, gripper]; got {got}."
            )

    def _check_auxiliary_targets(self, inputs: dict) -> None:
        """Refuse auxiliary heads the dataset has no targets for; switch off the heads left to their
        defaults when it has none."""
        if self.aux_indices is not None:
            size = inputs[OBS_ENV_STATE].shape[0]
            if max(self.aux_indices) >= size:
                raise ValueError(
                    f"aux_state_indices {list(self.aux_indices)} reach past {OBS_ENV_STATE!r} of size {size}."
                )
            return
        if self.aux_state_indices is not None:
            raise ValueError(
                f"--policy.aux_state_indices needs {OBS_ENV_STATE!r} in the dataset; it has {list(inputs)}. "
                "Drop the flag to train without auxiliary heads."
            )
        asked = [n for n in ("goal_head", "frame_position_head") if getattr(self, n)]
        refused = [n for n in asked if n not in getattr(self, "_default_heads", set())]
        if refused:
            raise ValueError(
                f"--policy.{refused[0]}=true needs auxiliary targets: a 6-D {OBS_ENV_STATE!r} or "
                "--policy.aux_state_indices; set it false for this dataset."
            )
        self.goal_head = self.frame_position_head = False

    @property
    def action_dim(self) -> int:
        """D, the size of the action: the continuous command, then the gripper command."""
        return self.output_features[ACTION].shape[0]

    @property
    def gripper_commands(self) -> tuple[float, ...]:
        """The gripper command of each gripper class, ascending."""
        return GRIPPER_COMMANDS if self.gripper_levels is None else tuple(map(float, self.gripper_levels))

    @property
    def gripper(self) -> GripperReadout:
        """What the gripper head's outputs mean (`gripper.py`)."""
        return gripper_readout(self.gripper_head, self.gripper_commands)

    @property
    def aux_indices(self) -> tuple[int, ...] | None:
        """The entries of `observation.environment_state` the auxiliary heads learn; None: no such heads."""
        env_state = (self.input_features or {}).get(OBS_ENV_STATE)
        if env_state is None:
            return None
        if self.aux_state_indices is not None:
            return tuple(int(i) for i in self.aux_state_indices)
        return tuple(range(AUX_DIM)) if tuple(env_state.shape) == (AUX_DIM,) else None

    @property
    def drop_n_last_frames(self) -> int:
        """Sequence training: `lerobot-train` samples chunk starts only where a whole chunk fits (its
        `EpisodeAwareSampler` drops the last L - 1 frames of each episode). Window training has no such
        attribute, so LeRobot samples every frame."""
        if self.training_mode != "sequence":
            raise AttributeError("drop_n_last_frames: window training samples every frame")
        return self.chunk_length - 1

    @property
    def observation_delta_indices(self) -> list[int]:
        if self.training_mode == "sequence":
            return list(range(self.chunk_length))
        return list(range(1 - self.n_obs_steps, 1))

    @property
    def action_delta_indices(self) -> list[int] | None:
        # Sequence: every frame's action is a label; window: the last frame's action, the item's own.
        return list(range(self.chunk_length)) if self.training_mode == "sequence" else None

    @property
    def reward_delta_indices(self) -> None:
        return None
