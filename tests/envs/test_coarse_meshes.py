"""Coarse meshes for drawing: vertex clustering keeps the shape, draws fewer triangles, and leaves the
model (and so the physics) exactly as it was."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_ivmc.envs.coarse_meshes import cluster_faces, coarse_meshes, normals


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
    assert np.all(normals(vertices, clustered)[:, 2] > 0)  # every face still faces up

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


def test_both_sides_of_a_double_sided_sheet_are_kept() -> None:
    """MuJoCo culls back faces: a thin part is drawn from both sides only if both windings survive."""
    vertices, faces = grid_mesh(41)
    both_sides = np.concatenate([faces, faces[:, ::-1]])
    _, clustered = cluster_faces(vertices, both_sides, cell=0.02)
    facing = np.sign(normals(vertices, clustered)[:, 2])
    assert (facing > 0).sum() == (facing < 0).sum() > 0


def test_a_face_that_clustering_turns_over_is_dropped() -> None:
    # A sliver whose apex shares a 2 cm cell with a vertex across its base: snapped there, it faces down.
    vertices = np.array([[0.0, 0.01, 0.0], [0.05, 0.01, 0.0], [0.025, 0.002, 0.0], [0.025, 0.014, 0.0]])
    sliver = np.array([[0, 1, 3]])  # faces up
    assert normals(vertices, sliver)[0, 2] > 0
    kept, _ = cluster_faces(vertices, sliver, cell=0.02)
    assert len(kept) == 0
    kept, _ = cluster_faces(vertices, sliver, cell=0.001)  # a fine cell moves nothing
    assert kept.tolist() == [0]


def test_a_cell_must_be_positive() -> None:
    vertices, faces = grid_mesh(3)
    with pytest.raises(ValueError, match="must be positive"):
        cluster_faces(vertices, faces, cell=0.0)


def test_the_model_is_restored_exactly_after_the_block() -> None:
    mujoco = pytest.importorskip("mujoco")
    spec = mujoco.MjSpec()
    for name, points in (("coarse", 5), ("fine", 21)):  # the second mesh's indices start past the first's
        vertices, faces = grid_mesh(points)
        mesh = spec.add_mesh(name=name)
        mesh.uservert = vertices.ravel().tolist()
        mesh.userface = faces.ravel().tolist()
        mesh.usertexcoord = vertices[:, :2].ravel().tolist()
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # a flat sheet has no volume
        body = spec.worldbody.add_body(name=name)
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, contype=0, conaffinity=0)
    model = spec.compile()
    arrays = ("mesh_face", "mesh_facenormal", "mesh_facetexcoord", "mesh_facenum")
    before = {name: getattr(model, name).copy() for name in arrays}
    with coarse_meshes(model, cell=0.03):
        assert model.mesh_facenum[1] < before["mesh_facenum"][1]
        fine = slice(model.mesh_faceadr[1], model.mesh_faceadr[1] + model.mesh_facenum[1])
        assert model.mesh_face[fine].max() < model.mesh_vertnum[1]  # indices stay the mesh's own
    for name, values in before.items():
        assert np.array_equal(getattr(model, name), values), name
