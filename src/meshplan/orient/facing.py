"""Making the normals face into the rooms.

Scans disagree on winding: some face their normals into the room, some out of it, some mix
both from one connected patch to the next. With the levels known, winding can be read from the
floors (whose normals must point up) and the ceilings (down). Each connected component of the
mesh is flipped when its floor and ceiling faces say it faces out; a component without floor or
ceiling faces follows the majority of the mesh.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..geometry import FloatArray, IntArray, Mesh
from .stories import Story


def face_components(faces: IntArray, n_vertices: int) -> IntArray:
    """Connected component of every face (faces sharing a vertex are connected)."""
    if not len(faces):
        return np.zeros(0, dtype=np.int64)
    rows = np.r_[faces[:, 0], faces[:, 1]]
    cols = np.r_[faces[:, 1], faces[:, 2]]
    graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n_vertices, n_vertices))
    _, labels = connected_components(graph, directed=False)
    return labels[faces[:, 0]].astype(np.int64)


def inward_flips(mesh: Mesh, normals_y: FloatArray, heights: FloatArray, stories: tuple[Story, ...], tolerance_m: float = 0.1) -> np.ndarray:
    """Boolean mask of the faces whose winding should be reversed to face into the rooms.

    Parameters
    ----------
    mesh
        The mesh (only its connectivity is used).
    normals_y, heights
        Up component of the face normals and centroid heights, in the levelled frame.
    stories
        Floors and ceilings found.
    """
    areas = mesh.face_areas
    vote = np.zeros(mesh.n_faces)
    horiz = np.abs(normals_y) > np.cos(np.radians(20.0))
    for s in stories:
        near_floor = horiz & (np.abs(heights - s.floor) < tolerance_m)
        vote[near_floor] += areas[near_floor] * np.sign(normals_y[near_floor])
        if s.ceiling_found:
            near_ceiling = horiz & (np.abs(heights - s.ceiling) < tolerance_m)
            vote[near_ceiling] -= areas[near_ceiling] * np.sign(normals_y[near_ceiling])
    comp = face_components(mesh.faces, mesh.n_vertices)
    per = np.bincount(comp, weights=vote)
    majority_out = vote.sum() < 0
    flip_comp = (per < 0) | ((per == 0) & majority_out)
    return flip_comp[comp]
