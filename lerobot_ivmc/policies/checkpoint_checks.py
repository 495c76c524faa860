"""Strict checkpoint loading for the `vmc` and `bvmc` policies.

LeRobot's `PreTrainedPolicy.from_pretrained` loads `model.safetensors` non-strictly by default: a tensor
missing from the file only logs a warning and the policy runs with that layer's random initial weights.
`VMCPolicy._load_as_safetensor` loads through `load_checkpoint_strictly` instead, which compares the file
with the model's own `state_dict()` (so optional submodules, such as the bvmc foresight head that exists
only when `config.foresight_enabled`, are expected exactly when the config builds them) and refuses any
difference, naming the file and the keys.
"""

from __future__ import annotations

from pathlib import Path

import torch
from safetensors import SafetensorError
from safetensors.torch import load_model
from torch import nn

# Keys listed in an error message, at most (the rest are counted).
_MAX_KEYS_SHOWN = 12


class CheckpointError(ValueError):
    """A checkpoint file that cannot be read or does not fit its policy; the message names the file."""


def _keys(names: list[str]) -> str:
    names = sorted(names)
    shown = ", ".join(names[:_MAX_KEYS_SHOWN])
    return shown + (f" and {len(names) - _MAX_KEYS_SHOWN} more" if len(names) > _MAX_KEYS_SHOWN else "")


def load_checkpoint_strictly(
    model: nn.Module, model_file: str | Path, device: str | torch.device = "cpu"
) -> None:
    """Load `model_file` into `model`, refusing a file that does not hold exactly the model's tensors.

    Args:
        model: the freshly built policy (its `state_dict()` keys are what the file must hold).
        model_file: a `model.safetensors` file.
        device: where the tensors are loaded.

    Raises:
        CheckpointError: the file is missing, truncated or not a safetensors file, holds tensors of other
            shapes, or lacks tensors of the model or holds tensors the model does not have.
    """
    path = Path(model_file)
    if not path.is_file():
        raise CheckpointError(f"Checkpoint file {path} does not exist.")
    try:
        missing, unexpected = load_model(model, path, strict=False, device=str(device))
    except (SafetensorError, OSError, ValueError) as error:
        raise CheckpointError(
            f"Checkpoint file {path} is not a readable safetensors file (truncated or corrupt?): {error}"
        ) from error
    except RuntimeError as error:  # torch's load_state_dict: tensors of other shapes
        details = " ".join(str(error).split())  # torch's message spans several lines
        raise CheckpointError(
            f"Checkpoint file {path} does not fit the {type(model).__name__}: {details}"
        ) from error
    problems = []
    if missing:
        problems.append(f"missing keys {_keys(list(missing))}")
    if unexpected:
        problems.append(f"unexpected keys {_keys(list(unexpected))}")
    if problems:
        raise CheckpointError(
            f"Checkpoint file {path} does not hold the tensors of this {type(model).__name__} (its config "
            f"may not be the one it was trained with): {'; '.join(problems)}."
        )
