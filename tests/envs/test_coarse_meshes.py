"""Coarse meshes for drawing: vertex clustering keeps the shape, draws fewer triangles, and leaves the
model (and so the physics) exactly as it was."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_ivmc.envs.coarse_meshes import cluster_faces, coarse_meshes


def grid_mesh(points_per_side: int, side: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """A flat square of `side` metres: (n*n, 3) vertices and its (2 (n-1)^2, 3) triangles."""
    axis = np.linspace(0.0, side, points_per_side)
    x, y = np.meshgrid(axis, axis, indexing="ij")
    vertices = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    index = np.arange(x.size).reshape(x.shape)
    a, b, c, d = index[:-1, :-1], index[1:, :-1], index[:-1, 1:], index[1:, 1:]
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    return vertices, faces


def test_a_cell_finer_than_the_mesh_keeps_every_face() -> None:
    vertices, faces = grid_mesh(11)  # 1 cm spacing
    kept, clustered = cluster_faces(vertices, faces, cell=0.001)
    assert np.array_equal(kept, np.arange(len(faces))) and np.array_equal(clustered, faces)


def test_a_coarser_cell_draws_fewer_triangles_that_still_cover_the_shape() -> None:
    vertices, faces = grid_mesh(41)  # 2.5 mm spacing
    kept, clustered = cluster_faces(vertices, faces, cell=0.02)
    assert 0 < len(kept) < len(faces) / 10
    assert np.all(clustered[:, 0] != clustered[:, 1]) and np.all(clustered[:, 1] != clustered[:, 2])
    assert len({tuple(sorted(face)) for face in clustered.tolist()}) == len(clustered)  # no duplicates

    def area(corners: np.ndarray) -> float:
        triangles = vertices[corners]
        return (
            0.5
            * np.linalg.norm(
                np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]), axis=1
            ).sum()
        )

    # The square keeps most of its area: clustering moves a vertex by less than a cell.
    assert area(clustered) == pytest.approx(area(faces), rel=0.5)


def test_a_cell_must_be_positive() -> None:
    vertices, faces = grid_mesh(3)
    with pytest.raises(ValueError, match="must be positive"):
        cluster_faces(vertices, faces, cell=0.0)


def test_the_model_is_restored_exactly_after_the_block() -> None:
    mujoco = pytest.importorskip("mujoco")
    vertices, faces = grid_mesh(21)
    spec = mujoco.MjSpec()
    mesh = spec.add_mesh(name="sheet")
    mesh.uservert = vertices.ravel().tolist()
    mesh.userface = faces.ravel().tolist()
    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # a flat sheet has no volume
    body = spec.worldbody.add_body(name="sheet")
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname="sheet", contype=0, conaffinity=0)
    model = spec.compile()
    before = {name: getattr(model, name).copy() for name in ("mesh_face", "mesh_facenormal", "mesh_facenum")}
    with coarse_meshes(model, cell=0.03):
        assert model.mesh_facenum[0] < before["mesh_facenum"][0]
    for name, values in before.items():
        assert np.array_equal(getattr(model, name), values), name
