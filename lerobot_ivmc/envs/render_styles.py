"""How the camera image is drawn: named render styles, recorded by datasets and checkpoints.

A style changes the pixels a policy sees, so a dataset's `meta/ivmc_collection.json` and a checkpoint's
config name the style they were made with, and a policy is refused in an env of another style.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class RenderStyle:
    """How frames are drawn. It changes the pixels, so datasets and checkpoints record it by name.

    Args:
        multisamples: MSAA samples per pixel (`vis.quality.offsamples`; 0 = none).
        shadows: cast shadows from the lights (`mjRND_SHADOW`).
        reflections: mirror the scene in reflective surfaces (`mjRND_REFLECTION`).
    """

    multisamples: int
    shadows: bool
    reflections: bool


# "fetch": the look of the Fetch XML (4x MSAA, shadows, reflections), that of every dataset and checkpoint
# made before render styles existed. "fast": no multisampling, which is most of the cost of a 64-px frame
# (benchmarks/bench_env.py); shadows and reflections are kept, since they cost little and the shadow under
# a lifted cube is the camera's cue of its height. "flat": also without shadows and reflections, the
# MetaWorld suite's default (its scenes' shadows and mirror-like floor cost most of a 64-px frame there).
RENDER_STYLES = {
    "fetch": RenderStyle(multisamples=4, shadows=True, reflections=True),
    "fast": RenderStyle(multisamples=0, shadows=True, reflections=True),
    "flat": RenderStyle(multisamples=0, shadows=False, reflections=False),
}
DEFAULT_RENDER_STYLE = "fast"
# What datasets and checkpoints that do not record a render style were made with.
LEGACY_RENDER_STYLE = "fetch"


def check_render_style(name: str, style: Any) -> str:
    """Return `style` if it names a render style, else raise a ValueError naming `name` and the styles."""
    if style not in RENDER_STYLES:
        raise ValueError(f"Unknown {name} {style!r}; choose one of {tuple(RENDER_STYLES)}.")
    return style
