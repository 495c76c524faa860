"""Coarser copies of a model's meshes for drawing only: vertex clustering, uploaded to the renderer.

A software renderer (Mesa's, where there is no GPU) spends most of a small frame on mesh triangles: the
MetaWorld Sawyer's meshes have about 67,000. Merging the vertices that share a grid cell of about a pixel's
size draws nearly the same image from a fraction of them. The physics never sees the change: the model's
mesh arrays are swapped only while a renderer uploads them, then restored.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import mujoco
import numpy as np


def cluster_faces(vertices: np.ndarray, faces: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertex clustering: every vertex moves to the first vertex of its `cell`-sized grid cell.

    A face is kept if its three corners stay distinct, it still faces the way it did (MuJoCo culls back
    faces: one turned over would vanish), and no earlier face has the same corners in the same winding.

    Args:
        vertices: (V, 3) mesh vertices, metres.
        faces: (F, 3) vertex indices of each triangle, counter-clockwise seen from outside.
        cell: the grid's cell side, metres (> 0).

    Returns:
        kept: (K,) indices of the faces kept.
        clustered: (K, 3) those faces' corners after clustering (indices into `vertices`).
    """
    if cell <= 0:
        raise ValueError(f"The clustering cell must be positive, got {cell}.")
    vertices, faces = np.asarray(vertices, dtype=np.float64), np.asarray(faces)
    cells = np.floor(vertices / cell).astype(np.int64)
    _, first, which = np.unique(cells, axis=0, return_index=True, return_inverse=True)
    corners = first[which.ravel()][faces]
    distinct = (
        (corners[:, 0] != corners[:, 1]) & (corners[:, 1] != corners[:, 2]) & (corners[:, 0] != corners[:, 2])
    )
    kept = np.flatnonzero(
        distinct & (np.einsum("ij,ij->i", normals(vertices, faces), normals(vertices, corners)) > 0)
    )
    # The same triangle in the same winding: rotate each so its smallest corner comes first.
    rotated = corners[kept]
    shift = rotated.argmin(axis=1)
    rotated = rotated[np.arange(len(rotated))[:, None], (shift[:, None] + np.arange(3)) % 3]
    _, unique = np.unique(rotated, axis=0, return_index=True)
    kept = kept[np.sort(unique)]
    return kept, corners[kept]


def normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(F, 3) unnormalised normals of the (F, 3) triangles (right-handed in their corner order)."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    return np.cross(b - a, c - a)


@contextlib.contextmanager
def coarse_meshes(model: mujoco.MjModel, cell: float) -> Iterator[None]:
    """Within the block, `model`'s meshes have their faces clustered to `cell` (0: left as they are).

    A renderer made inside the block uploads the coarse meshes (MuJoCo copies meshes to the rendering
    context when the context is made); on leaving, the model's face arrays are restored exactly.
    """
    if cell == 0 or model.nmesh == 0:
        yield
        return
    saved = {
        name: getattr(model, name).copy()
        for name in ("mesh_face", "mesh_facenormal", "mesh_facetexcoord", "mesh_facenum")
    }
    try:
        for mesh in range(model.nmesh):
            start, count = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
            first_vertex, vertex_count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            if count == 0:
                continue
            kept, clustered = cluster_faces(
                model.mesh_vert[first_vertex : first_vertex + vertex_count],
                saved["mesh_face"][start : start + count],
                cell,
            )
            # Faces are compacted to the front of the mesh's range; each keeps its own corner normals.
            end = start + len(kept)
            model.mesh_face[start:end] = clustered
            model.mesh_facenormal[start:end] = saved["mesh_facenormal"][start + kept]
            if len(saved["mesh_facetexcoord"]):
                model.mesh_facetexcoord[start:end] = saved["mesh_facetexcoord"][start + kept]
            model.mesh_facenum[mesh] = len(kept)
        yield
    finally:
        for name, values in saved.items():
            getattr(model, name)[:] = values
