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
        mesh_cell: draw meshes with their vertices clustered to cells of this side, metres
            (`coarse_meshes.py`; 0 = the model's meshes).
        framed: turn the camera to the task's workspace and narrow it until the workspace fills the frame
            (`metaworld/framing.py`; MetaWorld only, the Fetch camera is framed on its table already).
    """

    multisamples: int
    shadows: bool
    reflections: bool
    mesh_cell: float = 0.0
    framed: bool = False


# "fetch": the look of the Fetch XML (4x MSAA, shadows, reflections), that of every dataset and checkpoint
# made before render styles existed. "fast": no multisampling, which is most of the cost of a 64-px frame
# (benchmarks/bench_env.py); shadows and reflections are kept, since they cost little and the shadow under
# a lifted cube is the camera's cue of its height. "flat": also without shadows and reflections, the
# MetaWorld suite's default (its scenes' shadows and mirror-like floor cost most of a 64-px frame there).
# "lean": flat with the meshes clustered to 1 cm, under a pixel of a 64-px MetaWorld frame at the table;
# on a software renderer the Sawyer's mesh triangles are most of what remains of a flat frame's cost.
# "framed": flat, with MetaWorld's camera framed on the task's workspace (a pick-place puck two or three
# pixels wide at 64 px in LeRobot's corner2 view grows to about twice that).
RENDER_STYLES = {
    "fetch": RenderStyle(multisamples=4, shadows=True, reflections=True),
    "fast": RenderStyle(multisamples=0, shadows=True, reflections=True),
    "flat": RenderStyle(multisamples=0, shadows=False, reflections=False),
    "lean": RenderStyle(multisamples=0, shadows=False, reflections=False, mesh_cell=0.01),
    "framed": RenderStyle(multisamples=0, shadows=False, reflections=False, framed=True),
}
DEFAULT_RENDER_STYLE = "fast"
# What datasets and checkpoints that do not record a render style were made with.
LEGACY_RENDER_STYLE = "fetch"


def check_render_style(name: str, style: Any, framing: bool = True) -> str:
    """Return `style` if it names a render style, else raise a ValueError naming `name` and the styles.
    `framing=False` (an env whose camera cannot be framed) also refuses the framed styles."""
    if style not in RENDER_STYLES:
        raise ValueError(f"Unknown {name} {style!r}; choose one of {tuple(RENDER_STYLES)}.")
    if not framing and RENDER_STYLES[style].framed:
        others = tuple(key for key, value in RENDER_STYLES.items() if not value.framed)
        raise ValueError(
            f"{name} {style!r} frames a MetaWorld task's workspace; this suite cannot frame its camera (the "
            f"Fetch tasks' is framed on the table already): choose one of {others}."
        )
    return style
