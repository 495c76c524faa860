"""What a dataset's collector recorded about it (`meta/ivmc_collection.json`): its render style and task."""

from __future__ import annotations

import json
from pathlib import Path

from lerobot_ivmc.datasets.staging import COLLECTION_INFO_PATH
from lerobot_ivmc.envs.render_styles import LEGACY_RENDER_STYLE


def spec_render_style(spec: dict) -> str:
    """The render style of a collection spec (datasets made before render styles have the Fetch look)."""
    return spec.get("render_style", LEGACY_RENDER_STYLE)


def collection_spec(root: Path) -> dict | None:
    """The collection spec of the dataset in `root`, or None if lerobot-ivmc-collect did not make it."""
    path = Path(root) / COLLECTION_INFO_PATH
    if not path.exists():
        return None
    try:
        spec = json.loads(path.read_text())["spec"]
        spec["task"]  # noqa: B018
        return spec
    except (ValueError, KeyError, TypeError) as error:
        raise ValueError(
            f"{path} is not a readable collection record ({error}); recollect the dataset."
        ) from error


def dataset_render_style(root: Path) -> str | None:
    """The render style of the dataset in `root`, or None if lerobot-ivmc-collect did not make it."""
    spec = collection_spec(root)
    return None if spec is None else spec_render_style(spec)
