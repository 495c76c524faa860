"""File and folder names the commands share (LeRobot's own where it has them)."""

from __future__ import annotations

from pathlib import Path

from lerobot.utils.constants import CHECKPOINTS_DIR, LAST_CHECKPOINT_LINK, PRETRAINED_MODEL_DIR

# What `lerobot-ivmc-eval` (as `lerobot-eval`) writes last in its output folder.
EVAL_INFO_FILE = "eval_info.json"
# A training's final checkpoint, relative to its output folder (`lerobot-train`'s layout).
LAST_PRETRAINED_MODEL = Path(CHECKPOINTS_DIR) / LAST_CHECKPOINT_LINK / PRETRAINED_MODEL_DIR

__all__ = [
    "CHECKPOINTS_DIR",
    "EVAL_INFO_FILE",
    "LAST_CHECKPOINT_LINK",
    "LAST_PRETRAINED_MODEL",
    "PRETRAINED_MODEL_DIR",
]
