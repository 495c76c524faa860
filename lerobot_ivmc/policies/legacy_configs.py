"""Checkpoints saved before sequence training became the default keep acting as they were trained.

A saved `config.json` holds every field the config had when it was saved; a field added later is filled
from its current default when the file is read. Three such fields changed the network or its training
when their defaults became sequence training with the goal and frame position heads (`training_mode`,
`goal_head`, `frame_position_head`), and one changed the frames when render styles came (`render_style`):
a checkpoint whose file lacks them was made with the values in `LEGACY_DEFAULTS`, which
`fill_legacy_defaults` puts back.
"""

from __future__ import annotations

import json
import logging
import os
import sys
from pathlib import Path

from huggingface_hub import hf_hub_download
from huggingface_hub.constants import CONFIG_NAME
from huggingface_hub.errors import HfHubHTTPError

from lerobot_ivmc.policies.vmc.configuration_vmc import LEGACY_DEFAULTS, VMCConfig

logger = logging.getLogger(__name__)


def saved_config_fields(pretrained_name_or_path: str | Path, **hub_kwargs) -> set[str] | None:
    """The field names in a checkpoint's `config.json` (local folder or hub repo); None if unreadable."""
    model_id = str(pretrained_name_or_path)
    try:
        if os.path.isdir(model_id):
            path = Path(model_id) / CONFIG_NAME
        else:
            path = Path(hf_hub_download(repo_id=model_id, filename=CONFIG_NAME, **hub_kwargs))
        return set(json.loads(path.read_text()))
    except (OSError, ValueError, HfHubHTTPError):
        return None  # LeRobot's own loading reports the missing or broken file


def command_line_policy_fields() -> set[str]:
    """The `--policy.<field>=` names on this process's command line (what the user chose on purpose)."""
    return {
        arg.split("=", 1)[0].removeprefix("--policy.") for arg in sys.argv[1:] if arg.startswith("--policy.")
    }


def fill_legacy_defaults(
    config: VMCConfig, saved_fields: set[str], keep: set[str] = frozenset()
) -> list[str]:
    """Set the fields of `LEGACY_DEFAULTS` that `saved_fields` lacks to their values then (and,
    when that changed the training mode, a missing `rollout_memory` to the one it implies), except the
    fields in `keep` (set on the command line); return the names changed."""
    changed = []
    for name, value in LEGACY_DEFAULTS.items():
        if name not in saved_fields and name not in keep and getattr(config, name) != value:
            setattr(config, name, value)
            changed.append(name)
    if "training_mode" in changed and "rollout_memory" not in saved_fields | keep:
        implied = "trajectory" if config.training_mode == "sequence" else "window"
        if config.rollout_memory != implied:
            config.rollout_memory = implied
            changed.append("rollout_memory")
    return changed


def complete_legacy_config(config: VMCConfig, pretrained_name_or_path: str | Path, **hub_kwargs) -> list[str]:
    """`fill_legacy_defaults` of `config` from the checkpoint's saved config.json, leaving the fields set on
    this process's command line as given; returns the names changed (none if the file is unreadable), and
    says which in a warning."""
    saved = saved_config_fields(pretrained_name_or_path, **hub_kwargs)
    if saved is None:
        return []
    changed = fill_legacy_defaults(config, saved, keep=command_line_policy_fields())
    if changed:
        values = ", ".join(f"{name}={getattr(config, name)}" for name in changed)
        logger.warning(
            "%s predates sequence training as the default: it runs with its own %s",
            pretrained_name_or_path,
            values,
        )
    return changed
