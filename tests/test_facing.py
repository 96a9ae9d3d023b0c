"""Which way a wall patch faces when no floor or ceiling is part of it
(:func:`meshplan.orient.facing.inward_flips`): the side where its story's floor runs up to it,
read from the floor's triangles, not their centroids alone (a decimated or coarse scan's floor
triangles are 25 cm or larger, and their centroids leave most of the raster empty)."""

from __future__ import annotations

import numpy as np
import pytest

from meshplan.geometry import Mesh
from meshplan.orient.facing import inward_flips
from meshplan.orient.stories import Story


def _quad(x0, x1, z0, z1, y, n_x: int, n_z: int, up: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """A floor rectangle at height ``y`` in ``n_x`` by ``n_z`` cells, two triangles each,
    facing up."""
    xs, zs = np.linspace(x0, x1, n_x + 1), np.linspace(z0, z1, n_z + 1)
    gx, gz = np.meshgrid(xs, zs, indexing="ij")
    v = np.c_[gx.ravel(), np.full(gx.size, y), gz.ravel()]
    idx = np.arange(gx.size).reshape(gx.shape)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    f = np.r_[np.c_[a, c, b], np.c_[a, d, c]] if up else np.r_[np.c_[a, b, c], np.c_[a, c, d]]
    return v, f


def _wall(x: float, z0: float, z1: float, facing: float, n: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A wall patch in the plane x = ``x`` from the floor to 1.5 m, facing ``facing`` (+1: +x)."""
    zs, ys = np.linspace(z0, z1, n + 1), np.linspace(0.05, 1.5, 4)
    gz, gy = np.meshgrid(zs, ys, indexing="ij")
    v = np.c_[np.full(gz.size, x), gy.ravel(), gz.ravel()]
    idx = np.arange(gz.size).reshape(gz.shape)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    f = np.r_[np.c_[a, b, c], np.c_[a, c, d]]  # (b - a) x (c - a) points to -x
    if facing > 0:
        f = f[:, ::-1]
    return v, f


def _mesh(parts) -> Mesh:
    return Mesh.concatenate([Mesh(v, f) for v, f in parts])


@pytest.mark.parametrize("scanned", [1.0, -1.0])
def test_a_partitions_patch_faces_the_room_whose_coarse_floor_runs_up_to_it(scanned):
    """Room A (x < 0) has a coarse floor (2 triangles), room B (x > 0.12) a fine one; the
    partition's face at x = 0, a patch of its own, faces A. Read from centroids, A's floor is
    nowhere near the wall and B's is right behind it: the patch was turned to face B."""
    floor_a = _quad(-4.0, -0.02, 0.0, 4.0, 0.0, 1, 1)
    floor_b = _quad(0.14, 4.0, 0.0, 4.0, 0.0, 40, 40)
    wall = _wall(0.0, 0.5, 3.5, facing=scanned)  # wound either way
    mesh = _mesh([floor_a, floor_b, wall])
    normals, centroids = mesh.face_normals, mesh.face_centroids
    story = Story(0, 0.0, 2.5, False, -1.0, 3.0)
    flips = inward_flips(mesh, normals, centroids, centroids[:, 1], (story,))
    wall_faces = np.arange(len(floor_a[1]) + len(floor_b[1]), mesh.n_faces)
    turned = np.where(flips[wall_faces, None], -normals[wall_faces], normals[wall_faces])
    assert np.all(turned[:, 0] < -0.9), "the wall must face room A (-x)"
    assert not flips[: len(floor_a[1]) + len(floor_b[1])].any()
